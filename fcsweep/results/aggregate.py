"""Collect per-run ``analysis.h5`` files into one CF-1.8 phase-diagram dataset.

Dimensions: ``eta``, ``v0``, ``N`` (always, length 1 when not swept), any other swept
parameter in grid order, then ``replicate``; curves add their own coordinate
(``lag_time``, ``r``, ``dx``, ``q_bin``, ``cluster_size``).

Curve alignment: the coordinate of a curve is the sorted union of the values found in
the runs (lags are multiples of the frame interval, r and dx are bin centres
``(k + 1/2) * width`` and cluster sizes are integers, so runs of different N or box share
values exactly); a run lacking a value is NaN there.  No interpolation.

Integer labels (``phase``, ``percolated``, ``status``) are int8 with CF ``flag_values``
and ``flag_meanings``; missing or failed runs are NaN (floats) or the "unknown" flag, and
``status`` says why. Every observable has its 1-sigma error ``<name>_err``; each label
its ``<label>_confidence`` and ``<label>_reason`` (a character string per run).
Labels use the config's ``analysis`` section (``label_confidence``,
``percolation_threshold``), stored in the ``analysis_settings`` attribute.

Replicates: ``<name>_rmean`` and ``<name>_rmean_err`` reduce the ``replicate``
dimension (:func:`fcsweep.analysis.stats.combine`: plain mean, propagated error scaled
up by sqrt(chi2/dof) when the replicates scatter more than their errors allow) and
``<name>_rchi2`` is that reduced chi-square, ~1 when the per-run errors are honest.
``phase_point`` and ``percolated_point`` are the labels of a point: the one phase rule
(:func:`fcsweep.analysis.phase.phase_label`) on its replicate-combined evidence
(:mod:`fcsweep.analysis.points`). With an ``initial`` dimension (both starts swept) the
per-start labels are ``<label>_start`` and the point's labels have no ``initial``
dimension: the starts' common decided label, else undetermined; ``phase_hysteresis``
says whether the starts agree.

CF-1.8: integer variables are int32 or int8 (CF-1.8 has no int64), strings are
character arrays, bounds carry no fill value.
"""

from __future__ import annotations

import datetime as _dt
import json
from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep import __version__
from fcsweep.analysis.phase import (KTHNY_FLAGS, KTHNY_UNDETERMINED, MIN_CONFIDENCE, PERCOLATION_FLAGS, PHASE_FLAGS,
                                    RHO_D_PERCOLATION, flag_attrs)
from fcsweep.analysis.points import COMBINED, DECIDED, HYSTERESIS_FLAGS, LEAST, agree, point_labels
from fcsweep.analysis.fss import FSS_BOOTSTRAP, fss_collapse
from fcsweep.analysis.percolation import fisher_observables
from fcsweep.analysis.stats import combine
from fcsweep.io.observables import OBSERVABLES, REPLICATE_REDUCED, RUN_SCALARS, TEXTS
from fcsweep.io.status import read_status
from fcsweep.io.failures import remove_stale
from fcsweep.io.sweepdir import atomic_write, run_path, run_state
from fcsweep.model.parameters import PARAMETERS
from fcsweep.analysis.pipeline import (ANALYSIS_ERROR_FILE, ANALYSIS_FILE, CURVES, DATASET_FILE, config_settings,
                                      read_analysis)

CORE_DIMS = ("eta", "v0", "N")
STATUS_FLAGS = {0: "analysed", 1: "not_analysed", 2: "failed", 3: "running", 4: "pending",
                5: "missing", 6: "analysis_failed"}
_RUN_STATUS = {"failed": 2, "running": 3, "pending": 4}

#: (long_name, units) of every coordinate and variable: the observable table
#: (:mod:`fcsweep.io.observables`) and the parameter table (:mod:`fcsweep.model.parameters`).
META = {**{name: (p.long_name, p.units) for name, p in PARAMETERS.items()},
        **{name: (o.long_name, o.units) for name, o in OBSERVABLES.items()}}
#: Per-run numbers of the dataset.
SCALAR_VARS = RUN_SCALARS
#: Observables reduced over replicates (``<name>_rmean``, ``_rmean_err``, ``_rchi2``).
REPLICATE_VARS = REPLICATE_REDUCED
#: Per-run numbers the point labels read (:func:`fcsweep.analysis.points.combine_runs`).
POINT_INPUTS = COMBINED + tuple(f"{v}_err" for v in COMBINED) + LEAST + ("cage_lag",)
#: Per-run strings, written as CF character arrays.
STRING_VARS = TEXTS


