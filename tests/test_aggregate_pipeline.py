"""End to end: synthetic H5MD trajectories -> analyze -> aggregate (NetCDF) -> plot.

The trajectories are written directly with h5py in the contract layout (no simulation),
so the test is fast and independent of the engine: a 2 x 2 grid (eta, v0) of N = 36 runs;
large eta gives a vibrating lattice (solid), small eta a diffusing, deformed fluid.
"""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import xarray as xr

from fcsweep.results.aggregate import STATUS_FLAGS, aggregate_sweep, build_dataset
from fcsweep.results.figures import plot_sweep
from fcsweep.results.analyze import analyze_run, analyze_sweep, read_analysis
from fcsweep.analysis.phase import PHASE_SOLID, PHASE_UNDETERMINED
from fcsweep.model.lattice import hexagonal_lattice

config_mod = pytest.importorskip("fcsweep.config")

YAML = """
output: {out}
seed: 1
replicates: 1
grid:
  eta: [0.01, 0.1]
  v0: [0.03, 0.06]
model: {{N: 36, density: 0.95, Dr: 1.0, dt: 0.005, modes: 6}}
run: {{steps: 2000, sample_every: 50, checkpoint_every: 500, transient: 0.2}}
"""


def write_trajectory(path, params, *, T=121, fluid=False, seed=0):
    """Synthetic run in the contract's H5MD layout."""
    rng = np.random.default_rng(seed)
    N = int(params["N"])
    pos0, box = hexagonal_lattice(N, params.get("density", 0.95))
    dtf = params["dt"] * 50
    if fluid:  # random walk with D = 0.2 D0 plus vibrations
        D = 0.2 * params["v0"] ** 2 / (2 * params["Dr"])
        steps = rng.normal(scale=np.sqrt(2 * D * dtf), size=(T, N, 2))
        steps[0] = 0
        x = pos0 + np.cumsum(steps, axis=0)
        amp = 0.25
    else:
        x = pos0 + 0.001 * rng.standard_normal((T, N, 2))
        amp = 0.02
    image = np.floor_divide(x, box).astype(np.int32)
    wrapped = x - image * box
    a = amp * rng.uniform(-1, 1, (T, N, 5)) / np.arange(2, 7)
    b = amp * rng.uniform(-1, 1, (T, N, 5)) / np.arange(2, 7)
    steps_i = np.arange(T, dtype=np.int64) * 50
    with h5py.File(path, "w") as f:
        f.create_group("h5md").attrs["version"] = [1, 1]
        f["h5md"].create_group("creator").attrs.update({"name": "fcsweep", "version": "test"})
        cells = f.create_group("particles/cells")
        bx = cells.create_group("box")
        bx.attrs["dimension"] = 2
        bx.create_dataset("edges", data=box)
        for name, val in (("position", wrapped), ("image", image),
                          ("theta", rng.uniform(0, 6.28, (T, N))), ("shape_a", a), ("shape_b", b)):
            g = cells.create_group(name)
            g.create_dataset("step", data=steps_i)
            g.create_dataset("time", data=steps_i * params["dt"])
            g.create_dataset("value", data=val)
        par = f.create_group("parameters")
        for k, v in params.items():
            par.attrs[k] = v
        par.attrs["config_json"] = json.dumps({"test": True})


def fake_done_runs(cfg, out, *, fluid_below=None, **kwargs):
    """Give every run of ``cfg`` a synthetic trajectory and a "done" status under ``out/runs``
    (``fluid_below``: runs with eta below it are fluid; ``kwargs`` go to write_trajectory)."""
    for k, spec in enumerate(cfg.runs()):
        rd = out / "runs" / spec.run_id
        rd.mkdir(parents=True)
        fluid = fluid_below is not None and spec.params["eta"] < fluid_below
        write_trajectory(rd / "trajectory.h5", {**dict(spec.params), "run_id": spec.run_id}, fluid=fluid, seed=k,
                         **kwargs)
        (rd / "status.json").write_text(json.dumps({"status": "done", "reason": ""}))


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep")
    cfg = config_mod.parse_config(YAML.format(out=out))
    runs = cfg.runs()
    assert len(runs) == 4
    for k, spec in enumerate(runs):
        rd = out / "runs" / spec.run_id
        rd.mkdir(parents=True)
        params = {**dict(spec.params), "run_id": spec.run_id}
        if k == 3:  # a failed run: reported, NaN in the dataset
            (rd / "status.json").write_text(json.dumps({"status": "failed", "reason": "unstable"}))
            continue
        write_trajectory(rd / "trajectory.h5", params, fluid=spec.params["eta"] < 0.05, seed=k)
        (rd / "status.json").write_text(json.dumps({"status": "done", "reason": ""}))
    results = analyze_sweep(cfg, workers=1)
    return cfg, runs, results


