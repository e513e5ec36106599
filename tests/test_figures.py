"""Figures are produced from a phase-diagram dataset, also for 1-D grids and single points,
and say what a reader needs: phases as regions (undetermined ones distinct, with their
reason), log axes for log grids, error bars where errors exist, hollow markers where the
label rule did not accept a value, one panel per v0, a caption with N, run length and
quadrature, units on eta, v0 and t; they fit a paper column, draw into given axes, leave
matplotlib's backend alone, and movies are frames of whole H.264 macro blocks."""

import json

import matplotlib
import numpy as np
import pytest
import xarray as xr
from matplotlib.container import ErrorbarContainer
from fake_trajectory import FakeTrajectory
from matplotlib.patches import Rectangle

from fcsweep.results import figures as plots
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


def _defect_share(n_side, width, dpi, defect_every=2):
    """Share of the axes' pixels drawn in the defect colour for a frame of n_side^2 cells
    with every ``defect_every``-th cell a defect."""
    from fcsweep.results.figures.frames import FrameArtist

    N = n_side * n_side
    pos, box = hexagonal_lattice(N)
    art = FrameArtist(box, width=width, dpi=dpi)
    art.draw(pos, np.zeros(N), np.zeros((N, 5)), np.zeros((N, 5)), np.full(N, 3.6), np.arange(N) % defect_every == 0)
    img = art.rgb().astype(float)
    bb = art.ax.get_window_extent()
    h = img.shape[0]
    inner = img[int(h - bb.y1) + 2:int(h - bb.y0) - 2, int(bb.x0) + 2:int(bb.x1) - 2]
    vermillion = np.array([213, 94, 0], float)
    return float(np.mean(np.linalg.norm(inner - vermillion, axis=-1) < 60)), art._cell_points()


def test_defect_marks_of_a_crowded_frame_do_not_cover_the_cells():
    """25 600 cells in a column-wide snapshot at 300 dpi: a cell is about 1 point (4 pixels)
    across (a 10^5-cell run: half a point). Half the cells are defects. Outlines, drawn at
    least a pixel wide, are left off below 2 points and the defect dots shrink with the
    cells, so the defect colour covers a few per cent of the picture and the cells' q shows;
    with outlines and 1-point dots it covered nearly all of it (the 10^5 snapshot was one
    vermillion square). Cells larger than 2 points keep their outlines."""
    share, d = _defect_share(160, 3.4, 300)
    assert d < 2.0
    assert share < 0.25
    share_big, d_big = _defect_share(8, 3.4, 100)
    assert d_big > 2.0
    assert 0.02 < share_big < 0.5


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


def test_caption_gives_the_run_lengths_of_extended_runs():
    # runs extended past the config's 1000 time units (run.until, raised run.steps) are
    # described by what ran, not by the config
    ds = synthetic_dataset()
    t_end = np.full(ds["phase"].shape, 1000.0)
    t_end.flat[0], t_end.flat[1] = 2000.0, 3500.0
    ds["t_end"] = (ds["phase"].dims, t_end)
    assert "runs of 1000-3500 time units" in plots.caption(ds)
    ds["t_end"] = (ds["phase"].dims, np.full(ds["phase"].shape, 1000.0))
    assert "runs of 1000 time units (200,000 steps)" in plots.caption(ds)


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
    rgb = plots.common.value_colors(6)[:, :3]
    luminance = rgb @ np.array([0.2126, 0.7152, 0.0722])
    assert luminance.max() < 0.8  # viridis stops before its pale yellow end (luminance 0.87)


# ------------------------------------------------------------------ what is decided, units, sizes

def _undetermined(ds, reasons):
    """``with_statistics`` plus a reason per run; the points of ``reasons`` (eta index,
    v0 index) -> text are undetermined."""
    ds = with_statistics(ds)
    ds["phase"][1, 1] = 1  # only the points named below are undetermined
    why = np.full(ds["phase"].shape, "P(fluid) = 0.99", dtype=object)
    for (i, j), text in reasons.items():
        ds["phase"][i, j] = 3
        why[i, j] = text
    ds["phase_reason"] = (ds["phase"].dims, why)
    return ds


TOO_SHORT = ("run too short for D_eff: 4 time units analysed, need 8/Dr = 800; no cage broken within "
             "the window (cage-relative MSD 0.0005 +- 0.0001 a^2 over 4 time units); a longer run decides")