def _key(x):
    """Hashable, float-noise-free key of a coordinate value."""
    if isinstance(x, (float, np.floating)):
        return float(f"{float(x):.12g}")
    if isinstance(x, (np.integer,)):
        return int(x)
    return x


def _coord_values(vals):
    vals = sorted({_key(v) for v in vals}, key=lambda v: (isinstance(v, str), v))
    if all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in vals):
        return np.array(vals, dtype=np.int32)
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
        return np.array(vals, dtype=np.float64)
    return np.array([str(v) for v in vals], dtype=object)


def _dims(config) -> list[str]:
    swept = list(config.swept)
    return list(CORE_DIMS) + [s for s in swept if s not in CORE_DIMS] + ["replicate"]


def _attrs(name: str) -> dict:
    ln, un = META.get(name) or (f"swept parameter {name}", "1")
    out = {"long_name": ln}
    if un:
        out["units"] = un
    return out


def _frames_after_transient(sc: dict) -> float:
    """Frames after the transient, from which the Voronoi statistics take theirs.

    ``n_frames`` counts the frames after the equilibration cut (``t_equilibrated``), the
    equally spaced tail of those after the transient (``t_start`` .. ``t_end``), so
    the frame interval is ``(t_end - t_equilibrated) / (n_frames - 1)``.
    """
    nf, t0, t1, te = (float(sc.get(k, np.nan)) for k in ("n_frames", "t_start", "t_end", "t_equilibrated"))
    if not (np.isfinite(nf) and nf >= 2 and np.isfinite(t0) and np.isfinite(t1) and np.isfinite(te) and t1 > te):
        return nf
    return float(np.rint((nf - 1.0) * (t1 - t0) / (t1 - te)) + 1.0)