def test_analyze_reports_every_run_and_skips_when_up_to_date(sweep):
    cfg, runs, results = sweep
    st = {rid: s for rid, s, _ in results}
    assert [st[r.run_id] for r in runs] == ["done", "done", "done", "skipped"]
    assert "failed" in dict((rid, m) for rid, _, m in results)[runs[3].run_id]
    again = analyze_sweep(cfg)
    assert [s for _, s, _ in again][:3] == ["skipped"] * 3
    res = read_analysis(cfg.output / "runs" / runs[2].run_id / "analysis.h5")
    assert res["settings"]["transient"] == 0.2
    assert res["attrs"]["fcsweep_version"]
    # solid run (eta = 0.1): D_eff tiny, labelled solid; fluid run clearly diffusive
    assert res["scalars"]["D_eff"] < 1e-3 and res["scalars"]["phase"] == PHASE_SOLID
    fl = read_analysis(cfg.output / "runs" / runs[0].run_id / "analysis.h5")["scalars"]
    assert 0.05 < fl["D_eff"] < 0.6  # input 0.2, 33 frames of 36 cells: noisy
    assert fl["q_mean"] > res["scalars"]["q_mean"] > 3.5449


def test_analysis_pool_gives_the_serial_results_without_oversubscribing(sweep, monkeypatch):
    """workers = 5 on '2 cores': two processes, one freud thread each, same numbers."""
    import fcsweep.results.analyze as pipeline

    cfg, runs, _ = sweep
    serial = {r.run_id: read_analysis(cfg.output / "runs" / r.run_id / "analysis.h5")["scalars"] for r in runs[:3]}
    seen = []
    real = pipeline.ProcessPoolExecutor
    monkeypatch.setattr("fcsweep.io.machine.available_cores", lambda: 2)
    monkeypatch.setattr(pipeline, "ProcessPoolExecutor",
                        lambda **kw: seen.append((kw["max_workers"], kw["initargs"])) or real(**kw))
    results = analyze_sweep(cfg, workers=5, force=True)
    assert seen == [(2, (1,))]
    assert [s for _, s, _ in results] == ["done", "done", "done", "skipped"]
    for r in runs[:3]:
        pooled = read_analysis(cfg.output / "runs" / r.run_id / "analysis.h5")["scalars"]
        for k in ("D_eff", "q_mean", "rho_d", "psi6"):
            assert pooled[k] == serial[r.run_id][k] or (np.isnan(pooled[k]) and np.isnan(serial[r.run_id][k])), k


def test_bad_trajectory_is_reported_not_raised(tmp_path, sweep):
    cfg, runs, _ = sweep
    bad = tmp_path / "trajectory.h5"
    bad.write_bytes(b"not hdf5")
    from fcsweep.io.trajectory import TrajectoryError
    with pytest.raises(TrajectoryError, match="unreadable"):
        analyze_run(bad, tmp_path / "analysis.h5")


def test_dataset_round_trip_and_contents(sweep, tmp_path):
    cfg, runs, _ = sweep
    path = aggregate_sweep(cfg)
    assert path.name == "phase_diagram.nc"
    ds = build_dataset(cfg)
    with xr.open_dataset(path) as back:
        back = back.load()
    ds.attrs["history"] = back.attrs["history"]  # timestamps differ between the two builds
    xr.testing.assert_identical(ds, back)
    assert ds.attrs["Conventions"] == "CF-1.8"
    assert list(ds["D_eff"].dims) == ["eta", "v0", "N", "replicate"]
    for v in ds.variables:
        if v not in ("nv", "q_bin_bounds"):  # CF: a bounds variable inherits its attributes
            assert "long_name" in ds[v].attrs, v
    for v in ("D_eff", "q_mean", "q_hist", "rho_d", "largest_cluster_fraction", "psi6", "msd",
              "G6", "Gr", "phase", "percolated", "status", "D_eff_err"):
        assert v in ds
        assert "units" in ds[v].attrs, v
    assert ds["q_bin"].attrs["bounds"] == "q_bin_bounds"  # CF bounds carry no units
    failed = dict(eta=runs[3].params["eta"], v0=runs[3].params["v0"])
    assert np.isnan(ds["D_eff"].sel(failed).item())
    assert STATUS_FLAGS[ds["status"].sel(failed).item()] == "failed"
    assert ds["phase"].sel(failed).item() == -1
    solid = ds.sel(eta=0.1, v0=0.03).squeeze()
    assert solid["phase"].item() == PHASE_SOLID and solid["psi6"].item() > 0.9
    assert "flag_meanings" in ds["phase"].attrs
    assert "undetermined" in ds["phase"].attrs["flag_meanings"].split()
    # every observable carries an error and every label a confidence and a reason
    for v in ("D_eff", "D_s", "q_mean", "q_frac_above", "rho_d", "largest_cluster_fraction",
              "largest_cluster_fraction_shuffled", "psi6"):
        assert f"{v}_err" in ds, v
    # the shuffled control: a largest cluster never holds more than the defects there are
    shuf = ds["largest_cluster_fraction_shuffled"].values
    fin = np.isfinite(shuf)
    assert fin.any() and np.all(shuf[fin] <= ds["rho_d"].values[fin] + 1e-12)
    assert solid["phase_confidence"].item() > 0.95 and solid["phase_reason"].item().startswith("P(solid)")
    # CF-1.8 knows no int64; strings are character arrays
    assert not [v for v in ds.variables if ds[v].dtype == np.int64]
    assert solid["seed"].item() == str(runs[2].params["seed"])