NEAR_Q = "<q> = 3.8 +- 0.02 too close to 3.81 (P = 0.61 < 0.84)"


@pytest.mark.parametrize("text, short", [
    (TOO_SHORT, "too short, cage not broken"),
    ("D_eff = 0.0011 +- 0.0004 too close to the solid threshold 0.001 (P = 0.6 < 0.84)", "near threshold"),
    (NEAR_Q, "<q> near 3.81"),
    ("MSD not diffusive within the run: D_eff 0.1 +- 0.01, ...", "not settled"),
    ("D_eff not available", "no data"),
    ("", ""),
    ("something entirely new happened here", "something entirely new"),
])
def test_short_reason_names_the_cause_in_few_words(text, short):
    assert plots.short_reason(text) == short


def test_d_eff_values_the_label_rule_did_not_accept_are_hollow():
    ds = _undetermined(synthetic_dataset(), {(1, 1): TOO_SHORT, (2, 0): NEAR_Q})
    ds["phase"][3, 2] = -1  # no label at all: not accepted either
    ax = plots.d_eff_curves(ds).axes[0]
    hollow = [ln for ln in ax.get_lines() if ln.get_gid() == "not_accepted"]
    filled = [ln for ln in ax.get_lines() if ln.get_gid() == "accepted"]
    assert sum(len(ln.get_xdata()) for ln in hollow) == 3
    assert sum(len(ln.get_xdata()) for ln in filled) == ds.sizes["eta"] * ds.sizes["v0"] - 3
    assert all(matplotlib.colors.same_color(ln.get_markerfacecolor(), "w") for ln in hollow)
    assert not any(matplotlib.colors.same_color(ln.get_markerfacecolor(), "w") for ln in filled)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["label decided", "undetermined label"]
    # every label decided: no hollow marker, no legend
    ax = plots.d_eff_curves(synthetic_dataset()).axes[0]
    assert not [ln for ln in ax.get_lines() if ln.get_gid() == "not_accepted"] and ax.get_legend() is None
    matplotlib.pyplot.close("all")


def test_phase_diagram_writes_each_undetermined_points_reason():
    ds = _undetermined(synthetic_dataset(), {(1, 1): TOO_SHORT, (2, 0): NEAR_Q})
    ax = plots.phase_diagram(ds).axes[0]
    texts = sorted(t.get_text().replace("\n", " ") for t in ax.texts if t.get_gid() == "reason")
    assert texts == ["<q> near 3.81", "too short, cage not broken"]
    assert not [t for t in plots.phase_diagram(ds, reasons=False).axes[0].texts if t.get_gid() == "reason"]
    # two replicates with different decided labels: that is the reason
    plain = _undetermined(synthetic_dataset(Ns=(64,)), {})
    other = plain.copy(deep=True)
    other["phase"][0, 0] = 0 if int(plain["phase"][0, 0, 0, 0]) != 0 else 1
    two = xr.concat([plain, other], "replicate").assign_coords(replicate=[0, 1])
    texts = [t.get_text() for t in plots.phase_diagram(two).axes[0].texts if t.get_gid() == "reason"]
    assert texts == ["replicates\ndisagree"] or texts == ["replicates disagree"]
    matplotlib.pyplot.close("all")


def _with_kthny(ds):
    ds = ds.copy()
    k = np.where(ds["phase"] == 0, 0, 2).astype(np.int8)  # solid -> solid, moving -> liquid
    ds["kthny"] = (ds["phase"].dims, k)
    ds["kthny"][2, 1] = 1
    ds["kthny"][0, 0] = 3
    ds["kthny"].attrs.update(flag_values=np.array([-1, 0, 1, 2, 3], dtype=np.int8),
                             flag_meanings="unknown solid hexatic liquid undetermined")
    return ds


def test_summary_diagram_only_when_the_dataset_has_kthny_labels(tmp_path, monkeypatch):
    monkeypatch.setattr(plots, "SWEEP_FIGURES", {"phase_diagram": plots.phase_diagram})  # the others: above
    ds = synthetic_dataset(Ns=(64,))
    names = {p.name for p in plots.plot_dataset(ds, tmp_path / "a")}
    assert "phase_diagram.png" in names and "summary.png" not in names
    names = {p.name for p in plots.plot_dataset(_with_kthny(ds), tmp_path / "b")}
    assert {"summary.png", "summary.pdf"} <= names
    with pytest.raises(ValueError, match="kthny"):
        plots.summary_diagram(ds)
    matplotlib.pyplot.close("all")