def build_dataset(config) -> xr.Dataset:
    """Phase-diagram dataset of a sweep from its runs' ``analysis.h5`` files.

    Parameters
    ----------
    config : SweepConfig
        From :func:`fcsweep.config.load_config`.

    Returns
    -------
    xarray.Dataset
    """
    runs = list(config.runs())
    dims = _dims(config)
    coords = {}
    for d in dims:
        if d == "replicate":
            coords[d] = np.arange(max(int(getattr(config, "replicates", 1)),
                                      1 + max((r.replicate for r in runs), default=0)), dtype=np.int32)
        else:
            coords[d] = _coord_values([r.params.get(d, np.nan) for r in runs])
    index = {d: {_key(v): i for i, v in enumerate(coords[d])} for d in dims}
    shape = tuple(len(coords[d]) for d in dims)

    # read everything first (curve coordinates are unions over runs)
    entries = []
    status = np.full(shape, 5, dtype=np.int8)
    strings = {v: np.full(shape, "", dtype=object) for v in STRING_VARS}
    commits = set()
    settings = None
    for spec in runs:
        loc = tuple(index[d][_key(spec.replicate if d == "replicate" else spec.params.get(d, np.nan))]
                    for d in dims)
        strings["run_id"][loc] = spec.run_id
        strings["seed"][loc] = str(spec.params.get("seed", ""))
        rd = run_path(config.output, spec.run_id)
        rs = run_state(rd)  # the state `fcsweep status` shows
        if rs.status is None and rs.state == "pending":
            status[loc] = 5
            continue
        if rs.state != "done":
            status[loc] = _RUN_STATUS.get(rs.state, 5)
            continue
        if (rd / ANALYSIS_ERROR_FILE).exists():
            status[loc] = 6
            continue
        try:
            res = read_analysis(rd / ANALYSIS_FILE)
        except (OSError, KeyError, ValueError):
            status[loc] = 1
            continue
        status[loc] = 0
        settings = settings or res["settings"]
        for v in ("phase_reason", "percolated_reason", "kthny_reason"):
            strings[v][loc] = str(res["scalars"].get(v, ""))
        try:
            commit = json.loads(res["attrs"].get("parameters_json", "{}")).get("git_commit")
        except ValueError:
            commit = None
        if commit:
            commits.add(str(commit))
        entries.append((loc, res))

    curve_coords = {}
    for name, cname in CURVES.items():
        vals = set()
        for _, res in entries:
            if name in res["curves"]:
                x, y = res["curves"][name]
                if name == "cluster_size_distribution":  # trim trailing zero counts
                    nz = np.flatnonzero(np.asarray(y) > 0)
                    x = x[: (nz[-1] + 1 if nz.size else 1)]
                vals.update(_key(v) for v in np.asarray(x).tolist())
        cc = np.array(sorted(vals), dtype=np.int32 if cname == "cluster_size" else np.float64)
        if cc.size == 0:
            cc = np.array([1], dtype=np.int32) if cname == "cluster_size" else np.array([np.nan])
        curve_coords[cname] = cc
    cindex = {c: {_key(v): i for i, v in enumerate(cc.tolist())} for c, cc in curve_coords.items()}

    data = {v: np.full(shape, np.nan) for v in SCALAR_VARS}
    data["n_structure_frames"] = np.full(shape, np.nan)
    phase = np.full(shape, -1, dtype=np.int8)
    kth = np.full(shape, -1, dtype=np.int8)
    perc = np.full(shape, -1, dtype=np.int8)
    curves = {n: np.full(shape + (len(curve_coords[c]),), np.nan) for n, c in CURVES.items()}
    for loc, res in entries:
        sc = res["scalars"]
        for v in SCALAR_VARS:
            data[v][loc] = sc.get(v, np.nan)
        sset = res["settings"]
        nf = _frames_after_transient(sc)
        data["n_structure_frames"][loc] = min(nf, sset.get("structure_frames", nf)) if np.isfinite(nf) else np.nan
        phase[loc] = int(sc["phase"]) if np.isfinite(sc.get("phase", np.nan)) else -1
        kth[loc] = int(sc["kthny"]) if np.isfinite(sc.get("kthny", np.nan)) else -1
        perc[loc] = int(sc["percolated"]) if np.isfinite(sc.get("percolated", np.nan)) else -1
        for n, c in CURVES.items():
            if n not in res["curves"]:
                continue
            x, y = res["curves"][n]
            ix = cindex[c]
            for xv, yv in zip(np.asarray(x).tolist(), np.asarray(y).tolist()):
                j = ix.get(_key(xv))
                if j is not None:
                    curves[n][loc + (j,)] = yv

    ds = xr.Dataset(coords={d: (d, coords[d], _attrs(d)) for d in dims})
    for c, cc in curve_coords.items():
        ds.coords[c] = (c, cc, _attrs(c))
    if settings and "q_edges" in settings:
        lo, hi, nb = settings["q_edges"]
        e = np.linspace(lo, hi, int(nb) + 1)
        if len(e) - 1 == ds.sizes["q_bin"]:
            ds.coords["q_bin"].attrs["bounds"] = "q_bin_bounds"
            ds["q_bin_bounds"] = (("q_bin", "nv"), np.stack([e[:-1], e[1:]], axis=1))  # CF: attributes inherited
    for v, arr in data.items():
        ds[v] = (dims, arr, _attrs(v))
    for n, c in CURVES.items():
        ds[n] = (dims + [c], curves[n], _attrs(n))
    ds["phase"] = (dims, phase, {**_attrs("phase"), **flag_attrs(PHASE_FLAGS)})
    ds["kthny"] = (dims, kth, {**_attrs("kthny"), **flag_attrs(KTHNY_FLAGS)})
    ds["percolated"] = (dims, perc, {**_attrs("percolated"), **flag_attrs(PERCOLATION_FLAGS)})
    ds["status"] = (dims, status, {**_attrs("status"), **flag_attrs(STATUS_FLAGS)})
    for v, arr in strings.items():
        ds[v] = (dims, arr, _attrs(v))
    settings = {**(settings or {}), **config_settings(config)}  # the config's label settings rule the points
    _reduce_replicates(ds, settings)
    now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    cfg = config.to_dict() if hasattr(config, "to_dict") else {}
    ds.attrs = {
        "Conventions": "CF-1.8",
        "title": "fcsweep phase-diagram dataset (Fourier contour model of active deformable cells)",
        "source": f"fcsweep {__version__}",
        "fcsweep_version": __version__,
        "history": f"{now} fcsweep aggregate {getattr(config, 'source', '')}".strip(),
        "references": "Fourier contour cell model; observables as defined in docs/model.md",
        "config": json.dumps(cfg, sort_keys=True, default=str),
        "analysis_settings": json.dumps(settings or {}, sort_keys=True),
        "curve_alignment": "curve coordinates are the union over runs; NaN where a run has no value (no interpolation)",
        "n_runs": np.int32(len(runs)),
        "n_analysed": np.int32(len(entries)),
    }
    if commits:
        ds.attrs["git_commit"] = " ".join(sorted(commits))
    ds.attrs.update(cost_attributes(config))
    return ds


#: status.json cost keys -> NetCDF attribute of their sum over the sweep's runs.
COST_ATTRIBUTES = {"cell_steps": "total_cell_steps", "cell_steps_computed": "total_cell_steps_computed",
                   "cpu_seconds": "total_cpu_seconds", "check_cpu_seconds": "total_check_cpu_seconds",
                   "wall_seconds": "total_wall_seconds"}