def test_figures_are_written(sweep, tmp_path):
    cfg, runs, _ = sweep
    paths = plot_sweep(cfg, outdir=tmp_path / "fig")
    assert len(paths) == 18  # 9 figures (the KTHNY summary included) x (PNG, PDF)
    paths += plot_sweep(cfg, run=0, frame=-1, outdir=tmp_path / "fig")
    for p in paths:
        assert p.exists() and p.stat().st_size > 1000, p


def test_any_swept_parameter_becomes_a_dimension(tmp_path):
    """Sweeping Dr (a float) and quadrature (a string) besides eta gives dims
    (eta, v0, N, Dr, quadrature, replicate), with CF attributes on the new coordinates."""
    text = YAML.replace("  eta: [0.01, 0.1]\n  v0: [0.03, 0.06]\n",
                        "  eta: [0.1]\n  Dr: [0.003, 0.01]\n  quadrature: [binary, arc]\n")
    text = text.replace("v0: [0.03, 0.06]", "").replace("Dr: 1.0, ", "v0: 0.03, ")
    cfg = config_mod.parse_config(text.format(out=tmp_path))
    fake_done_runs(cfg, tmp_path)
    analyze_sweep(cfg, workers=1)
    ds = xr.open_dataset(aggregate_sweep(cfg))
    assert ds["D_eff"].dims == ("eta", "v0", "N", "Dr", "quadrature", "replicate")
    assert ds["D_eff"].shape == (1, 1, 1, 2, 2, 1)
    assert "long_name" in ds["Dr"].attrs and "long_name" in ds["quadrature"].attrs
    assert np.all(np.isfinite(ds["q_mean"].values))
    paths = plot_sweep(cfg)
    assert paths and all(p.stat().st_size > 0 for p in paths)


def test_initial_becomes_a_string_dimension(tmp_path):
    """Sweeping the start (``initial: [lattice, disordered]``) gives a string coordinate
    ``initial`` with the table's long name and no units, one label per start."""
    text = YAML.replace("  eta: [0.01, 0.1]\n  v0: [0.03, 0.06]\n", "  eta: [0.1]\n  initial: [lattice, disordered]\n")
    text = text.replace("v0: [0.03, 0.06]", "").replace("Dr: 1.0, ", "Dr: 1.0, v0: 0.03, ")
    cfg = config_mod.parse_config(text.format(out=tmp_path))
    fake_done_runs(cfg, tmp_path)
    analyze_sweep(cfg, workers=1)
    ds = xr.open_dataset(aggregate_sweep(cfg))
    assert ds["phase"].dims == ("eta", "v0", "N", "initial", "replicate")
    assert [str(v) for v in ds["initial"].values] == ["disordered", "lattice"]
    assert ds["initial"].attrs == {"long_name": "initial state of the run"}
    assert ds["phase"].shape == (1, 1, 1, 2, 1)


def _short_sweep(out, replicates=1, Dr=1.0):
    cfg = config_mod.parse_config(YAML.replace("replicates: 1", f"replicates: {replicates}")
                                  .replace("Dr: 1.0", f"Dr: {Dr}").format(out=out))
    fake_done_runs(cfg, out, fluid_below=0.05)
    analyze_sweep(cfg)
    return cfg


