"""Reason codes of the labels, declared once: a short machine-readable word beside each
label's free-text reason.

Every :class:`fcsweep.analysis.phase.Label` carries ``reason_code``, one ``name`` of
:data:`REASONS`; its integer ``code`` is what is stored (``<label>_reason_code``: an int8
HDF5 enum in ``analysis.h5``, an int8 variable with CF ``flag_values`` /
``flag_meanings`` in the phase-diagram dataset). A code means the same in every label;
each label family (``phase``, ``percolated``, ``kthny``; their run, start and point
variables) declares the codes it can carry (:func:`reason_flags`). ``short`` is the
two or three words a figure writes beside an undetermined point.

Code 0, ``not_recorded``, is what a dataset holds for an analysis written before the
codes existed (its reason text is all there is); ``not_analysed`` is a run without a
usable analysis (its ``status`` says why).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Reason", "REASONS", "REASON_BY_NAME", "REASON_BY_CODE", "FAMILIES", "reason_value", "reason_name",
           "reason_flags", "reason_short"]

#: Label families that carry reason codes.
FAMILIES = ("phase", "percolated", "kthny")
_ALL = FAMILIES


@dataclass(frozen=True)
class Reason:
    """One reason code.

    Attributes
    ----------
    code : int
        Stored value (int8).
    name : str
        Short machine-readable word (a CF ``flag_meanings`` entry: no blanks).
    meaning : str
        What it says.
    labels : tuple of str
        The label families (:data:`FAMILIES`) that can carry it.
    short : str
        Words a figure writes for it ("" for a decided label: nothing to explain).
    """

    code: int
    name: str
    meaning: str
    labels: tuple
    short: str = ""


_R = Reason
#: Every reason code, in code order.
REASONS = (
    _R(0, "not_recorded", "no reason code stored (analysis written before the codes); read the reason text",
       _ALL),
    _R(1, "not_analysed", "the run has no usable analysis (its status says why)", _ALL, "no data"),
    _R(2, "no_analysed_run", "no replicate of the point was analysed", _ALL, "no data"),
    _R(3, "not_available", "an input of the label (D_eff, <q>, rho_d) is NaN", _ALL, "no data"),
    _R(4, "no_error", "an input of the label has no error estimate", _ALL, "no error"),
    _R(5, "too_short", "run too short for D_eff (a time block shorter than min_block_persistence / Dr)",
       ("phase",), "too short"),
    _R(6, "not_diffusive", "D_eff not trustworthy: the MSD is not diffusive within the run", ("phase",),
       "not settled"),
    _R(7, "fluid_cages_intact", "D_eff reads fluid but nothing shows that the cells left their cages",
       ("phase",), "D_eff fluid, cage not broken"),
    _R(8, "near_d_threshold", "D_eff (or D_eff_cr_late) too close to the solid threshold 1e-3", ("phase",),
       "near threshold"),
    _R(9, "cages_may_be_broken", "D_eff reads solid but the cages may be broken", ("phase",),
       "cage may be broken"),
    _R(10, "few_late_lags", "cages broken but too few lags past the breaking for D_eff_cr_late", ("phase",),
       "few lags past breaking"),
    _R(11, "near_q_star", "<q> too close to 3.81", ("phase",), "<q> near 3.81"),
    _R(12, "solid_cages_intact", "solid: a trustworthy D_eff_cr below 1e-3 and the cages not broken",
       ("phase",)),
    _R(13, "decided_cages_broken", "cages broken: D_eff_cr_late decides solid, <q> fluid against soft fluid",
       ("phase",)),
    _R(14, "decided_d_eff", "the plain D_eff test (no cage test) and <q> decide", ("phase",)),
    _R(15, "decided_q_no_d_eff", "cages broken without D_eff (a movie): not solid, <q> decides", ("phase",)),
    _R(16, "cages_intact_no_d_eff", "cages not broken and no D_eff (a movie): solid cannot be decided",
       ("phase",), "cage not broken"),
    _R(17, "msd_bounded", "confined run (a well or a channel): the whole-cell MSD is bounded by the walls, so "
                          "D_eff decides nothing; without a cage-relative D_eff_cr solid cannot be decided",
       ("phase",), "MSD bounded by walls"),
    _R(18, "not_stationary", "the equilibration cut reached its limit (half the frames after the transient): <q> "
                             "or rho_d still drifts there, so no label is decided on the window",
       ("phase", "percolated"), "not stationary"),
    _R(19, "rule_sensitive", "the label depends on the contour rule's or the step's measured systematic offset of "
                             "<q> or D (fcsweep.model.systematics): corrected by it, the deciding estimate "
                             "lies on both sides of its threshold", ("phase",), "rule-sensitive"),
    _R(20, "near_rho_threshold", "rho_d too close to the percolation threshold", ("percolated",),
       "rho_d near 1/2"),
    _R(21, "decided_rho_d", "rho_d with its error decides", ("percolated",)),
    _R(22, "decided_relaxed", "not solid: the cage-relative F_s(2 pi / a) fell below 1/e faster than a state at "
                              "D_eff = 1e-3 can, before the cages broke by a^2; <q> decides fluid against soft fluid",
       ("phase",)),
    _R(30, "not_computed", "correlations G6, G_r, C_G1 not computed", ("kthny",), "no data"),
    _R(31, "too_few_cells", "too few cells for C_G1 and G6 over half a box", ("kthny",), "too few cells"),
    _R(32, "g6_not_fitted", "G6 could not be fitted", ("kthny",), "G6 not fitted"),
    _R(33, "g6_noise_untestable", "G6 fell into its noise with too few points to test its bound", ("kthny",),
       "G6 in noise"),
    _R(34, "cg1_not_computed", "C_G1 not computed: the translational order cannot be decided", ("kthny",),
       "no C_G1"),
    _R(35, "cg1_noise_untestable", "C_G1 fell into its noise with too few points to test its bound", ("kthny",),
       "C_G1 in noise"),
    _R(36, "cg1_not_fitted", "C_G1 could not be fitted", ("kthny",), "C_G1 not fitted"),
    _R(37, "near_kthny_bounds", "eta_G1 or eta_6 too close to its bound (1/3, 1/4)", ("kthny",),
       "near KTHNY bound"),
    _R(38, "decided_exponents", "eta_G1 and eta_6 against their bounds decide", ("kthny",)),
    _R(39, "not_periodic", "confined run (a well or a channel): the KTHNY correlations and bounds are those of a "
                           "homogeneous periodic system and are not computed", ("kthny",), "confined"),
    _R(40, "replicates_disagree", "the replicates give different decided labels", _ALL, "replicates disagree"),
    _R(41, "replicates_agree", "the replicates give the same label for different reasons", _ALL),
    _R(42, "starts_disagree", "the two starts give different decided labels", _ALL, "starts disagree"),
    _R(43, "starts_agree", "both starts give the same label for different reasons", _ALL),
    _R(44, "solid_kinds_differ", "both starts read solid, one a crystal and the other amorphous (|Psi6|, rho_d): the "
                                 "same label is not the same state", ("phase",), "crystal vs amorphous"),
)
#: name -> :class:`Reason`.
REASON_BY_NAME = {r.name: r for r in REASONS}
#: code -> :class:`Reason`.
REASON_BY_CODE = {r.code: r for r in REASONS}


def reason_value(name: str) -> int:
    """Stored integer of the reason code ``name`` (KeyError for an undeclared one)."""
    return REASON_BY_NAME[name].code


def reason_name(code) -> str:
    """Name of a stored reason code (``not_recorded`` for an unknown value)."""
    return REASON_BY_CODE.get(int(code), REASONS[0]).name


def reason_flags(label: str) -> dict[int, str]:
    """``{code: name}`` of the reasons label family ``label`` can carry (for
    :func:`fcsweep.analysis.phase.flag_attrs` and the HDF5 enum of ``analysis.h5``)."""
    label = label.split("_")[0] if label.split("_")[0] in FAMILIES else label
    if label not in FAMILIES:
        raise KeyError(f"no reason codes for label {label!r}; families: {', '.join(FAMILIES)}")
    return {r.code: r.name for r in REASONS if label in r.labels}


def reason_short(code) -> str:
    """The words a figure writes for a stored reason code ("" for decided labels and
    ``not_recorded``)."""
    return REASON_BY_CODE.get(int(code), REASONS[0]).short
