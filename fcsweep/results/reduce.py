"""Reductions of the phase-diagram dataset (in place): replicate means and their reduced
chi-square, the point labels, Fisher exponents and finite-size collapses.

Called by :func:`fcsweep.results.aggregate.build_dataset` once the per-run variables are
in; the numbers come from :mod:`fcsweep.analysis` (:func:`fcsweep.analysis.stats.combine`,
:func:`fcsweep.analysis.points.point_labels`, :func:`fcsweep.analysis.percolation.fisher_observables`,
:func:`fcsweep.analysis.fss.fss_collapse`).  Also the dataset's vocabulary: the
attributes of every variable (:data:`META`) and the run status flags (:data:`STATUS_FLAGS`).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from fcsweep.analysis.fss import FSS_BOOTSTRAP, fss_collapse, not_periodic_reason
from fcsweep.analysis.percolation import fisher_observables
from fcsweep.analysis.phase import (KTHNY_FLAGS, KTHNY_UNDETERMINED, MIN_CONFIDENCE, PERCOLATION_FLAGS, PHASE_FLAGS,
                                    BIAS_KEYS, PHASE_SOLID, RHO_D_PERCOLATION, SOLID_KIND_FLAGS, flag_attrs, solid_kind)
from fcsweep.analysis.points import (COMBINED, DECIDED, HYSTERESIS_DISAGREE, HYSTERESIS_FLAGS, LEAST, MOST, agree,
                                     combine_runs, common_reason, point_labels)
from fcsweep.analysis.reasons import reason_flags, reason_value
from fcsweep.analysis.stats import combine
from fcsweep.io.schema import DONE, STATUSES
from fcsweep.model.observables import LABELS, OBSERVABLES, REPLICATE_REDUCED, group
from fcsweep.model.parameters import PARAMETERS

#: (long_name, units) of every coordinate and variable: the observable table
#: (:mod:`fcsweep.model.observables`) and the parameter table (:mod:`fcsweep.model.parameters`).
META = {**{name: (p.long_name, p.units) for name, p in PARAMETERS.items()},
        **{name: (o.long_name, o.units) for name, o in OBSERVABLES.items()}}
#: Observables reduced over replicates (``<name>_rmean``, ``_rmean_err``, ``_rchi2``).
REPLICATE_VARS = REPLICATE_REDUCED
#: Per-run numbers the point labels read (:func:`fcsweep.analysis.points.combine_runs`).
POINT_INPUTS = COMBINED + tuple(f"{v}_err" for v in COMBINED) + LEAST + MOST + ("cage_lag",) + BIAS_KEYS
#: The flags of each label of the observable table (:data:`fcsweep.model.observables.LABELS`).
LABEL_FLAGS = {"phase": PHASE_FLAGS, "percolated": PERCOLATION_FLAGS, "kthny": KTHNY_FLAGS}

#: Status of every run of the dataset (variable ``status``): a done run by its analysis
#: (``analysed``, ``not_analysed``: no current analysis.h5, ``analysis_failed``), any
#: other run by its state (:data:`fcsweep.io.schema.STATUSES`, as ``fcsweep status``
#: shows it: a run without status.json is ``pending``), and ``missing`` for a grid cell
#: without a run (the points of a non-rectangular grid).
STATUS_WORDS = ("analysed", "not_analysed", "analysis_failed") + tuple(s for s in STATUSES if s != DONE) + ("missing",)
STATUS_FLAGS = dict(enumerate(STATUS_WORDS))
#: Status word -> flag.
STATUS_CODES = {word: code for code, word in STATUS_FLAGS.items()}
ANALYSED = STATUS_CODES["analysed"]


def attrs_of(name: str) -> dict:
    """CF attributes (``long_name``, ``units``) of a coordinate or variable."""
    ln, un = META.get(name) or (f"swept parameter {name}", "1")
    out = {"long_name": ln}
    if un:
        out["units"] = un
    return out


def reduce_dataset(ds: xr.Dataset, settings) -> None:
    """Add ``<name>_rmean``, ``_rmean_err``, ``_rchi2`` and the point labels (in place)."""
    conf = float((settings or {}).get("label_confidence", MIN_CONFIDENCE))
    for v in REPLICATE_VARS:
        x = ds[v].transpose(..., "replicate").values
        e = ds[f"{v}_err"].transpose(..., "replicate").values
        out = np.full(x.shape[:-1] + (3,), np.nan)
        for idx in np.ndindex(x.shape[:-1]):
            c = combine(x[idx], e[idx])
            out[idx] = (c.mean, c.err, c.chi2_dof)
        dims = [d for d in ds[v].dims if d != "replicate"]
        ln = META[v][0]
        ds[f"{v}_rmean"] = (dims, out[..., 0], {"long_name": f"replicate mean of {ln}", "units": "1"})
        ds[f"{v}_rmean_err"] = (dims, out[..., 1], {"long_name": f"1-sigma error of {v}_rmean", "units": "1"})
        ds[f"{v}_rchi2"] = (dims, out[..., 2], {
            "long_name": f"reduced chi-square of the replicates of {v} about their mean (~1: honest errors)",
            "units": "1"})
    add_point_labels(ds, conf, float((settings or {}).get("percolation_threshold", RHO_D_PERCOLATION)))
    fisher_exponents(ds)
    fss_collapses(ds)


def add_point_labels(ds: xr.Dataset, conf: float, threshold: float) -> None:
    """Point labels (in place): the phase rule on each point's replicate-combined evidence
    (:func:`fcsweep.analysis.points.point_labels`), the KTHNY label common to the
    replicates; with an ``initial`` dimension these are the per-start labels
    (``<label>_start``) and the point's are the starts' common label
    (:func:`fcsweep.analysis.points.agree`), with ``phase_hysteresis``."""
    names = [v for v in POINT_INPUTS if v in ds]
    vals = {v: ds[v].transpose(..., "replicate").values for v in names}
    st = ds["status"].transpose(..., "replicate").values
    dims = [d for d in ds["phase"].dims if d != "replicate"]
    shape = st.shape[:-1]
    out = {k: np.full(shape, -1, dtype=np.int8) for k in ("phase", "percolated")}
    cf = {k: np.full(shape, np.nan) for k in ("phase", "percolated")}
    why = {k: np.full(shape, -1, dtype=np.int8) for k in ("phase", "percolated")}
    kind = np.full(shape, -1, dtype=np.int8)
    for idx in np.ndindex(shape):
        runs = [{v: float(vals[v][idx + (r,)]) for v in names} for r in np.flatnonzero(st[idx] == ANALYSED)]
        ph, pc = point_labels(runs, min_confidence=conf, percolation_threshold=threshold)
        if runs:
            ev = combine_runs(runs)
            kind[idx] = solid_kind(ph.code, ev["psi6"], ev["psi6_err"], ev["rho_d"], ev["rho_d_err"],
                                   min_confidence=conf)[0]
        out["phase"][idx], cf["phase"][idx] = ph.code, ph.confidence
        out["percolated"][idx], cf["percolated"][idx] = pc.code, pc.confidence
        why["phase"][idx], why["percolated"][idx] = reason_value(ph.reason_code), reason_value(pc.reason_code)
    out["kthny"], cf["kthny"] = kthny_common(ds)
    why["kthny"] = common_reason(out["kthny"], ds["kthny"].transpose(..., "replicate").values,
                                 ds.get("kthny_reason_code", 0 * ds["kthny"]).transpose(..., "replicate").values,
                                 DECIDED["kthny"][0],
                                 disagree="replicates_disagree", agree_="replicates_agree")
    flags = LABEL_FLAGS
    if "initial" not in dims:
        for k in LABELS:
            ds[f"{k}_point"] = (dims, out[k], {**attrs_of(f"{k}_point"), **flag_attrs(flags[k])})
            ds[f"{k}_point_confidence"] = (dims, cf[k], attrs_of(f"{k}_point_confidence"))
            ds[f"{k}_point_reason_code"] = (dims, why[k], {**attrs_of(f"{k}_point_reason_code"),
                                                           **flag_attrs(reason_flags(k))})
        return
    axis = dims.index("initial")
    pdims = [d for d in dims if d != "initial"]
    for k in LABELS:
        ds[f"{k}_start"] = (dims, out[k], {**attrs_of(f"{k}_start"), **flag_attrs(flags[k])})
        ds[f"{k}_start_confidence"] = (dims, cf[k], attrs_of(f"{k}_start_confidence"))
        decided, undetermined = DECIDED[k]
        code, conf_k, hyst = agree(np.moveaxis(out[k], axis, -1), np.moveaxis(cf[k], axis, -1), decided, undetermined)
        if k == "phase":  # the same label is not the same state: a crystal against a glass
            kinds = np.moveaxis(kind, axis, -1)
            differ = (code == PHASE_SOLID) & np.all(np.isin(kinds, (0, 1)), axis=-1) & \
                (kinds.max(axis=-1) != kinds.min(axis=-1))
            code = np.where(differ, undetermined, code).astype(np.int8)
            conf_k = np.where(differ, np.nan, conf_k)
            hyst = np.where(differ, HYSTERESIS_DISAGREE, hyst).astype(np.int8)
            common = np.where(np.all(kinds == kinds[..., :1], axis=-1), kinds[..., 0], 2)
            ds["solid_kind_start"] = (dims, kind, {**attrs_of("solid_kind_start"), **flag_attrs(SOLID_KIND_FLAGS)})
            ds["solid_kind_point"] = (pdims, np.where(code == PHASE_SOLID, common, -1).astype(np.int8),
                                      {**attrs_of("solid_kind_point"), **flag_attrs(SOLID_KIND_FLAGS)})
        ds[f"{k}_point"] = (pdims, code, {**attrs_of(f"{k}_point"), **flag_attrs(flags[k])})
        ds[f"{k}_point_confidence"] = (pdims, conf_k, attrs_of(f"{k}_point_confidence"))
        rc_k = common_reason(code, np.moveaxis(out[k], axis, -1), np.moveaxis(why[k], axis, -1), decided,
                             disagree="starts_disagree", agree_="starts_agree")
        if k == "phase":
            rc_k = np.where(differ, reason_value("solid_kinds_differ"), rc_k).astype(np.int8)
        ds[f"{k}_start_reason_code"] = (dims, why[k], {**attrs_of(f"{k}_start_reason_code"),
                                                       **flag_attrs(reason_flags(k))})
        ds[f"{k}_point_reason_code"] = (pdims, rc_k, {**attrs_of(f"{k}_point_reason_code"),
                                                      **flag_attrs(reason_flags(k))})
        if k == "phase":
            ds["phase_hysteresis"] = (pdims, hyst, {**attrs_of("phase_hysteresis"), **flag_attrs(HYSTERESIS_FLAGS)})


def kthny_common(ds: xr.Dataset):
    """The replicates' common KTHNY label, its lowest confidence, or undetermined when
    they differ or one is undetermined."""
    k = ds["kthny"].transpose(..., "replicate").values
    c = ds["kthny_confidence"].transpose(..., "replicate").values
    same = np.all(k == k[..., :1], axis=-1) & np.all(k >= 0, axis=-1)
    point = np.where(same, k[..., 0], np.where(np.any(k >= 0, axis=-1), KTHNY_UNDETERMINED, -1)).astype(np.int8)
    conf = np.where(same, np.nanmin(np.where(np.isfinite(c), c, np.inf), axis=-1), np.nan)
    return point, np.where(np.isinf(conf), np.nan, conf)


def fisher_exponents(ds: xr.Dataset) -> None:
    """``tau_fisher``, its error and reason per point from the pooled cluster sizes (in place)."""
    counts = ds["cluster_size_distribution"].fillna(0).sum("replicate")
    dims = list(counts.dims[:-1])
    size = counts.sizes["cluster_size"]
    tau = np.full(counts.shape[:-1], np.nan)
    err = np.full(counts.shape[:-1], np.nan)
    why = np.full(counts.shape[:-1], "", dtype=object)
    Ns = counts["N"].broadcast_like(counts.isel(cluster_size=0)).values
    sizes = counts["cluster_size"].values
    for idx in np.ndindex(tau.shape):
        c = np.zeros(int(sizes.max()) if size else 0)
        c[sizes - 1] = counts.values[idx]
        if not np.any(c > 0):
            why[idx] = "no defect clusters"
            continue
        try:
            r = fisher_observables(c, int(Ns[idx]))
        except ValueError as exc:
            why[idx] = str(exc)
            continue
        tau[idx], err[idx], why[idx] = r["tau_fisher"], r["tau_fisher_err"], r["tau_fisher_reason"]
    for name, arr in (("tau_fisher", tau), ("tau_fisher_err", err), ("tau_fisher_reason", why)):
        ds[name] = (dims, arr, attrs_of(name))


#: Variables of the finite-size collapse (the observable table's group ``fss``).
FSS_VARS = group("fss")
#: The same for the collapse of the shuffled-label control ``largest_cluster_fraction_shuffled``.
FSS_SHUFFLED_VARS = group("fss_shuffled")


def fss_collapses(ds: xr.Dataset, n_bootstrap: int = FSS_BOOTSTRAP) -> None:
    """Finite-size collapses of the largest defect cluster, one per v0 (in place).

    Only for datasets with two or more N.  Each slice of the dimensions other than
    ``eta``, ``N`` and ``replicate`` (v0 and any other swept parameter) is one fit:
    its points are the replicate means ``largest_cluster_fraction_rmean`` (with their
    errors) against ``rho_d_rmean`` over every eta and N, because eta moves rho_d
    through the threshold at fixed v0 while N supplies the sizes
    (:func:`fcsweep.analysis.fss.fss_collapse`; the error of rho_d is not used).
    The same fit of ``largest_cluster_fraction_shuffled_rmean`` (defect labels permuted
    over each frame's Voronoi graph, same rho_d) gives ``fss_shuffled_*``: the threshold
    of random site percolation on the cells' own graphs, so ``fss_rho_c -
    fss_shuffled_rho_c`` is the shift caused by the correlations of the defects.
    """
    if ds.sizes.get("N", 1) < 2:
        return
    for stat, names in (("largest_cluster_fraction", FSS_VARS),
                        ("largest_cluster_fraction_shuffled", FSS_SHUFFLED_VARS)):
        _collapse_per_slice(ds, stat, names, n_bootstrap)


def _collapse_per_slice(ds: xr.Dataset, stat: str, names: tuple, n_bootstrap: int) -> None:
    """:func:`fss_collapses` for the replicate means of one largest-cluster statistic ``stat``; the
    variables ``names`` (in the order of :data:`FSS_VARS`) and ``<prefix>_reason``."""
    if f"{stat}_rmean" not in ds:  # a dataset assembled without the statistic
        return
    reason = names[0].removesuffix("_rho_c") + "_reason"
    rho, pmax, err = (ds[v].transpose("eta", "N", ...) for v in ("rho_d_rmean", f"{stat}_rmean", f"{stat}_rmean_err"))
    confined = _confined_points(ds)
    dims, shape = list(rho.dims[2:]), rho.shape[2:]
    Ns = np.broadcast_to(ds["N"].values.astype(float)[None, :], rho.shape[:2])
    out = np.full(shape + (len(names),), np.nan)
    why = np.full(shape, "", dtype=object)
    for idx in np.ndindex(shape):
        sl = (slice(None), slice(None)) + idx
        r, p, e = rho.values[sl].ravel(), pmax.values[sl].ravel(), err.values[sl].ravel()
        n = Ns.ravel()
        ok = np.isfinite(r) & np.isfinite(p)
        if confined is not None and confined[sl].any():
            why[idx] = not_periodic_reason()
            continue
        if np.unique(n[ok]).size < 2:
            why[idx] = f"fewer than two N with finite rho_d and {stat}"
            continue
        fit = fss_collapse(r[ok], p[ok], n[ok], np.where(np.isfinite(e[ok]), e[ok], 0.0), n_bootstrap=n_bootstrap)
        out[idx] = [fit[k.removeprefix("fss_")] for k in FSS_VARS]
        why[idx] = fit.reason
    for k, name in enumerate(names):
        ds[name] = (dims, out[..., k], attrs_of(name))
    ds[reason] = (dims, why, attrs_of(reason))


def _confined_points(ds: xr.Dataset):
    """Points (dimensions ``eta``, ``N``, then the others) with a confined run (a finite
    ``area_fraction``: a well or channel), or None in a dataset without it."""
    if "area_fraction" not in ds:
        return None
    c = np.isfinite(ds["area_fraction"])
    if "replicate" in c.dims:
        c = c.any("replicate")
    return c.transpose("eta", "N", ...).values


def replicate_error_check(ds: xr.Dataset) -> dict:
    """Median reduced chi-square of the replicates per observable: ``{name: (median, points)}``.

    Near 1 the per-run errors describe the replicate scatter; well above 1 they are too
    small (the point errors ``<name>_rmean_err`` are scaled up for it already).
    Observables without two replicates at any point are left out.
    """
    out = {}
    for v in REPLICATE_VARS:
        x = ds.get(f"{v}_rchi2")
        if x is None:
            continue
        vals = x.values[np.isfinite(x.values)]
        if vals.size:
            out[v] = (float(np.median(vals)), int(vals.size))
    return out
