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
``status`` says why; each has its words beside it as a string, ``<label>_label``
(:func:`add_label_words`). Every observable has its 1-sigma error ``<name>_err``; each label
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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from fcsweep import __version__
from fcsweep.analysis.phase import PHASE_FLAGS
from fcsweep.analysis.reasons import reason_flags, reason_value
from fcsweep.io.failures import remove_stale
from fcsweep.io.schema import DONE, PENDING
from fcsweep.io.sweepdir import atomic_write, run_path, run_state
from fcsweep.model.observables import CURVES, LABELS, REASON_CODES, REASONS, RUN_SCALARS, TEXTS
from fcsweep.results.analyze import ANALYSIS_ERROR_FILE, ANALYSIS_FILE, DATASET_FILE, config_settings, read_analysis
# the reductions' names stay importable from here (where they were before fcsweep.results.reduce)
from fcsweep.results.reduce import (FSS_SHUFFLED_VARS, FSS_VARS, LABEL_FLAGS, META, POINT_INPUTS,  # noqa: F401
                                    REPLICATE_VARS, STATUS_CODES, STATUS_FLAGS, STATUS_WORDS, fisher_exponents,
                                    fss_collapses, kthny_common, add_point_labels, attrs_of, flag_attrs, reduce_dataset,
                                    replicate_error_check)

CORE_DIMS = ("eta", "v0", "N")
#: Per-run numbers of the dataset.
SCALAR_VARS = RUN_SCALARS
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
    dims, coords, index = _grid(config, runs)
    shape = tuple(len(coords[d]) for d in dims)
    read = _read_runs(config, runs, dims, index, shape)  # everything first: curve coordinates are unions over runs
    curve_coords = _curve_coords(read.entries)
    ds = xr.Dataset(coords={d: (d, coords[d], attrs_of(d)) for d in dims})
    for c, cc in curve_coords.items():
        ds.coords[c] = (c, cc, attrs_of(c))
    _q_bounds(ds, read.settings)
    _fill_runs(ds, dims, shape, read.entries, curve_coords)
    ds["status"] = (dims, read.status, {**attrs_of("status"), **flag_attrs(STATUS_FLAGS)})
    for v, arr in read.strings.items():
        ds[v] = (dims, arr, attrs_of(v))
    for v, arr in read.codes.items():
        ds[v] = (dims, arr, {**attrs_of(v), **flag_attrs(reason_flags(v.removesuffix("_reason_code")))})
    settings = {**(read.settings or {}), **config_settings(config)}  # the config's label settings rule the points
    reduce_dataset(ds, settings)
    add_label_words(ds)
    ds.attrs = _dataset_attrs(config, len(runs), len(read.entries), settings)
    if read.commits:
        ds.attrs["git_commit"] = " ".join(sorted(read.commits))
    ds.attrs.update(cost_attributes(config))
    return ds


def _grid(config, runs):
    """Dimensions, their coordinate values and value -> index maps of a sweep's grid."""
    dims = _dims(config)
    coords = {}
    for d in dims:
        if d == "replicate":
            coords[d] = np.arange(max(int(getattr(config, "replicates", 1)),
                                      1 + max((r.replicate for r in runs), default=0)), dtype=np.int32)
        else:
            coords[d] = _coord_values([r.params.get(d, np.nan) for r in runs])
    index = {d: {_key(v): i for i, v in enumerate(coords[d])} for d in dims}
    return dims, coords, index


@dataclass
class _Runs:
    """What :func:`_read_runs` found: ``(location, analysis)`` of every analysed run, the
    status flags and strings of the grid, the git commits and the first analysis settings."""

    entries: list
    status: np.ndarray
    strings: dict
    commits: set
    settings: dict | None
    codes: dict


