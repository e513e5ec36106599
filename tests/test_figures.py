"""Figures are produced from a phase-diagram dataset, also for 1-D grids and single points,
and say what a reader needs: phases as regions (undetermined ones distinct), log axes for
log grids, error bars where errors exist, one panel per v0, a caption with N, run length
and quadrature."""

import json

import matplotlib
import numpy as np
import pytest
import xarray as xr
from matplotlib.container import ErrorbarContainer
from matplotlib.patches import Rectangle

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
    ds.attrs["config"] = json.dumps({"grid": {"eta": list(etas), "v0": list(v0s), "N": list(Ns)},
                                     "model": {"dt": 0.005, "quadrature": "binary", "modes": 6,
                                               "contour_points": 40, "Dr": 0.01},
                                     "run": {"steps": 200000}})
    return ds


def with_statistics(ds):
    """The variables issue 14 adds: an undetermined phase code and 1-sigma errors."""
    ds = ds.copy(deep=True)
    ds["phase"].attrs.update(flag_values=np.array([-1, 0, 1, 2, 3], dtype=np.int8),
                             flag_meanings="unknown solid fluid soft_fluid undetermined")
    ds["phase"][1, 1] = 3
    ds["D_eff_err"] = 0.2 * ds["D_eff"] + 1e-4
    ds["largest_cluster_fraction_err"] = 0.05 + 0 * ds["D_eff"]
    return ds


FIGS = (plots.phase_diagram, plots.d_eff_curves, plots.q_distributions, plots.largest_cluster,
        plots.cluster_sizes, plots.correlations, plots.msd_curves)


@pytest.mark.parametrize("sub", ["full", "one_eta", "single_point"])
def test_all_figures_written_for_grids_and_points(tmp_path, sub):
    ds = synthetic_dataset()
    if sub == "one_eta":
        ds = ds.isel(eta=[1])
    elif sub == "single_point":
        ds = ds.isel(eta=[0], v0=[0], N=[0])
    for fn in FIGS:
        if sub == "full":  # both formats once; the degenerate grids need only to draw
            paths = plots.save_figure(fn(ds), tmp_path / fn.__name__, dpi=100)
        else:
            fig = fn(ds)
            fig.savefig(tmp_path / f"{fn.__name__}.png", dpi=40)
            matplotlib.pyplot.close(fig)
            paths = [tmp_path / f"{fn.__name__}.png"]
        for p in paths:
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


def test_caption_names_system_size_run_length_and_quadrature():
    cap = plots.caption(synthetic_dataset())
    assert "N = 256" in cap and "1000 time units (200,000 steps)" in cap and "binary quadrature" in cap
    assert "N = 64" in plots.caption(synthetic_dataset(), {"N": 64})
    ds = synthetic_dataset()
    cfg = json.loads(ds.attrs["config"])
    cfg["run"]["until"] = {"check_every": 1000, "min_steps": 1000, "confidence": 0.9}
    ds.attrs["config"] = json.dumps(cfg)
    assert "runs of up to 1000 time units (200,000 steps), stopped when settled" in plots.caption(ds)


def test_refined_log_grid_labels_do_not_overlap():
    # nine log-spaced eta values (two refinement rounds of 0.01, 0.0316, 0.1): every
    # grid value gets a tick, at most six get a label, in three digits
    etas = tuple(np.round(np.logspace(-2, -1, 9), 12))
    ax = plots.phase_diagram(synthetic_dataset(etas=etas)).axes[0]
    labels = [t.get_text() for t in ax.xaxis.get_ticklabels()]
    assert np.allclose(ax.get_xticks(), etas) and len(labels) == 9
    shown = [t for t in labels if t]
    assert 3 <= len(shown) <= 6 and all(len(t) <= 6 for t in shown) and shown[0] == "0.01"
    matplotlib.pyplot.close("all")


def test_log_axes_for_log_grids_and_for_a_decade_apart():
    log_eta = synthetic_dataset(etas=(0.01, 0.0215, 0.0464, 0.1))
    ax = plots.phase_diagram(log_eta).axes[0]
    assert ax.get_xscale() == "log" and ax.get_yscale() == "linear"  # v0 0.02, 0.04, 0.06 is linear
    lin = synthetic_dataset(etas=(0.02, 0.04, 0.06, 0.08))
    assert plots.phase_diagram(lin).axes[0].get_xscale() == "linear"
    two = synthetic_dataset(etas=(0.01, 0.1))  # linear cells would reach eta = -0.035
    ax = plots.phase_diagram(two).axes[0]
    assert ax.get_xscale() == "log" and ax.get_xlim()[0] > 0
    matplotlib.pyplot.close("all")


