"""Figures are produced from a phase-diagram dataset, also for 1-D grids and single points."""

import numpy as np
import pytest
import xarray as xr

from fcsweep.analysis import figures as plots
from fcsweep.model.lattice import hexagonal_lattice


def synthetic_dataset(etas=(0.01, 0.03, 0.06, 0.1), v0s=(0.02, 0.04, 0.06), Ns=(64, 256)):
    rng = np.random.default_rng(0)
    E, V, Nn = np.meshgrid(etas, v0s, Ns, indexing="ij")
    shape = E.shape + (1,)
    D = np.exp(-(E / V) * 8)[..., None]
    q = (3.6 + 0.5 * V / (E + 0.02))[..., None]
    rho = np.clip(0.1 + 6 * V / (E + 0.05) * 0.1, 0, 1)[..., None]
    qb = np.linspace(3.545, 5.035, 150)
    s = np.arange(1, 257)
    t = np.linspace(0, 100, 30)
    r = (np.arange(50) + 0.5) * 0.2
    dims = ["eta", "v0", "N", "replicate"]
    ds = xr.Dataset(coords={"eta": list(etas), "v0": list(v0s), "N": list(Ns), "replicate": [0],
                            "q_bin": qb, "cluster_size": s, "lag_time": t, "r": r, "dx": r})
    ds["D_eff"] = (dims, D)
    ds["q_mean"] = (dims, q)
    ds["rho_d"] = (dims, rho)
    ds["largest_cluster_fraction"] = (dims, rho ** 2)
    ds["phase"] = (dims, np.where(D < 1e-3, 0, np.where(q > 3.81, 2, 1)).astype(np.int8))
    ds["q_hist"] = (dims + ["q_bin"], np.exp(-((qb - q[..., None]) / 0.05) ** 2))
    ds["cluster_size_distribution"] = (dims + ["cluster_size"],
                                       np.broadcast_to(1e4 * s ** -2.05, shape + s.shape).copy())
    ds["msd"] = (dims + ["lag_time"], D[..., None] * t + 1e-4)
    ds["G6"] = (dims + ["r"], np.broadcast_to(r ** -0.25, shape + r.shape).copy())
    ds["Gr"] = (dims + ["dx"], 1 + rng.uniform(0, 1, shape + r.shape))
    return ds


FIGS = (plots.phase_diagram, plots.q_distributions, plots.largest_cluster,
        plots.cluster_sizes, plots.correlations, plots.msd_curves)


@pytest.mark.parametrize("sub", ["full", "one_eta", "single_point"])
def test_all_figures_written_for_grids_and_points(tmp_path, sub):
    ds = synthetic_dataset()
    if sub == "one_eta":
        ds = ds.isel(eta=[1])
    elif sub == "single_point":
        ds = ds.isel(eta=[0], v0=[0], N=[0])
    for fn in FIGS:
        for p in plots.save_figure(fn(ds), tmp_path / fn.__name__):
            assert p.exists() and p.stat().st_size > 1000


def test_phase_diagram_with_missing_points(tmp_path):
    ds = synthetic_dataset()
    ds["D_eff"][0, 0] = np.nan
    ds["q_mean"][:] = np.nan  # no contour can be drawn: skipped, no crash
    paths = plots.save_figure(plots.phase_diagram(ds), tmp_path / "pd")
    assert all(p.stat().st_size > 1000 for p in paths)


def test_snapshot_draws_every_cell_with_periodic_copies(tmp_path):
    pos, box = hexagonal_lattice(64)
    rng = np.random.default_rng(2)
    a = 0.1 * rng.uniform(-1, 1, (64, 5))
    b = 0.1 * rng.uniform(-1, 1, (64, 5))
    polys, owner = plots.cell_polygons(pos, rng.uniform(0, 6, 64), a, b, box)
    assert set(owner.tolist()) == set(range(64))
    assert len(polys) > 64  # cells crossing the box edges are drawn on both sides
    q = np.full(64, 3.6)
    fig = plots.snapshot(pos, np.zeros(64), a, b, box, q, np.arange(64) % 7 == 0)
    paths = plots.save_figure(fig, tmp_path / "snap")
    assert [p.suffix for p in paths] == [".png", ".pdf"]
    assert all(p.stat().st_size > 1000 for p in paths)


def test_log_binned_cluster_density_recovers_power_law():
    s = np.arange(1, 5001)
    counts = 1e6 * s ** (-187 / 91)
    c, d = plots.log_binned(s, counts)
    slope = np.polyfit(np.log(c[2:-2]), np.log(d[2:-2]), 1)[0]
    assert slope == pytest.approx(-187 / 91, abs=0.1)