def _run_status(rd: Path):
    """The status word of one run (:data:`STATUS_WORDS`) and its analysis when it has one."""
    rs = run_state(rd)  # the state `fcsweep status` shows
    if rs.state != DONE:
        return rs.state if rs.state in STATUS_CODES else PENDING, None
    if (rd / ANALYSIS_ERROR_FILE).exists():
        return "analysis_failed", None
    try:
        return "analysed", read_analysis(rd / ANALYSIS_FILE)
    except (OSError, KeyError, ValueError):
        return "not_analysed", None


def _read_runs(config, runs, dims, index, shape) -> _Runs:
    """Every run's status and, for the analysed ones, its ``analysis.h5``."""
    out = _Runs([], np.full(shape, STATUS_CODES["missing"], dtype=np.int8),
                {v: np.full(shape, "", dtype=object) for v in STRING_VARS}, set(), None,
                {v: np.full(shape, reason_value("not_analysed"), dtype=np.int8) for v in REASON_CODES})
    for spec in runs:
        loc = tuple(index[d][_key(spec.replicate if d == "replicate" else spec.params.get(d, np.nan))]
                    for d in dims)
        out.strings["run_id"][loc] = spec.run_id
        out.strings["seed"][loc] = str(spec.params.get("seed", ""))
        word, res = _run_status(run_path(config.output, spec.run_id))
        out.status[loc] = STATUS_CODES[word]
        if res is None:
            continue
        out.settings = out.settings or res["settings"]
        for v in REASONS:
            out.strings[v][loc] = str(res["scalars"].get(v, ""))
        for v in REASON_CODES:  # an analysis.h5 older than the codes: not_recorded (0)
            out.codes[v][loc] = int(res["scalars"].get(v, reason_value("not_recorded")))
        try:
            commit = json.loads(res["attrs"].get("parameters_json", "{}")).get("git_commit")
        except ValueError:
            commit = None
        if commit:
            out.commits.add(str(commit))
        out.entries.append((loc, res))
    return out


def _curve_coords(entries) -> dict:
    """Coordinate of every curve: the sorted union of the values found in the runs."""
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
    return curve_coords


def _q_bounds(ds: xr.Dataset, settings) -> None:
    """CF bounds of the q histogram bins from the analysis setting ``q_edges`` (in place)."""
    if settings and "q_edges" in settings:
        lo, hi, nb = settings["q_edges"]
        e = np.linspace(lo, hi, int(nb) + 1)
        if len(e) - 1 == ds.sizes["q_bin"]:
            ds.coords["q_bin"].attrs["bounds"] = "q_bin_bounds"
            ds["q_bin_bounds"] = (("q_bin", "nv"), np.stack([e[:-1], e[1:]], axis=1))  # CF: attributes inherited


def _fill_runs(ds: xr.Dataset, dims, shape, entries, curve_coords) -> None:
    """The per-run numbers, labels and curves of the analysed runs (in place; NaN, or the
    label flag -1, elsewhere)."""
    cindex = {c: {_key(v): i for i, v in enumerate(cc.tolist())} for c, cc in curve_coords.items()}
    data = {v: np.full(shape, np.nan) for v in SCALAR_VARS}
    data["n_structure_frames"] = np.full(shape, np.nan)
    labels = {k: np.full(shape, -1, dtype=np.int8) for k in LABELS}
    curves = {n: np.full(shape + (len(curve_coords[c]),), np.nan) for n, c in CURVES.items()}
    for loc, res in entries:
        sc = res["scalars"]
        for v in SCALAR_VARS:
            data[v][loc] = sc.get(v, np.nan)
        nf = _frames_after_transient(sc)
        if np.isfinite(nf):
            data["n_structure_frames"][loc] = min(nf, res["settings"].get("structure_frames", nf))
        for k in LABELS:
            labels[k][loc] = int(sc[k]) if np.isfinite(sc.get(k, np.nan)) else -1
        for n, c in CURVES.items():
            if n not in res["curves"]:
                continue
            x, y = res["curves"][n]
            ix = cindex[c]
            for xv, yv in zip(np.asarray(x).tolist(), np.asarray(y).tolist()):
                j = ix.get(_key(xv))
                if j is not None:
                    curves[n][loc + (j,)] = yv
    for v, arr in data.items():
        ds[v] = (dims, arr, attrs_of(v))
    for n, c in CURVES.items():
        ds[n] = (dims + [c], curves[n], attrs_of(n))
    for k in LABELS:
        ds[k] = (dims, labels[k], {**attrs_of(k), **flag_attrs(LABEL_FLAGS[k])})


