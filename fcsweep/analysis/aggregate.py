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

Replicates: ``<name>_rmean`` and ``<name>_rmean_err`` reduce the ``replicate``
dimension (:func:`fcsweep.analysis.stats.combine`: plain mean, propagated error scaled
up by sqrt(chi2/dof) when the replicates scatter more than their errors allow) and
``<name>_rchi2`` is that reduced chi-square, ~1 when the per-run errors are honest.
``phase_point`` and ``percolated_point`` are the labels of these replicate means.

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
                                    classify_percolation, classify_phase, flag_attrs)
from fcsweep.analysis.cage import bounds_d_eff, broken_probability
from fcsweep.analysis.fss import FSS_BOOTSTRAP, fss_collapse
from fcsweep.analysis.percolation import fisher_observables
from fcsweep.analysis.stats import combine
from fcsweep.io.observables import OBSERVABLES, REPLICATE_REDUCED, RUN_SCALARS, TEXTS
from fcsweep.io.status import read_status
from fcsweep.io.failures import remove_stale
from fcsweep.io.sweepdir import atomic_write, run_path, run_state
from fcsweep.model.parameters import PARAMETERS
from fcsweep.analysis.pipeline import (ANALYSIS_ERROR_FILE, ANALYSIS_FILE, CURVES, DATASET_FILE,
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
    reduced = {}
    for v in REPLICATE_VARS:
        x = ds[v].transpose(..., "replicate").values
        e = ds[f"{v}_err"].transpose(..., "replicate").values
        out = np.full(x.shape[:-1] + (3,), np.nan)
        for idx in np.ndindex(x.shape[:-1]):
            c = combine(x[idx], e[idx])
            out[idx] = (c.mean, c.err, c.chi2_dof)
        reduced[v] = out
        dims = [d for d in ds[v].dims if d != "replicate"]
        ln = META[v][0]
        ds[f"{v}_rmean"] = (dims, out[..., 0], {"long_name": f"replicate mean of {ln}", "units": "1"})
        ds[f"{v}_rmean_err"] = (dims, out[..., 1], {"long_name": f"1-sigma error of {v}_rmean", "units": "1"})
        ds[f"{v}_rchi2"] = (dims, out[..., 2], {
            "long_name": f"reduced chi-square of the replicates of {v} about their mean (~1: honest errors)",
            "units": "1"})
    ok = ds["msd_diffusive"].fillna(0).astype(bool) & ds["msd_long_enough"].fillna(0).astype(bool)
    ok = ok.transpose(..., "replicate").values.all(axis=-1)
    long_ok = ds["msd_long_enough"].fillna(0).astype(bool).transpose(..., "replicate").values.all(axis=-1)
    bound = ds["cage_d_eff_bound"].transpose(..., "replicate").values
    bound_ok = np.all(bounds_d_eff(bound), axis=-1)
    dims = [d for d in ds["phase"].dims if d != "replicate"]
    shape = ok.shape
    phase = np.full(shape, -1, dtype=np.int8)
    pconf = np.full(shape, np.nan)
    perc = np.full(shape, -1, dtype=np.int8)
    cconf = np.full(shape, np.nan)
    for idx in np.ndindex(shape):
        D, q, r = reduced["D_eff"][idx], reduced["q_mean"][idx], reduced["rho_d"][idx]
        c = reduced["cage_msd_ratio"][idx]
        p_broken = broken_probability(c[0], c[1]) if bound_ok[idx] and c[1] > 0 else float("nan")
        trusted = bool(ok[idx])
        if np.all(np.isfinite(reduced["D_eff_cr"][idx][:2])):  # the solid test (pipeline.solid_test_estimate)
            D, trusted = reduced["D_eff_cr"][idx], bool(long_ok[idx])
        lab = classify_phase(D[0], D[1], q[0], q[1], diffusion_ok=trusted,
                             diffusion_note="a replicate's D_eff is not trustworthy", cage_broken=p_broken,
                             cage_note=f"replicate-mean cage-relative MSD {c[0]:.3g} +- {c[1]:.2g} a^2",
                             min_confidence=conf)
        phase[idx], pconf[idx] = lab.code, lab.confidence
        lab = classify_percolation(r[0], r[1], min_confidence=conf)
        perc[idx], cconf[idx] = lab.code, lab.confidence
    ds["phase_point"] = (dims, phase, {**_attrs("phase_point"), **flag_attrs(PHASE_FLAGS)})
    ds["phase_point_confidence"] = (dims, pconf, _attrs("phase_point_confidence"))
    ds["percolated_point"] = (dims, perc, {**_attrs("percolated_point"), **flag_attrs(PERCOLATION_FLAGS)})
    ds["percolated_point_confidence"] = (dims, cconf, _attrs("percolated_point_confidence"))
    _kthny_point(ds)
    _fisher_exponents(ds)
    _fss(ds)


def _kthny_point(ds: xr.Dataset) -> None:
    """``kthny_point``: the replicates' common KTHNY label, its lowest confidence, or
    undetermined when they differ or one is undetermined (in place)."""
    k = ds["kthny"].transpose(..., "replicate").values
    c = ds["kthny_confidence"].transpose(..., "replicate").values
    same = np.all(k == k[..., :1], axis=-1) & np.all(k >= 0, axis=-1)
    point = np.where(same, k[..., 0], np.where(np.any(k >= 0, axis=-1), KTHNY_UNDETERMINED, -1)).astype(np.int8)
    conf = np.where(same, np.nanmin(np.where(np.isfinite(c), c, np.inf), axis=-1), np.nan)
    conf = np.where(np.isinf(conf), np.nan, conf)
    dims = [d for d in ds["kthny"].dims if d != "replicate"]
    ds["kthny_point"] = (dims, point, {**_attrs("kthny_point"), **flag_attrs(KTHNY_FLAGS)})
    ds["kthny_point_confidence"] = (dims, conf, _attrs("kthny_point_confidence"))


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


def _fss(ds: xr.Dataset, n_bootstrap: int = FSS_BOOTSTRAP) -> None:
    """Finite-size collapse of the largest defect cluster, one per v0 (in place).

    Only for datasets with two or more N.  Each slice of the dimensions other than
    ``eta``, ``N`` and ``replicate`` (v0 and any other swept parameter) is one fit:
    its points are the replicate means ``largest_cluster_fraction_rmean`` (with their
    errors) against ``rho_d_rmean`` over every eta and N, because eta moves rho_d
    through the threshold at fixed v0 while N supplies the sizes
    (:func:`fcsweep.analysis.fss.fss_collapse`; the error of rho_d is not used).
    """
    if ds.sizes.get("N", 1) < 2:
        return
    names = ("rho_d_rmean", "largest_cluster_fraction_rmean", "largest_cluster_fraction_rmean_err")
    rho, pmax, err = (ds[v].transpose("eta", "N", ...) for v in names)
    dims = list(rho.dims[2:])
    shape = rho.shape[2:]
    Ns = np.broadcast_to(ds["N"].values.astype(float)[None, :], rho.shape[:2])
    out = np.full(shape + (len(FSS_VARS),), np.nan)
    why = np.full(shape, "", dtype=object)
    for idx in np.ndindex(shape):
        sl = (slice(None), slice(None)) + idx
        r, p, e = rho.values[sl].ravel(), pmax.values[sl].ravel(), err.values[sl].ravel()
        n = Ns.ravel()
        ok = np.isfinite(r) & np.isfinite(p)
        if np.unique(n[ok]).size < 2:
            why[idx] = "fewer than two N with finite rho_d and largest_cluster_fraction"
            continue
        fit = fss_collapse(r[ok], p[ok], n[ok], np.where(np.isfinite(e[ok]), e[ok], 0.0), n_bootstrap=n_bootstrap)
        out[idx] = [fit[k.removeprefix("fss_")] for k in FSS_VARS]
        why[idx] = fit.reason
    for k, name in enumerate(FSS_VARS):
        ds[name] = (dims, out[..., k], _attrs(name))
    ds["fss_reason"] = (dims, why, _attrs("fss_reason"))


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
