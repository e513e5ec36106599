"""The observables, declared once.

Every quantity the analysis stores per run (``analysis.h5``) or the aggregate writes to
the phase-diagram dataset is one :class:`Observable` row of :data:`OBSERVABLES`: its
kind, CF long name and units, whether it is reduced over replicates and whether
``run.until.rel_error`` may target it.  From this table come the scalars the analysis
writes (:data:`RUN_SCALARS`), the curves and their coordinates (:data:`CURVES`), the
NetCDF variables and their attributes (:mod:`fcsweep.results.aggregate`) and the
``run.until`` observables the config accepts (:data:`UNTIL_OBSERVABLES`).  Lengths are in
units of R0, times in the model's time unit; both are reduced, hence CF units "1"
(``long_name`` says which); strings carry no units.

Kinds: ``run`` a per-run number (an ``analysis.h5`` scalar and a dataset variable),
``label`` a per-run label (its flag code: a float in ``analysis.h5``, int8 in the dataset),
``curve`` a per-run curve on the coordinate ``axis``, ``text`` a per-run string, ``code``
a per-run reason code beside a label's reason text (:mod:`fcsweep.analysis.reasons`: an int8
HDF5 enum in ``analysis.h5``, int8 with CF flags in the dataset),
``coord`` a coordinate of the curves (or ``replicate``), ``dataset`` what the aggregate
computes itself (run status, per-point labels and fits).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Observable", "OBSERVABLES", "RUN_SCALARS", "LABELS", "CURVES", "TEXTS", "REPLICATE_REDUCED",
           "UNTIL_OBSERVABLES", "KINDS", "REASONS", "REASON_CODES", "KTHNY_FITS", "group"]

KINDS = ("run", "label", "curve", "text", "coord", "dataset", "code")


@dataclass(frozen=True)
class Observable:
    """One stored observable.

    Attributes
    ----------
    name : str
        Attribute / variable name.
    kind : str
        One of :data:`KINDS`.
    long_name : str
        CF long name (what it is, and its unit in words where it has one).
    units : str
        CF units: "1" (reduced, dimensionless numbers) or "" (strings, bounds).
    axis : str
        The coordinate of a curve.
    replicate : bool
        Reduced over replicates by the aggregate (``<name>_rmean``, ``_rmean_err``, ``_rchi2``).
    until : bool
        ``run.until.rel_error`` may target it (it carries a 1-sigma error ``<name>_err``).
    group : str
        The fit it comes from, where one fit gives several: ``kthny`` (the KTHNY fits of one
        run), ``fss`` and ``fss_shuffled`` (the finite-size collapses of the aggregate).
    """

    name: str
    kind: str
    long_name: str
    units: str = "1"
    axis: str = ""
    replicate: bool = False
    until: bool = False
    group: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"observable {self.name}: kind {self.kind!r} not in {KINDS}")


_O = Observable

#: Every observable, in the order the dataset holds them.
OBSERVABLES: dict[str, Observable] = {o.name: o for o in (
    _O("D_eff", "run", "effective diffusion D_s / D0, D0 = v0^2 / (2 Dr)", replicate=True, until=True),
    _O("D_eff_err", "run", "1-sigma error of D_eff: the cell error, or the larger of it and the time-block error "
                           "with 4 or more time blocks"),
    _O("D_eff_err_time", "run", "error of D_eff from the scatter of time blocks"),
    _O("D_eff_err_cells", "run", "error of D_eff from the scatter of the cells' own MSD slopes, counted with the "
                                 "spatial inefficiency D_eff_g_cells"),
    _O("D_eff_late", "run", "D_eff from the upper half of the MSD fit window (settling check)"),
    _O("D_eff_late_err", "run", "1-sigma error of D_eff_late"),
    _O("D_eff_long", "run", "D_eff at another block length: the whole run, or half blocks (settling check; the "
                            "solid test without D_eff_cr)", replicate=True),
    _O("D_eff_long_err", "run", "1-sigma error of D_eff_long"),
    _O("msd_diffusive", "run", "1 if the MSD slope has settled within the run, else 0"),
    _O("msd_long_enough", "run", "1 if a time block spans at least min_block_persistence / Dr, else 0"),
    _O("n_time_blocks", "run", "number of time blocks of the D_eff estimate"),
    _O("block_span", "run", "length of one time block of the D_eff estimate (time units)"),
    _O("D_s", "run", "long-time self-diffusion coefficient (R0^2 per time unit)", until=True),
    _O("D_s_err", "run", "1-sigma error of D_s"),
    _O("D0", "run", "free active diffusion v0^2 / (2 Dr) (R0^2 per time unit)"),
    _O("fit_t_min", "run", "start of the MSD fit window (time units)"),
    _O("fit_t_max", "run", "end of the MSD fit window (time units)"),
    _O("q_mean", "run", "mean shape index <q> over cells and analysed frames", replicate=True, until=True),
    _O("q_mean_err", "run", "1-sigma error of q_mean (autocorrelation of the frame series)"),
    _O("q_std", "run", "standard deviation of the shape index"),
    _O("q_frac_above", "run", "fraction of cells with q > 3.81", replicate=True, until=True),
    _O("q_frac_above_err", "run", "1-sigma error of q_frac_above"),
    _O("rho_d", "run", "defect fraction: cells with != 6 Voronoi neighbours / N", replicate=True, until=True),
    _O("rho_d_err", "run", "1-sigma error of rho_d (autocorrelation of the frame series)"),
    _O("largest_cluster_fraction", "run", "largest defect cluster size / N, frame average", replicate=True, until=True),
    _O("largest_cluster_fraction_err", "run", "1-sigma error of largest_cluster_fraction"),
    _O("largest_cluster_fraction_shuffled", "run", "largest defect cluster size / N with the defect labels "
                                                   "permuted at random over the cells of each frame's Voronoi graph "
                                                   "(same rho_d and graph, label correlations destroyed), frame "
                                                   "average",
       replicate=True),
    _O("largest_cluster_fraction_shuffled_err", "run", "1-sigma error of largest_cluster_fraction_shuffled"),
    _O("psi6", "run", "global hexatic order |Psi6| = |<psi6_i>|, frame average", replicate=True, until=True),
    _O("psi6_err", "run", "1-sigma error of psi6 (autocorrelation of the frame series)"),
    _O("n_frames", "run", "frames after the transient used for the MSD"),
    _O("t_start", "run", "time of the first analysed frame"),
    _O("t_end", "run", "time of the last analysed frame"),
    _O("t_equilibrated", "run", "start of the frames used for D_eff after equilibration detection"),
    _O("equilibration_at_limit", "run", "1 if the equilibration cut reached its limit (half the frames after the "
                                        "transient): a series still drifts there and no label is decided on the "
                                        "window; else 0"),
    _O("phase_confidence", "run", "probability of the most probable phase given the errors"),
    _O("percolated_confidence", "run", "probability of the most probable percolation label"),
    _O("q_bias_low", "run", "smallest measured systematic offset of <q> for the run's contour rule and dt "
                            "(fcsweep.model.systematics; -inf: not measured)"),
    _O("q_bias_high", "run", "largest measured systematic offset of <q> for the run's contour rule and dt"),
    _O("d_bias_low", "run", "smallest measured relative systematic offset of D for the run's contour rule and dt"),
    _O("d_bias_high", "run", "largest measured relative systematic offset of D for the run's contour rule and dt"),
    _O("solid_kind", "run", "kind of a solid: 0 crystal (|Psi6| > 0.7 and rho_d < 0.02), 1 amorphous, 2 undetermined, "
                            "-1 not a solid"),
    _O("solid_kind_confidence", "run", "probability of solid_kind given the errors of psi6 and rho_d"),
    _O("D_eff_g_cells", "run", "spatial statistical inefficiency of the squared displacements: N / g cells move "
                               "independently"),
    _O("neighbour_spacing", "run", "neighbour spacing a of a triangular lattice at the cells' density (units of R0)"),
    _O("cage_lag", "run", "lag of the cage-breaking test: the whole analysed window (time units)"),
    _O("cage_msd_ratio", "run", "cage-relative mean squared displacement at cage_lag over a^2 (> 1: cages broken)",
       replicate=True),
    _O("cage_msd_ratio_err", "run", "1-sigma error of cage_msd_ratio (spatially contiguous cell blocks)"),
    _O("cage_broken_probability", "run", "probability that cage_msd_ratio > 1"),
    _O("cage_d_eff_bound", "run", "D_eff a broken cage stands for: a^2 / (4 cage_lag D0) (information only; no "
                                  "label reads it)"),
    _O("F_s_window", "run", "self-intermediate scattering function of cage-relative displacements at k = 2 pi / a "
                            "and the lag cage_lag"),
    _O("relaxation_lag", "run", "lag by which a state at D_eff = 1e-3 would at the earliest relax: "
                                "a^2 / (4 pi^2 1e-3 D0 (1 + <1/n>)), Gaussian cage-relative displacements"),
    _O("F_s_bound", "run", "cage-relative F_s(2 pi / a) at relaxation_lag (NaN: beyond the window): below 1/e "
                           "the phase rule reads not solid"),
    _O("F_s_bound_err", "run", "1-sigma error of F_s_bound over 16 spatial blocks"),
    _O("tau_alpha", "run", "structural relaxation time: lag where F_s first falls below 1/e (time units; NaN: not "
                           "within the window)"),
    _O("D_eff_cr", "run", "cage-relative D_eff: a quarter of the late slope of the cage-relative MSD over D0 (the "
                          "solid test where the cages did not break)", replicate=True),
    _O("D_eff_cr_err", "run", "1-sigma error of D_eff_cr (spatially contiguous cell blocks)"),
    _O("D_eff_cr_late", "run", "D_eff past the cage breaking: a quarter of the slope of the cage-relative MSD over "
                               "the lags >= cage_lag, over D0 (1 + <1/n>) (n: Voronoi neighbours); NaN where the "
                               "cages did not break (the fluid rule)", replicate=True),
    _O("D_eff_cr_late_err", "run", "1-sigma error of D_eff_cr_late (spatially contiguous cell blocks)"),
    _O("eta_G1", "run", "first-shell translational exponent: algebraic decay of C_G1(r) (the KTHNY solid bound "
                        "1/3 applies to it)", group="kthny"),
    _O("eta_G1_err", "run", "1-sigma error of eta_G1: statistical and the spread over fit ranges in quadrature",
       group="kthny"),
    _O("eta_T", "run", "algebraic decay exponent of the G_r(dx, 0) - 1 peak envelope (all Bragg shells: steeper "
                       "than eta_G1)", group="kthny"),
    _O("eta_T_err", "run", "1-sigma error of eta_T: statistical and the spread over fit ranges in quadrature",
       group="kthny"),
    _O("xi_T", "run", "exponential decay length of the G_r(dx, 0) - 1 peak envelope (units of R0)", group="kthny"),
    _O("xi_T_err", "run", "1-sigma error of xi_T", group="kthny"),
    _O("eta_6", "run", "algebraic decay exponent of G6(r)", group="kthny"),
    _O("eta_6_err", "run", "1-sigma error of eta_6: statistical and the spread over fit ranges in quadrature",
       group="kthny"),
    _O("xi_6", "run", "exponential decay length of G6(r) (units of R0)", group="kthny"),
    _O("xi_6_err", "run", "1-sigma error of xi_6", group="kthny"),
    _O("kthny_confidence", "run", "probability of the KTHNY label given the fit errors"),
    _O("msd_bounded", "run", "1 for a confined run (well or channel): the whole-cell MSD is bounded by the walls "
                             "and D_eff decides no phase (the cage rule must), else 0"),
    _O("n_counted_cells", "run", "cells the defect, cluster and |Psi6| statistics count, frame average: N in a "
                                 "periodic box; in a well or channel the cells with certain Voronoi sides at least "
                                 "2a from the walls"),
    _O("area_fraction", "run", "area fraction of a confined run: sum of pi R0,i^2 over the area inside the walls "
                               "(NaN in a periodic box: the density parameter)"),
    _O("wall_pressure", "run", "pressure on the wall: inward-normal wall forces summed over the cells per unit wall "
                               "length, mean over the equilibrated frames (dimensionless: the wall energy is the "
                               "cells' area beyond the wall; NaN in a periodic box)", replicate=True),
    _O("wall_pressure_err", "run", "1-sigma error of wall_pressure (autocorrelation of the frame series)"),
    _O("crystal_fraction", "run", "fraction of crystalline cells (six Voronoi neighbours, each with Re(psi6_i "
                                  "psi6_j*) >= 1/2), mean over the structure frames of a coexistence start (NaN for "
                                  "other starts)"),
    _O("crystal_fraction_err", "run", "1-sigma error of crystal_fraction (autocorrelation of the frame series)"),
    _O("crystal_speed", "run", "interface speed (Ly / 2) d(crystal_fraction)/dt of a coexistence start, R0 per time "
                               "unit (> 0: the crystal grows; NaN where an end state, melted or filled, decided)"),
    _O("crystal_speed_err", "run", "1-sigma error of crystal_speed (correlated frames)"),
    _O("phase_coexistence", "run", "label of a coexistence start from its crystal (fcsweep.analysis.crystal): 0 solid "
                                   "(the crystal grows, stays or filled the box), 1 not solid (it melts or melted), "
                                   "2 undetermined, -1 unknown; NaN for other starts"),
    _O("phase_coexistence_confidence", "run", "probability of phase_coexistence (NaN when too few frames or "
                                              "effective samples decide nothing)"),
    _O("replicate", "coord", "replicate index (independent noise)"),
    _O("lag_time", "coord", "MSD lag time (model time units)"),
    _O("r", "coord", "pair distance, bin centre (units of R0)"),
    _O("dx", "coord", "pair separation along the mean hexatic axis, bin centre (units of R0)"),
    _O("q_bin", "coord", "shape index q, bin centre"),
    _O("q_bin_bounds", "coord", "shape index q, bin edges (CF bounds: units inherited from q_bin)", units=""),
    _O("cluster_size", "coord", "defect cluster size (cells)"),
    _O("cage_lag_time", "coord", "lag time of the cage-relative curves F_s and cage_msd (time units)"),
    _O("F_s", "curve", "self-intermediate scattering function F_s(2 pi / a, t) of cage-relative displacements",
       axis="cage_lag_time"),
    _O("cage_msd", "curve", "cage-relative mean squared displacement (R0^2)", axis="cage_lag_time"),
    _O("q_hist", "curve", "probability density of the shape index", axis="q_bin"),
    _O("cluster_size_distribution", "curve", "number of defect clusters of each size, pooled over the "
                                             "n_structure_frames analysed frames", axis="cluster_size"),
    _O("msd", "curve", "drift-subtracted mean squared displacement (R0^2)", axis="lag_time"),
    _O("G6", "curve", "bond-orientational correlation Re <psi6_i psi6_j*>(r)", axis="r"),
    _O("Gr", "curve", "translational correlation G_r(dx, 0) along the mean hexatic axis, ideal gas = 1", axis="dx"),
    _O("C_G1", "curve", "first-shell translational correlation Re <psi_G,i psi_G,j*>(r), psi_G,i = exp(i G . r_i), "
                        "mean over the first-shell reciprocal vectors G", axis="r"),
    _O("phase", "label", "phase label: solid if D_eff < 1e-3, else soft fluid if <q> > 3.81, else fluid; with "
                         "broken cages D_eff_cr_late decides, without them only a trustworthy D_eff_cr < 1e-3 "
                         "(solid); undetermined below the required confidence"),
    _O("phase_reason", "text", "why the phase label is what it is", units=""),
    _O("phase_reason_code", "code", "reason code of the phase label (what decided it, or why nothing did)"),
    _O("percolated", "label", "defect percolation label: rho_d > percolation_threshold (default 1/2); undetermined "
                              "below the required confidence"),
    _O("kthny", "label", "KTHNY label from the decay of C_G1(r) and G6(r): solid (C_G1 algebraic, eta_G1 <= 1/3), "
                         "hexatic (C_G1 decaying faster, G6 algebraic with eta_6 <= 1/4), liquid (G6 decaying "
                         "faster)"),
    _O("kthny_reason", "text", "why the KTHNY label is what it is", units=""),
    _O("kthny_reason_code", "code", "reason code of the KTHNY label (what decided it, or why nothing did)"),
    _O("kthny_point", "dataset", "KTHNY label common to the replicates (undetermined when they differ)"),
    _O("kthny_point_confidence", "dataset", "lowest replicate confidence of kthny_point"),
    _O("percolated_reason", "text", "why the percolation label is what it is", units=""),
    _O("percolated_reason_code", "code", "reason code of the percolation label (what decided it, or why nothing did)"),
    _O("phase_point", "dataset", "phase label of the grid point: the phase rule on the replicate means (errors "
                                 "inflated by their scatter); with both starts, their common label"),
    _O("phase_point_confidence", "dataset", "probability of phase_point given the replicate-mean errors (both "
                                            "starts: the smaller)"),
    _O("percolated_point", "dataset", "percolation label of the replicate mean of rho_d (both starts: their common "
                                      "label)"),
    _O("percolated_point_confidence", "dataset", "probability of percolated_point"),
    _O("phase_start", "dataset", "phase label of each start (dimension initial): the phase rule on its replicate "
                                 "means"),
    _O("phase_start_confidence", "dataset", "probability of phase_start"),
    _O("solid_kind_start", "dataset", "kind of a solid phase_start (dimension initial; replicate means of psi6 and "
                                      "rho_d): 0 crystal, 1 amorphous, 2 undetermined, -1 not a solid"),
    _O("solid_kind_point", "dataset", "kind of a solid phase_point common to the starts: 0 crystal, 1 amorphous, 2 "
                                      "undetermined (the starts' kinds differ or one is undetermined), -1 not a solid"),
    _O("percolated_start", "dataset", "percolation label of each start (dimension initial)"),
    _O("percolated_start_confidence", "dataset", "probability of percolated_start"),
    _O("kthny_start", "dataset", "KTHNY label common to the replicates of each start (dimension initial)"),
    _O("kthny_start_confidence", "dataset", "lowest replicate confidence of kthny_start"),
    _O("phase_point_reason_code", "dataset", "reason code of phase_point"),
    _O("percolated_point_reason_code", "dataset", "reason code of percolated_point"),
    _O("kthny_point_reason_code", "dataset", "reason code of kthny_point (replicates_disagree where the replicates "
                                             "differ)"),
    _O("phase_start_reason_code", "dataset", "reason code of phase_start"),
    _O("percolated_start_reason_code", "dataset", "reason code of percolated_start"),
    _O("kthny_start_reason_code", "dataset", "reason code of kthny_start"),
    _O("phase_hysteresis", "dataset", "whether the starts' phase labels agree: agree, disagree, one_sided (one "
                                      "start decided or present), unknown"),
    _O("seed", "text", "random seed of the run (decimal string)", units=""),
    _O("tau_fisher", "dataset", "Fisher exponent of the defect cluster sizes (replicates pooled; critical 187/91)"),
    _O("tau_fisher_err", "dataset", "1-sigma error of tau_fisher"),
    _O("tau_fisher_reason", "text", "why tau_fisher is undetermined or flagged (empty: a usable fit)", units=""),
    _O("fss_rho_c", "dataset", "percolation threshold of rho_d from the finite-size collapse of "
                               "largest_cluster_fraction over N and eta (critical 1/2)", group="fss"),
    _O("fss_rho_c_err", "dataset", "1-sigma bootstrap error of fss_rho_c", group="fss"),
    _O("fss_nu", "dataset", "correlation-length exponent nu of the finite-size collapse (critical 4/3)", group="fss"),
    _O("fss_nu_err", "dataset", "1-sigma bootstrap error of fss_nu", group="fss"),
    _O("fss_beta", "dataset", "order-parameter exponent beta of the finite-size collapse (critical 5/36)", group="fss"),
    _O("fss_beta_err", "dataset", "1-sigma bootstrap error of fss_beta", group="fss"),
    _O("fss_quality", "dataset", "collapse quality S at the fit (~1: the sizes collapse within their errors)",
       group="fss"),
    _O("fss_reason", "text", "why the finite-size collapse is undetermined or flagged (empty: a usable fit)", units=""),
    _O("fss_shuffled_rho_c", "dataset", "percolation threshold of rho_d from the finite-size collapse of "
                                        "largest_cluster_fraction_shuffled (labels permuted: random site "
                                        "percolation on the cells' graph, critical 1/2); fss_rho_c - "
                                        "fss_shuffled_rho_c is the shift caused by defect correlations",
       group="fss_shuffled"),
    _O("fss_shuffled_rho_c_err", "dataset", "1-sigma bootstrap error of fss_shuffled_rho_c", group="fss_shuffled"),
    _O("fss_shuffled_nu", "dataset", "correlation-length exponent nu of the shuffled-label collapse (critical 4/3)",
       group="fss_shuffled"),
    _O("fss_shuffled_nu_err", "dataset", "1-sigma bootstrap error of fss_shuffled_nu", group="fss_shuffled"),
    _O("fss_shuffled_beta", "dataset", "order-parameter exponent beta of the shuffled-label collapse (critical 5/36)",
       group="fss_shuffled"),
    _O("fss_shuffled_beta_err", "dataset", "1-sigma bootstrap error of fss_shuffled_beta", group="fss_shuffled"),
    _O("fss_shuffled_quality", "dataset", "collapse quality S of the shuffled-label collapse (~1: the sizes "
                                          "collapse within their errors)", group="fss_shuffled"),
    _O("fss_shuffled_reason", "text", "why the shuffled-label finite-size collapse is undetermined or flagged "
                                      "(empty: a usable fit)", units=""),
    _O("status", "dataset", "status of the run: a done run by its analysis (analysed, not_analysed, analysis_failed), "
                            "any other by its state (failed, running, pending, interrupted, corrupt); missing where "
                            "no run is"),
    _O("n_structure_frames", "dataset", "frames used for Voronoi, defect and order statistics"),
    _O("run_id", "text", "run identifier (directory name under runs/)", units=""),
)}


def _names(kind: str) -> tuple[str, ...]:
    return tuple(name for name, o in OBSERVABLES.items() if o.kind == kind)


#: Per-run numbers: attributes of ``/observables`` in analysis.h5 and dataset variables.
RUN_SCALARS = _names("run")
#: Per-run labels, stored as their flag codes.
LABELS = _names("label")
#: Per-run strings.
TEXTS = _names("text")
#: Per-run reason codes of the labels (``<label>_reason_code``).
REASON_CODES = _names("code")
#: Curves: name -> the name of their coordinate.
CURVES = {name: o.axis for name, o in OBSERVABLES.items() if o.kind == "curve"}
#: Observables reduced over replicates.
REPLICATE_REDUCED = tuple(name for name, o in OBSERVABLES.items() if o.replicate)
#: Label explanations of a run (``<label>_reason``), strings beside the labels.
REASONS = tuple(f"{label}_reason" for label in LABELS)


def group(name: str) -> tuple[str, ...]:
    """The observables of one fit (:attr:`Observable.group`), in table order."""
    return tuple(n for n, o in OBSERVABLES.items() if o.group == name)


#: KTHNY fit results of one run (:func:`fcsweep.analysis.kthny.kthny_fits`).
KTHNY_FITS = group("kthny")
#: Observables ``run.until.rel_error`` may target.
UNTIL_OBSERVABLES = tuple(name for name, o in OBSERVABLES.items() if o.until)


def markdown_table() -> str:
    """The variable table of results_schema.md: every observable with its kind, CF units and
    long name (curves with their coordinate).

    Returns
    -------
    str
        Markdown, one row per observable, ending with a newline.
    """
    rows = ["| variable | kind | units | long_name |", "|---|---|---|---|"]
    for name, o in OBSERVABLES.items():
        kind = f"curve (+`{o.axis}`)" if o.kind == "curve" else o.kind
        flags = "".join((", replicate-reduced" if o.replicate else "", ", `run.until`" if o.until else ""))
        long_name = o.long_name.replace("|", "\\|")
        rows.append(f"| `{name}` | {kind}{flags} | {o.units or '—'} | {long_name} |")
    return "\n".join(rows) + "\n"