def cost_attributes(config) -> dict:
    """What the sweep cost, summed over its runs' ``status.json`` (cell-steps in the
    trajectories and integrated, CPU seconds of the runs and of their ``run.until``
    checks, wall seconds) and how its runs stopped (``runs_settled``, ``runs_at_cap``)."""
    totals = dict.fromkeys(COST_ATTRIBUTES, 0.0)
    stops = {"settled": 0, "steps": 0}
    for spec in config.runs():
        st = read_status(run_path(config.output, spec.run_id)) or {}
        for k in totals:
            totals[k] += float(st.get(k) or 0.0)
        if st.get("status") == "done" and st.get("stop_reason", "steps") in stops:
            stops[st.get("stop_reason", "steps")] += 1
    out = {COST_ATTRIBUTES[k]: np.float64(v) for k, v in totals.items()}
    out.update(runs_settled=np.int32(stops["settled"]), runs_at_cap=np.int32(stops["steps"]))
    return out


def _reduce_replicates(ds: xr.Dataset, settings) -> None:
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
    _point_labels(ds, conf, float((settings or {}).get("percolation_threshold", RHO_D_PERCOLATION)))
    _fisher_exponents(ds)
    _fss(ds)


def _point_labels(ds: xr.Dataset, conf: float, threshold: float) -> None:
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
    for idx in np.ndindex(shape):
        runs = [{v: float(vals[v][idx + (r,)]) for v in names} for r in np.flatnonzero(st[idx] == 0)]
        ph, pc = point_labels(runs, min_confidence=conf, percolation_threshold=threshold)
        out["phase"][idx], cf["phase"][idx] = ph.code, ph.confidence
        out["percolated"][idx], cf["percolated"][idx] = pc.code, pc.confidence
    out["kthny"], cf["kthny"] = _kthny_common(ds)
    flags = {"phase": PHASE_FLAGS, "percolated": PERCOLATION_FLAGS, "kthny": KTHNY_FLAGS}
    if "initial" not in dims:
        for k in ("phase", "percolated", "kthny"):
            ds[f"{k}_point"] = (dims, out[k], {**_attrs(f"{k}_point"), **flag_attrs(flags[k])})
            ds[f"{k}_point_confidence"] = (dims, cf[k], _attrs(f"{k}_point_confidence"))
        return
    axis = dims.index("initial")
    pdims = [d for d in dims if d != "initial"]
    for k in ("phase", "percolated", "kthny"):
        ds[f"{k}_start"] = (dims, out[k], {**_attrs(f"{k}_start"), **flag_attrs(flags[k])})
        ds[f"{k}_start_confidence"] = (dims, cf[k], _attrs(f"{k}_start_confidence"))
        decided, undetermined = DECIDED[k]
        code, conf_k, hyst = agree(np.moveaxis(out[k], axis, -1), np.moveaxis(cf[k], axis, -1), decided, undetermined)
        ds[f"{k}_point"] = (pdims, code, {**_attrs(f"{k}_point"), **flag_attrs(flags[k])})
        ds[f"{k}_point_confidence"] = (pdims, conf_k, _attrs(f"{k}_point_confidence"))
        if k == "phase":
            ds["phase_hysteresis"] = (pdims, hyst, {**_attrs("phase_hysteresis"), **flag_attrs(HYSTERESIS_FLAGS)})


def _kthny_common(ds: xr.Dataset):
    """The replicates' common KTHNY label, its lowest confidence, or undetermined when
    they differ or one is undetermined."""
    k = ds["kthny"].transpose(..., "replicate").values
    c = ds["kthny_confidence"].transpose(..., "replicate").values
    same = np.all(k == k[..., :1], axis=-1) & np.all(k >= 0, axis=-1)
    point = np.where(same, k[..., 0], np.where(np.any(k >= 0, axis=-1), KTHNY_UNDETERMINED, -1)).astype(np.int8)
    conf = np.where(same, np.nanmin(np.where(np.isfinite(c), c, np.inf), axis=-1), np.nan)
    return point, np.where(np.isinf(conf), np.nan, conf)


def _fisher_exponents(ds: xr.Dataset) -> None:
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
        ds[name] = (dims, arr, _attrs(name))


#: Variables of the finite-size collapse, in the order of its fit's fields.
FSS_VARS = ("fss_rho_c", "fss_rho_c_err", "fss_nu", "fss_nu_err", "fss_beta", "fss_beta_err", "fss_quality")
#: The same for the collapse of the shuffled-label control ``largest_cluster_fraction_shuffled``.
FSS_SHUFFLED_VARS = tuple(v.replace("fss_", "fss_shuffled_", 1) for v in FSS_VARS)