def _hatched(ax):
    return [p for p in ax.patches if isinstance(p, Rectangle) and p.get_hatch()]


def test_phase_regions_mark_undetermined_points_distinctly():
    plain = synthetic_dataset()
    ax = plots.phase_diagram(plain).axes[0]
    assert not _hatched(ax)  # datasets without the code draw as before
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "undetermined" not in labels and "solid" in labels
    ds = with_statistics(plain)
    ds["phase"][3, 0] = -1  # nothing ran here (a non-product grid): white, not undetermined
    ax = plots.phase_diagram(ds).axes[0]
    assert len(_hatched(ax)) == 1
    assert "not analysed" in [t.get_text() for t in ax.get_legend().get_texts()]
    assert "undetermined" in [t.get_text() for t in ax.get_legend().get_texts()]
    # replicates that disagree on the label are undetermined too
    two = xr.concat([plain, plain.assign(phase=plain["phase"].where(plain["eta"] != 0.01, 1))], "replicate")
    two = two.assign_coords(replicate=[0, 1])
    ax = plots.phase_diagram(two).axes[0]
    assert len(_hatched(ax)) == int(((plain["phase"].isel(N=-1, replicate=0) != 1)
                                     & (plain["eta"] == 0.01)).sum())
    matplotlib.pyplot.close("all")


def test_contours_of_the_two_thresholds_are_drawn_and_named():
    ax = plots.phase_diagram(synthetic_dataset()).axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert r"$\langle q\rangle = 3.81$" in labels and r"$\rho_d = 1/2$" in labels
    matplotlib.pyplot.close("all")


def test_error_bars_where_the_dataset_has_errors():
    def bars(fig):
        return [c for c in fig.axes[0].containers if isinstance(c, ErrorbarContainer) and c.has_yerr]

    ds = synthetic_dataset()
    assert not bars(plots.d_eff_curves(ds)) and not bars(plots.largest_cluster(ds))
    ds = with_statistics(ds)
    assert len(bars(plots.d_eff_curves(ds))) == ds.sizes["v0"]
    assert len(bars(plots.largest_cluster(ds))) == ds.sizes["N"]
    assert plots.d_eff_curves(ds).axes[0].get_yscale() == "log"
    ds["D_eff"][0, 0] = -2e-4  # fit noise in a solid: kept on a symlog axis, not dropped
    assert plots.d_eff_curves(ds).axes[0].get_yscale() == "symlog"
    matplotlib.pyplot.close("all")


def test_one_panel_per_v0_and_an_empty_cluster_panel_says_so():
    ds = synthetic_dataset()
    fig = plots.q_distributions(ds)
    panels = [ax for ax in fig.axes if ax.get_title().startswith("$v_0$")]
    assert len(panels) == ds.sizes["v0"]
    ds["cluster_size_distribution"][:, 0] = 0.0  # no defect clusters at the first v0
    fig = plots.cluster_sizes(ds)
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert "no defect clusters" in texts
    matplotlib.pyplot.close("all")


def test_translational_correlation_keeps_negative_values():
    ds = synthetic_dataset()
    ds["Gr"][:] = 1 + 0.3 * np.cos(np.arange(ds.sizes["dx"]))  # G_r - 1 changes sign
    ax = plots.correlations(ds).axes[0]
    assert ax.get_yscale() == "symlog"
    y = np.concatenate([ln.get_ydata() for ln in ax.get_lines() if len(ln.get_ydata()) > 2])
    assert (y < 0).any() and (y > 0).any()
    matplotlib.pyplot.close("all")


def test_palettes_are_colour_blind_safe():
    okabe = {c.lower() for c in plots.OKABE_ITO.values()}
    assert {plots.PHASE_COLORS[w][0].lower() for w in ("solid", "fluid", "soft_fluid")} <= okabe
    rgb = plots._colors(6)[:, :3]
    luminance = rgb @ np.array([0.2126, 0.7152, 0.0722])
    assert luminance.max() < 0.8  # viridis stops before its pale yellow end (luminance 0.87)