def test_replicates_reduce_to_a_mean_with_error_and_a_chi2(tmp_path):
    """3 replicates: <name>_rmean is their mean, its error at least the propagated one,
    <name>_rchi2 the scatter check; the point label comes from the replicate means."""
    cfg = _short_sweep(tmp_path, replicates=3)
    ds = xr.open_dataset(aggregate_sweep(cfg)).load()
    for v in ("D_eff", "q_mean", "rho_d", "psi6", "largest_cluster_fraction", "q_frac_above"):
        assert ds[f"{v}_rmean"].dims == ("eta", "v0", "N")
        np.testing.assert_allclose(ds[f"{v}_rmean"], ds[v].mean("replicate"), rtol=1e-12)
    prop = np.sqrt((ds["D_eff_err"] ** 2).sum("replicate")) / 3
    assert np.all(ds["D_eff_rmean_err"] >= prop - 1e-15)
    assert np.all(np.isfinite(ds["D_eff_rchi2"]))
    assert ds["phase_point"].sel(eta=0.1).values.ravel().tolist() == [PHASE_SOLID] * 2
    assert np.all(ds["phase_point_confidence"].sel(eta=0.1) > 0.95)


def test_run_too_short_for_its_persistence_time_is_undetermined(tmp_path):
    """Dr = 0.01: 1/Dr = 100 time units, but the runs span 0.6: no label, a reason."""
    cfg = _short_sweep(tmp_path, Dr=0.01)
    ds = xr.open_dataset(aggregate_sweep(cfg)).load()
    assert np.all(ds["phase"].values == PHASE_UNDETERMINED)
    assert all("too short" in r for r in ds["phase_reason"].values.ravel())
    assert np.all(ds["msd_long_enough"].values == 0)


def test_failed_analysis_leaves_no_stale_file_and_aggregate_names_it(tmp_path):
    from click.testing import CliRunner

    from fcsweep.cli import cli

    cfg = _short_sweep(tmp_path)
    victim = cfg.runs()[1]
    traj = tmp_path / "runs" / victim.run_id / "trajectory.h5"
    assert (traj.parent / "analysis.h5").exists()
    traj.write_bytes(traj.read_bytes()[:2000])  # truncated
    res = dict((r, s) for r, s, _ in analyze_sweep(cfg, force=True))
    assert res[victim.run_id] == "failed"
    assert not (traj.parent / "analysis.h5").exists()
    cfg_file = tmp_path / "sweep.yaml"
    cfg_file.write_text(YAML.format(out=tmp_path))
    out = CliRunner().invoke(cli, ["aggregate", str(cfg_file)])
    assert out.exit_code == 1
    assert victim.run_id in out.output and "analysis_failed" in out.output


def test_phase_diagram_passes_the_cf_checker(sweep):
    """IOOS compliance-checker cf:1.8 (optional extra 'cf'): no errors, no warnings."""
    pytest.importorskip("compliance_checker")
    import subprocess
    import sys

    cfg, _, _ = sweep
    path = aggregate_sweep(cfg)
    exe = Path(sys.executable).with_name("compliance-checker")
    r = subprocess.run([str(exe), "--test=cf:1.8", "--format=json", "-o", "-", str(path)],
                       capture_output=True, text=True, timeout=300)
    report = json.loads(r.stdout)
    scored = report["cf:1.8"]
    assert scored["high_count"] == 0 and scored["medium_count"] == 0 and scored["low_count"] == 0, scored


def test_fisher_exponent_per_point_pools_replicates():
    """Two replicates of exact critical percolation (N = 1024, 1000 realisations each) in
    a dataset: the point's tau pools both and is 187/91 within 2 sigma; a point without
    defects says so."""
    from percolation_lattice import cluster_counts

    from fcsweep.results.reduce import fisher_exponents
    from fcsweep.analysis.percolation import TAU_2D

    c = np.stack([cluster_counts(32, 1000, p=0.5, seed=s) for s in (21, 22)])  # (replicate, size)
    cs = np.zeros((2, 2, 1024))
    cs[0, :, :c.shape[1]] = c[:, :1024]
    ds = xr.Dataset({"cluster_size_distribution": (("eta", "replicate", "cluster_size"), cs)},
                    coords={"eta": [0.03, 0.1], "replicate": [0, 1], "N": 1024,
                            "cluster_size": np.arange(1, 1025, dtype=np.int32)})
    ds = ds.expand_dims("N").transpose("eta", "N", "replicate", "cluster_size")
    fisher_exponents(ds)
    crit = ds.sel(eta=0.03).squeeze()
    assert abs(crit["tau_fisher"].item() - TAU_2D) < 2 * crit["tau_fisher_err"].item()
    assert ds["tau_fisher_reason"].sel(eta=0.1).item() == "no defect clusters"


def test_replicate_error_check_reports_the_median_chi2():
    from fcsweep.results.reduce import replicate_error_check

    ds = xr.Dataset({"D_eff_rchi2": (("eta",), [0.8, 1.2, np.nan, 5.0])})
    assert replicate_error_check(ds) == {"D_eff": (1.2, 3)}