def _dataset_attrs(config, n_runs: int, n_analysed: int, settings) -> dict:
    """Global attributes: CF conventions, provenance, the config and the analysis settings."""
    now = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    cfg = config.to_dict() if hasattr(config, "to_dict") else {}
    return {
        "Conventions": "CF-1.8",
        "title": "fcsweep phase-diagram dataset (Fourier contour model of active deformable cells)",
        "source": f"fcsweep {__version__}",
        "fcsweep_version": __version__,
        "history": f"{now} fcsweep aggregate {getattr(config, 'source', '')}".strip(),
        "references": "Fourier contour cell model; observables as defined in docs/model.md",
        "config": json.dumps(cfg, sort_keys=True, default=str),
        "analysis_settings": json.dumps(settings or {}, sort_keys=True),
        "curve_alignment": "curve coordinates are the union over runs; NaN where a run has no value (no interpolation)",
        "n_runs": np.int32(n_runs),
        "n_analysed": np.int32(n_analysed),
    }


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
        rs = run_state(run_path(config.output, spec.run_id))
        st = rs.status or {}
        for k in totals:
            totals[k] += float(st.get(k) or 0.0)
        if rs.state == DONE and st.get("stop_reason", "steps") in stops:
            stops[st.get("stop_reason", "steps")] += 1
    out = {COST_ATTRIBUTES[k]: np.float64(v) for k, v in totals.items()}
    out.update(runs_settled=np.int32(stops["settled"]), runs_at_cap=np.int32(stops["steps"]))
    return out


def add_label_words(ds: xr.Dataset) -> None:
    """Add ``<name>_label``, the words of every int8 label with CF flags (``phase_label``:
    "solid", "fluid", ...), beside the codes: xarray does not decode ``flag_meanings``.
    Reason codes get none (their words are the ``<label>_reason`` texts); a code without a
    meaning reads "unknown"."""
    for v in list(ds.data_vars):
        da = ds[v]
        if da.dtype != np.int8 or "flag_meanings" not in da.attrs or v.endswith("_reason_code"):
            continue
        words = dict(zip(np.atleast_1d(da.attrs["flag_values"]).tolist(), str(da.attrs["flag_meanings"]).split()))
        text = np.array([words.get(int(c), "unknown") for c in da.values.ravel()], dtype=object).reshape(da.shape)
        ds[f"{v}_label"] = (da.dims, text, {"long_name": f"{v} as a word (the flag_meanings entry of its code)"})


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
        elif v in STRING_VARS or ds[v].dtype == object:
            enc[v] = {"dtype": "S1"}
    return atomic_write(path, lambda tmp: ds.to_netcdf(tmp, format="NETCDF4", engine="netcdf4", encoding=enc),
                        fsync=True)


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
    unanalysed = (STATUS_CODES["not_analysed"], STATUS_CODES["analysis_failed"])
    return [(str(r), STATUS_FLAGS[int(s)]) for r, s in zip(ids, st) if int(s) in unanalysed]


def aggregate_sweep(config, say=None) -> Path:
    """Build the dataset of a sweep and write ``<output>/phase_diagram.nc`` (temporary files
    of killed aggregations are removed first, each told to ``say``)."""
    for tmp in remove_stale(config.output, (DATASET_FILE,)):
        (say or (lambda m: None))(f"removed {tmp}, left by a killed aggregate")
    return write_dataset(build_dataset(config), Path(config.output) / DATASET_FILE)