def _fss(ds: xr.Dataset, n_bootstrap: int = FSS_BOOTSTRAP) -> None:
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
    """:func:`_fss` for the replicate means of one largest-cluster statistic ``stat``; the
    variables ``names`` (in the order of :data:`FSS_VARS`) and ``<prefix>_reason``."""
    if f"{stat}_rmean" not in ds:  # a dataset assembled without the statistic
        return
    reason = names[0].removesuffix("_rho_c") + "_reason"
    rho, pmax, err = (ds[v].transpose("eta", "N", ...) for v in ("rho_d_rmean", f"{stat}_rmean", f"{stat}_rmean_err"))
    dims, shape = list(rho.dims[2:]), rho.shape[2:]
    Ns = np.broadcast_to(ds["N"].values.astype(float)[None, :], rho.shape[:2])
    out = np.full(shape + (len(names),), np.nan)
    why = np.full(shape, "", dtype=object)
    for idx in np.ndindex(shape):
        sl = (slice(None), slice(None)) + idx
        r, p, e = rho.values[sl].ravel(), pmax.values[sl].ravel(), err.values[sl].ravel()
        n = Ns.ravel()
        ok = np.isfinite(r) & np.isfinite(p)
        if np.unique(n[ok]).size < 2:
            why[idx] = f"fewer than two N with finite rho_d and {stat}"
            continue
        fit = fss_collapse(r[ok], p[ok], n[ok], np.where(np.isfinite(e[ok]), e[ok], 0.0), n_bootstrap=n_bootstrap)
        out[idx] = [fit[k.removeprefix("fss_")] for k in FSS_VARS]
        why[idx] = fit.reason
    for k, name in enumerate(names):
        ds[name] = (dims, out[..., k], _attrs(name))
    ds[reason] = (dims, why, _attrs(reason))


def write_dataset(ds: xr.Dataset, path) -> Path:
    """Write ``ds`` as NetCDF4 through :func:`fcsweep.io.sweepdir.atomic_write`: the previous
    dataset stays until the new one is complete (a full disk raises
    :class:`fcsweep.io.failures.WriteFailure` and leaves it byte for byte)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    enc = {}
    for v in ds.variables:
        if ds[v].dtype.kind == "f":
            bounds = v.endswith("_bounds")
            enc[v] = {"_FillValue": np.nan if v not in ds.coords and not bounds else None}
        elif v in STRING_VARS:
            enc[v] = {"dtype": "S1"}
    return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=enc),
                        fsync=True)


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


def point_summaries(ds: xr.Dataset) -> list[str]:
    """One line per grid point and replicate: its coordinates and the phase label with its
    confidence, or the reason it is undetermined (what ``fcsweep aggregate`` prints)."""
    phase = ds["phase"]
    lines = []
    for idx in np.ndindex(phase.shape):
        where = " ".join(f"{d}={_grid_word(ds[d].values[i])}" for d, i in zip(phase.dims, idx)
                         if d != "replicate" or ds.sizes["replicate"] > 1)
        code = int(phase.values[idx])
        word = PHASE_FLAGS.get(code, "unknown").replace("_", "-")
        if code in (0, 1, 2):
            lines.append(f"{where}: {word} (P = {float(ds['phase_confidence'].values[idx]):.3f})")
        else:
            why = str(ds["phase_reason"].values[idx]) or STATUS_FLAGS.get(int(ds["status"].values[idx]), "")
            lines.append(f"{where}: {word}: {why}")
    return lines


def _grid_word(v) -> str:
    return f"{v:.4g}" if isinstance(v, (float, np.floating)) else str(v)


def unanalysed_runs(ds: xr.Dataset) -> list[tuple[str, str]]:
    """``(run_id, status word)`` of finished runs without a usable analysis in ``ds``."""
    st = ds["status"].values.ravel()
    ids = ds["run_id"].values.ravel()
    return [(str(r), STATUS_FLAGS[int(s)]) for r, s in zip(ids, st) if int(s) in (1, 6)]


def aggregate_sweep(config, say=None) -> Path:
    """Build the dataset of a sweep and write ``<output>/phase_diagram.nc`` (temporary files
    of killed aggregations are removed first, each told to ``say``)."""
    for tmp in remove_stale(config.output, (DATASET_FILE,)):
        (say or (lambda m: None))(f"removed {tmp}, left by a killed aggregate")
    return write_dataset(build_dataset(config), Path(config.output) / DATASET_FILE)