def test_summary_labels_follow_kthny_and_name_soft_fluids():
    ds = _with_kthny(synthetic_dataset())
    ds["phase"][0, 0] = 3  # KTHNY and phase both undetermined there
    lab = plots.summary_labels(ds)  # (v0, eta) at the largest N
    phase = ds["phase"].isel(N=-1, replicate=0).values.T
    assert lab[1, 2] == "hexatic" and lab[0, 0] == "undetermined"
    liquid = (ds["kthny"].isel(N=-1, replicate=0).values.T == 2)
    assert np.all(lab[liquid & (phase == 2)] == "soft_fluid") and np.all(lab[liquid & (phase == 1)] == "liquid")
    ax = plots.summary_diagram(ds).axes[0]
    assert {t.get_text() for t in ax.get_legend().get_texts()} >= {"solid", "hexatic", "undetermined"}
    hatched = [c for c in ax.collections if c.get_gid() == "undetermined"]
    assert len(hatched) == 1 and hatched[0].get_hatch()
    matplotlib.pyplot.close("all")


def test_summary_labels_fall_back_to_the_phase_label_where_kthny_is_not_decided():
    """At N < 4096 the KTHNY label is never decided (undetermined); the summary then shows
    the decided phase label (the demo at N = 64 drew all its decided points undetermined)."""
    ds = synthetic_dataset(Ns=(64,))
    ds["kthny"] = (ds["phase"].dims, np.full(ds["phase"].shape, 3, dtype=np.int8),
                   {"flag_values": np.array([-1, 0, 1, 2, 3], dtype=np.int8),
                    "flag_meanings": "unknown solid hexatic liquid undetermined"})
    ds["phase"][1, 2] = 3
    lab = plots.summary_labels(ds)
    phase = ds["phase"].isel(N=0, replicate=0).values.T
    words = {0: "solid", 1: "liquid", 2: "soft_fluid", 3: "undetermined"}
    assert lab.tolist() == [[words[int(c)] for c in row] for row in phase]
    assert lab[2, 1] == "undetermined" and np.sum(lab == "undetermined") == 1
    matplotlib.pyplot.close("all")


def test_drawing_functions_draw_into_a_given_axes():
    ds = with_statistics(synthetic_dataset())
    fig, axes = matplotlib.pyplot.subplots(2, 3)
    a = axes.ravel()
    assert plots.phase_diagram(ds, ax=a[0]) is fig and a[0].collections
    assert plots.d_eff_curves(ds, ax=a[1]) is fig and a[1].get_lines()
    assert plots.msd_curves(ds, ax=a[2]) is fig and a[2].get_lines()
    assert plots.largest_cluster(ds, ax=a[3]) is fig and a[3].containers
    pos, box = hexagonal_lattice(16)
    none = np.zeros((16, 0))
    assert plots.snapshot(pos, np.zeros(16), none, none, box, np.full(16, 3.6), np.zeros(16, bool), ax=a[4]) is fig
    assert a[4].collections[0].get_paths()
    assert len(matplotlib.pyplot.get_fignums()) == 1  # nothing drawn elsewhere
    fig2, panels = matplotlib.pyplot.subplots(1, ds.sizes["v0"])
    assert plots.q_distributions(ds, axes=panels) is fig2 and all(p.get_lines() for p in panels)
    matplotlib.pyplot.close("all")


def test_importing_the_figures_module_leaves_the_backend_alone():
    import subprocess
    import sys

    code = ("import matplotlib; matplotlib.use('pdf'); import fcsweep.results.figures; "
            "print(matplotlib.get_backend())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().lower() == "pdf"


def test_default_sizes_fit_a_paper_column_or_two():
    ds = with_statistics(synthetic_dataset())
    for fn in (plots.phase_diagram, plots.d_eff_curves, plots.largest_cluster, plots.msd_curves):
        assert fn(ds).get_figwidth() <= plots.COLUMN
    for fn in (plots.q_distributions, plots.cluster_sizes, plots.correlations):
        assert fn(ds).get_figwidth() <= plots.DOUBLE_COLUMN
    assert plots.summary_diagram(_with_kthny(ds)).get_figwidth() <= plots.COLUMN
    fig = plots.phase_diagram(ds)
    assert fig.axes[0].get_xlabel().endswith("[$F$]") and fig.axes[0].get_ylabel().endswith(r"[$\mu F$]")
    assert plots.msd_curves(ds).axes[0].get_xlabel().endswith(f"[{plots.TIME_UNIT}]")
    matplotlib.pyplot.close("all")


def test_power_law_guides_leave_the_range_to_the_data():
    ds = synthetic_dataset()
    ds["G6"][:] = 0.1 * ds["r"] ** -0.25  # G6 0.056-0.18: a guide from 1 at r = 1 would widen the axis
    ax = plots.correlations(ds).axes[1]
    lo, hi = ax.get_ylim()
    data = np.concatenate([ln.get_ydata() for ln in ax.get_lines() if ln.get_gid() != "guide"])
    span = data.max() / data.min()
    assert data.min() / span ** 0.06 <= lo <= data.min() and data.max() <= hi <= data.max() * span ** 0.06
    guide = [ln for ln in ax.get_lines() if ln.get_gid() == "guide"]
    assert len(guide) == 1 and np.all((guide[0].get_ydata() > lo) & (guide[0].get_ydata() < hi))  # in view
    matplotlib.pyplot.close("all")


def test_cluster_colour_bar_only_when_clusters_are_drawn():
    ds = synthetic_dataset()
    n = ds.sizes["v0"]
    assert len(plots.cluster_sizes(ds).axes) == n + 1  # panels and the eta colour bar
    ds["cluster_size_distribution"][:] = 0.0
    fig = plots.cluster_sizes(ds)
    assert len(fig.axes) == n and all(not ax.get_lines() for ax in fig.axes)
    matplotlib.pyplot.close("all")


def test_snapshot_title_has_model_units(tmp_path, monkeypatch):
    import fcsweep.io.trajectory as trajectory

    monkeypatch.setattr(trajectory, "open_trajectory", lambda p: FakeTrajectory())
    title = plots.frames._frame_title(FakeTrajectory(), 1, np.zeros(16, bool))
    assert rf"t = 2.5 {plots.TIME_UNIT}" in title and r"$\eta$ = 0.05 $F$" in title and r"0.03 $\mu F$" in title
    paths = plots.snapshot_run(tmp_path / "trajectory.h5", 1)
    assert all(p.exists() for p in paths)


def test_movie_frames_are_whole_macro_blocks(tmp_path, monkeypatch, caplog):
    pytest.importorskip("imageio_ffmpeg")
    import imageio.v2 as imageio

    import fcsweep.io.trajectory as trajectory

    monkeypatch.setattr(trajectory, "open_trajectory", lambda p: FakeTrajectory())
    for dpi in (97, 120):  # 120 dpi gave 852 x 683 before
        art = plots.FrameArtist(FakeTrajectory().box, width=plots.SLIDE, dpi=dpi, style=plots.SLIDE_STYLE)
        h, w, _ = art.rgb().shape
        assert h % 16 == 0 and w % 16 == 0
    with caplog.at_level("WARNING"):
        out = plots.movie_run(tmp_path / "trajectory.h5", tmp_path / "m.mp4", dpi=97, progress=False)
    assert not [r for r in caplog.records if "macro_block_size" in r.getMessage()]
    with imageio.get_reader(out) as reader:
        assert reader.count_frames() == 3


def test_summary_diagram_leaves_grid_points_without_a_run_empty():
    # a hole of a refined or joined grid (empty run_id) is no run at all: no marker, while
    # a run without an analysis stays "not analysed"
    ds = _with_kthny(synthetic_dataset(Ns=(64,)))
    ids = np.full(ds["phase"].shape, "run", dtype=object)
    ds["run_id"] = (ds["phase"].dims, ids)
    for v in ("kthny", "phase"):
        ds[v][dict(eta=0, v0=0)] = -1
        ds[v][dict(eta=1, v0=0)] = -1
    ds["run_id"][dict(eta=0, v0=0)] = ""
    lab = plots.summary_labels(ds)
    assert lab[0, 0] == "none" and lab[0, 1] == "unknown"
    ax = plots.summary_diagram(ds).axes[0]
    gids = {c.get_gid(): len(c.get_offsets()) for c in ax.collections}
    assert "none" not in gids and gids["unknown"] == 1
    matplotlib.pyplot.close("all")


def test_threshold_contours_run_on_cell_edges_between_the_points_that_bracket_them():
    """<q> = 3.81 on a 2 x 2 log grid (the demo's): the line is the edges between a cell
    above and its neighbours below, nowhere inside a cell (an interpolated contour, linear
    in eta on the log axis, ran three quarters into the fluid cell beside a soft fluid)."""
    from fcsweep.results.figures.common import cell_edges
    from fcsweep.results.figures.diagrams import level_edges

    eta, v0 = np.array([0.01, 0.3]), np.array([0.02, 0.2])
    ex, ey = cell_edges(eta, True), cell_edges(v0, True)
    q = np.array([[3.60, 3.56], [3.96, 3.60]])  # rows v0, columns eta: soft fluid at (0.01, 0.2)
    segs = level_edges(q, 3.81, ex, ey)
    assert len(segs) == 2
    mid_x, mid_y = ex[1], ey[1]  # the inner cell edges
    assert {tuple(map(tuple, s)) for s in segs} == {((mid_x, ey[1]), (mid_x, ey[2])), ((ex[0], mid_y), (ex[1], mid_y))}
    nan_segs = level_edges(np.array([[3.6, np.nan], [3.9, 3.7]]), 3.81, ex, ey)
    assert len(nan_segs) == 2  # (0,0)-(1,0) and (1,0)-(1,1); none to the NaN cell
    ds = synthetic_dataset(etas=(0.01, 0.3), v0s=(0.02, 0.2), Ns=(64,))
    ds["q_mean"][:] = q.T[..., None, None]
    ax = plots.phase_diagram(ds).axes[0]
    (line,) = [c for c in ax.collections if c.get_gid() == "q_mean_contour"]
    assert len(line.get_segments()) == 2
    for seg in line.get_segments():  # every point on a cell edge
        assert all(np.isclose(x, ex).any() or np.isclose(y, ey).any() for x, y in seg)
    matplotlib.pyplot.close("all")


def test_summary_legend_says_fluid_as_every_other_figure():
    ds = _with_kthny(with_statistics(synthetic_dataset()))
    ax = plots.summary_diagram(ds).axes[0]
    words = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "fluid" in words and "liquid" not in words
    matplotlib.pyplot.close("all")


def test_q_distribution_marks_and_the_defect_colour_have_legends():
    fig = plots.q_distributions(synthetic_dataset())
    words = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any("3.81" in w for w in words) and any("3.545" in w for w in words)
    pos, box = hexagonal_lattice(16)
    fig = plots.snapshot(pos, np.zeros(16), None, None, box, np.full(16, 3.7), np.arange(16) == 3)
    texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert texts == ["defect (not 6 Voronoi neighbours)"]
    matplotlib.pyplot.close("all")


def test_labels_have_their_words_beside_the_codes():
    """phase_label etc. are the flag_meanings of the codes (xarray does not decode them),
    written as strings to the NetCDF file and read back as words; reason codes get none."""
    from fcsweep.results.aggregate import add_label_words

    ds = with_statistics(synthetic_dataset())
    ds["phase_reason_code"] = xr.zeros_like(ds["phase"]).assign_attrs(flag_values=np.array([0], np.int8),
                                                                      flag_meanings="not_recorded")
    add_label_words(ds)
    words = dict(zip([-1, 0, 1, 2, 3], "unknown solid fluid soft_fluid undetermined".split()))
    assert "phase_label" in ds and "phase_reason_code_label" not in ds
    assert [words[int(c)] for c in ds["phase"].values.ravel()] == list(ds["phase_label"].values.ravel())
    assert "undetermined" in ds["phase_label"].values


def test_label_words_survive_the_netcdf_file(tmp_path):
    from fcsweep.results.aggregate import add_label_words, write_dataset

    ds = with_statistics(synthetic_dataset())[["phase"]]
    add_label_words(ds)
    back = xr.open_dataset(write_dataset(ds, tmp_path / "d.nc"))
    assert back["phase_label"].values.tolist() == ds["phase_label"].values.tolist()
    back.close()
