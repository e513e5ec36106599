"""The analysis of confined runs (a well, a channel): fcsweep.analysis.confined and its use in
fcsweep.analysis.run_observables. Known answers on synthetic positions (no simulation)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fcsweep.analysis import confined as C
from fcsweep.analysis.phase import PHASE_FLAGS, PHASE_SOLID, PHASE_UNDETERMINED, phase_evidence, phase_label
from fcsweep.analysis.points import combine_runs
from fcsweep.analysis.reasons import reason_flags, reason_value
from fcsweep.analysis.run_observables import RunFrames, compute_observables, frame_plan, run_confinement
from fcsweep.analysis.voronoi import voronoi_neighbors
from fcsweep.model.confinement import confinement_of, wall_pressure
from fcsweep.model.observables import REASONS, RUN_SCALARS
from fcsweep.results.analyze import settings_with


def _hex_patch(conf, a: float, inset: float = 0.5) -> np.ndarray:
    """Triangular lattice of spacing ``a`` through the well's centre, the sites farther
    than ``inset * a`` inside the wall."""
    n = int(conf.size / a) + 3
    i, j = np.meshgrid(np.arange(-n, n + 1), np.arange(-n, n + 1))
    p = np.stack([i + 0.5 * j, j * math.sqrt(3.0) / 2.0], axis=-1).reshape(-1, 2) * a
    p = p[np.linalg.norm(p, axis=1) < conf.size - inset * a]
    return p + conf.centre


def _well_of(N: int, Rw: float):
    return confinement_of("well", Rw, N, 0.9)


def test_a_perfect_patch_in_a_well_has_no_defect_among_the_counted_cells():
    """rho_d = 0 over the counted cells; the whole tessellation (rim cells included) is
    far from it, and so is a periodic tessellation of the host box."""
    conf0 = _well_of(100, 20.0)
    a = 2.0
    p = _hex_patch(conf0, a)
    conf = _well_of(len(p), 20.0)
    tess = C.confined_voronoi(p, conf)
    counted = C.counted_cells(p, conf, tess, C.lattice_spacing(conf, len(p)))
    r = C.frame_defects(tess, counted, 0)
    assert r["rho_d"] == 0.0 and r["pmax"] == 0.0 and r["n_counted"] == counted.sum() > 0.4 * len(p)
    assert np.mean(tess.n_sides != 6) > 0.1  # the rim: unbounded regions, 4 or 5 sides
    periodic = voronoi_neighbors(p, conf.host)
    assert np.mean(periodic.n_sides != 6) > 0.1  # the empty margin of the host box deforms the rim cells
    assert C.confined_psi6(tess, counted) == pytest.approx(1.0, abs=1e-9)
    # counted cells: sides certain and at least 2a from the wall
    d = conf.inside_distance(p[counted])
    assert d.min() >= 2.0 * C.lattice_spacing(conf, len(p))


def test_a_defect_in_the_middle_of_the_well_is_counted():
    """One site removed at the centre: its six neighbours become 5- or 7-sided defects of one cluster."""
    conf0 = _well_of(100, 20.0)
    p = _hex_patch(conf0, 2.0)
    p = p[np.linalg.norm(p - conf0.centre, axis=1) > 0.1]  # the vacancy
    conf = _well_of(len(p), 20.0)
    tess = C.confined_voronoi(p, conf)
    counted = C.counted_cells(p, conf, tess, C.lattice_spacing(conf, len(p)))
    r = C.frame_defects(tess, counted, 0)
    n_def = round(r["rho_d"] * r["n_counted"])
    assert n_def == 6 and r["pmax"] == pytest.approx(6 / r["n_counted"])


def _channel_lattice(nx: int, rows: int, a: float, margin_rows: float = 0.5):
    """A channel whose length holds ``nx`` lattice sites and width ``rows`` rows (plus half a
    row at each wall), and the lattice in it (host-box coordinates)."""
    N = nx * rows
    h = a * math.sqrt(3.0) / 2.0
    W = (rows - 1 + 2 * margin_rows) * h
    density = N * math.pi / (W * nx * a)
    conf = confinement_of("channel", W, N, density)
    assert conf.host[0] == pytest.approx(nx * a)
    i, j = np.meshgrid(np.arange(nx), np.arange(rows))
    p = np.stack([(i + 0.5 * (j % 2)) * a, conf.y_lo + (margin_rows + j) * h], axis=-1).reshape(-1, 2)
    return conf, p


def test_a_channel_of_a_lattice_has_no_defect_away_from_the_walls():
    conf, p = _channel_lattice(16, 12, 2.0)
    a = C.lattice_spacing(conf, len(p))
    tess = C.confined_voronoi(p, conf)
    counted = C.counted_cells(p, conf, tess, a)
    r = C.frame_defects(tess, counted, 0)
    assert r["n_counted"] >= 16 * 4 and r["rho_d"] == 0.0
    assert np.all(tess.n_sides[counted] == 6)
    # periodic along x: a cell at x ~ 0 has its neighbours across x = L_x at minimum image
    assert np.abs(tess.vectors[:, 0]).max() < 1.01 * 2.0
    # shifted along x by any amount (wrapped): the same counts (no seam along x)
    q = p.copy()
    q[:, 0] = np.mod(q[:, 0] + 7.3, conf.host[0])
    t2 = C.confined_voronoi(q, conf)
    assert np.array_equal(np.sort(t2.n_sides), np.sort(tess.n_sides))
    assert C.counted_cells(q, conf, t2, a).sum() == counted.sum()


def test_radical_tessellation_of_unequal_cells_in_a_channel():
    """With per-cell radii the tessellation is the radical (Laguerre) one: at equal radii it is
    the Voronoi one, bond for bond; for a bidisperse packing the neighbours of every counted
    cell are those of the periodic radical tessellation of the host box
    (:func:`fcsweep.analysis.voronoi.laguerre_bonds`, which sees the same cells), and differ
    from the plain Voronoi ones for some cells."""
    from fcsweep.analysis.voronoi import laguerre_bonds

    rng = np.random.default_rng(4)
    conf = confinement_of("channel", 12.0, 256, 0.8)
    pos = conf.random_points(256, rng, inset=0.3)
    plain = C.confined_voronoi(pos, conf)
    same = C.confined_voronoi(pos, conf, np.full(256, 1.0))
    assert np.array_equal(plain.i, same.i) and np.array_equal(plain.j, same.j)
    assert np.array_equal(plain.certain, same.certain)
    radii = np.where(rng.random(256) < 0.5, 0.8, 1.2)
    tess = C.confined_voronoi(pos, conf, radii)
    counted = C.counted_cells(pos, conf, tess, C.lattice_spacing(conf, 256))
    assert counted.sum() > 40
    li, lj, _ = laguerre_bonds(pos, conf.host, radii)
    differs = 0
    for c in np.flatnonzero(counted):
        mine = set(tess.j[tess.i == c].tolist())
        assert mine == set(lj[li == c].tolist())
        differs += mine != set(plain.j[plain.i == c].tolist())
    assert differs > 0


def test_no_bond_across_a_wall():
    """Two rows of cells on either side of the channel's host box edge: no bond between them
    (the host box is periodic along y, the channel is not)."""
    conf, p = _channel_lattice(16, 12, 2.0)
    tess = C.confined_voronoi(p, conf)
    assert np.abs(tess.vectors[:, 1]).max() < 2.0  # a periodic y would give bonds of ~ L_y - W


def test_pressure_of_a_rigid_disc_pressed_into_the_wall_is_its_chord_over_the_wall_length():
    """Well: a unit disc whose centre lies 0.6 inside the wall; the force on it is the chord
    of its part beyond the wall, 2 sqrt(1 - 0.6^2) (flat-wall limit, R_w >> 1)."""
    conf = confinement_of("well", 2000.0, 1, 0.5)
    pos = conf.centre + np.array([[conf.size - 0.6, 0.0]])
    P = wall_pressure(pos, np.zeros(1), np.zeros((1, 0)), np.zeros((1, 0)), conf)
    assert P * conf.wall_length == pytest.approx(2.0 * math.sqrt(1 - 0.36), rel=1e-3)
    # channel: a disc 0.3 from the upper wall and one 0.5 below the lower, same formula exactly
    ch = confinement_of("channel", 10.0, 2, 0.5)
    pos = np.array([[1.0, ch.y_hi - 0.3], [3.0, ch.y_lo + 0.5]])
    series = C.pressure_series(pos[None], np.zeros((1, 2)), None, None, ch)
    chords = 2.0 * math.sqrt(1 - 0.09) + 2.0 * math.sqrt(1 - 0.25)
    assert series[0] == pytest.approx(chords / ch.wall_length, rel=1e-12)
    # a deformable cell at the same place with zero modes: the contour quadrature agrees to O(1/K^2)
    s2 = C.pressure_series(pos[None], np.zeros((1, 2)), np.zeros((1, 2, 5)), np.zeros((1, 2, 5)), ch,
                           contour_points=400)
    assert s2[0] == pytest.approx(series[0], rel=1e-3)


def test_the_pressure_error_is_that_of_a_correlated_series():
    """An AR(1) series with phi = 0.8 (tau = 9): the quoted error is sqrt(tau) times the naive one."""
    rng = np.random.default_rng(5)
    phi, n = 0.8, 4000
    x = np.empty(n)
    x[0] = 0.0
    e = rng.standard_normal(n)
    for t in range(1, n):
        x[t] = phi * x[t - 1] + e[t]
    out = C.pressure_observables(1.0 + 0.01 * x)
    naive = 0.01 * x.std() / math.sqrt(n)
    tau = (1 + phi) / (1 - phi)
    assert out["wall_pressure_err"] / naive == pytest.approx(math.sqrt(tau), rel=0.3)
    assert abs(out["wall_pressure"] - 1.0) < 4 * out["wall_pressure_err"]


# ------------------------------------------------------------------ a confined run, end to end on arrays

def _well_run(T: int = 60, jitter: float = 0.02, seed: int = 2, inset: float = 0.6):
    """Rigid discs vibrating about a hexagonal patch in a well (never crossing the wall)."""
    Rw, a = 14.0, 2.0
    p = _hex_patch(_well_of(10, Rw), a, inset=inset)
    N = len(p)
    params = {"R0": 1.0, "v0": 0.02, "Dr": 0.1, "modes": 0, "N": N, "boundary": "well", "boundary_size": Rw,
              "density": 0.9}
    conf = confinement_of("well", Rw, N, 0.9)
    s = settings_with({"structure_frames": 10, "correlation_frames": 2, "shape_frames": 12}, transient=0.2)
    plan = frame_plan(T, s)
    rng = np.random.default_rng(seed)
    x = p[None] + jitter * rng.standard_normal((T, N, 2))
    theta = rng.uniform(0, 2 * np.pi, (T, N))
    run = RunFrames(source="well", params=params, box=conf.host, time=np.arange(T) * 5.0, plan=plan, shape_a=None,
                    shape_b=None, rigid=True, positions=x[plan.structure_frames], unwrapped=x[plan.frames],
                    wall_positions=x[plan.shape_frames], wall_theta=theta[plan.shape_frames])
    return run, s, conf


def test_a_vibrating_patch_in_a_well_end_to_end():
    run, s, conf = _well_run()
    sc, cv, extra = compute_observables(run, s, curves=True)
    assert set(RUN_SCALARS) <= set(sc) and set(REASONS) <= set(sc)
    assert sc["rho_d"] == 0.0 and 0 < sc["n_counted_cells"] < run.n_cells
    assert sc["psi6"] > 0.95
    assert sc["area_fraction"] == pytest.approx(conf.area_fraction)
    assert sc["msd_bounded"] == 1.0
    assert sc["wall_pressure"] == 0.0  # every disc clear of the wall
    assert np.isnan(sc["kthny"]) and sc["kthny_reason_code"] == reason_value("not_periodic")
    assert reason_value("not_periodic") in reason_flags("kthny")
    assert cv["G6"][1].size == 0
    # the cage rule ran on the cells away from the wall, with the spacing of the well's area
    assert sc["neighbour_spacing"] == pytest.approx(C.lattice_spacing(conf, run.n_cells))
    assert np.isfinite(sc["D_eff_cr"]) and sc["cage_msd_ratio"] < 0.1
    assert PHASE_FLAGS[int(sc["phase"])] == "solid", sc["phase_reason"]


def test_a_pressed_patch_has_a_positive_pressure_with_an_error():
    """Discs of radius 1 whose rim sites sit within 0.6 of the wall press on it every frame."""
    run, s, conf = _well_run(T=80, jitter=0.05, inset=0.3)
    x = np.asarray(run.wall_positions)
    d = conf.inside_distance(x)
    assert d.min() < 1.0
    sc, _, _ = compute_observables(run, s, curves=False)
    assert sc["wall_pressure"] > 0 and 0 < sc["wall_pressure_err"] < 0.2 * sc["wall_pressure"]


def test_the_host_box_must_match_the_parameters():
    run, s, _ = _well_run()
    bad = RunFrames(**{**run.__dict__, "box": run.box * 1.1})
    with pytest.raises(Exception, match="host box"):
        run_confinement(bad)


def test_a_bounded_msd_decides_nothing_without_the_cage_rule():
    """A well: D_eff reads solid (the MSD saturates) but without D_eff_cr it decides nothing."""
    sc = {"D_eff": 1e-5, "D_eff_err": 1e-6, "D_eff_long": 1e-5, "D_eff_long_err": 1e-6, "n_time_blocks": 4,
          "msd_long_enough": 1.0, "msd_diffusive": 1.0, "q_mean": 3.7, "q_mean_err": 0.01, "msd_bounded": 1.0}
    lab = phase_label(phase_evidence(sc))
    assert lab.code == PHASE_UNDETERMINED and lab.reason_code == "msd_bounded", lab
    assert "bounded by the walls" in lab.reason
    periodic = phase_label(phase_evidence({**sc, "msd_bounded": 0.0}))
    assert periodic.code == PHASE_SOLID
    with_cage = phase_label(phase_evidence({**sc, "D_eff_cr": 1e-5, "D_eff_cr_err": 1e-6, "cage_msd_ratio": 0.01,
                                            "cage_msd_ratio_err": 0.001}))
    assert with_cage.code == PHASE_SOLID  # the cage rule decides
    assert combine_runs([sc, {**sc, "msd_bounded": np.nan}])["msd_bounded"] == 1.0


# ------------------------------------------------------------------ results: FSS, h5md, figures, export

def test_fss_is_not_applicable_to_confined_runs():
    import xarray as xr

    from fcsweep.analysis.fss import NOT_PERIODIC
    from fcsweep.analysis.reasons import REASON_BY_NAME
    from fcsweep.results.reduce import FSS_VARS, _collapse_per_slice

    dims = ("eta", "N", "v0")
    ds = xr.Dataset(coords={"eta": [0.01, 0.02, 0.03], "N": [64, 256], "v0": [0.1], "replicate": [0]})
    rng = np.random.default_rng(1)
    for v in ("rho_d_rmean", "largest_cluster_fraction_rmean", "largest_cluster_fraction_rmean_err"):
        ds[v] = (dims, rng.uniform(0.1, 0.9, (3, 2, 1)))
    ds["area_fraction"] = (dims + ("replicate",), np.full((3, 2, 1, 1), 0.85))
    _collapse_per_slice(ds, "largest_cluster_fraction", FSS_VARS, 2)
    assert str(ds["fss_reason"].values.ravel()[0]).startswith(NOT_PERIODIC + ":")
    assert np.isnan(ds["fss_rho_c"].values).all()
    assert NOT_PERIODIC in REASON_BY_NAME


@pytest.mark.parametrize("boundary, expected", [("periodic", ["periodic", "periodic"]), ("well", ["none", "none"]),
                                                ("channel", ["periodic", "none"])])
def test_h5md_box_boundary(tmp_path, boundary, expected):
    import h5py

    from fcsweep.io.h5md import create_trajectory

    path = tmp_path / "t.h5"
    create_trajectory(path, n_cells=4, box=(10.0, 10.0), modes_width=0, fields=["position"],
                      parameters={"boundary": boundary, "N": 4}, dt=0.005)
    with h5py.File(path, "r") as f:
        got = [v.decode() if isinstance(v, bytes) else v for v in f["particles/cells/box"].attrs["boundary"]]
    assert got == expected


def test_no_copy_across_a_wall_in_figures_and_vtk():
    from fcsweep.results.figures.frames import cell_polygons
    from fcsweep.results.vtk import periodic_copies

    box = np.array([10.0, 10.0])
    pos = np.array([[0.5, 0.5]])  # crosses both edges
    polys, owner = cell_polygons(pos, np.zeros(1), None, None, box)
    assert len(polys) == 4
    assert len(cell_polygons(pos, np.zeros(1), None, None, box, periodic=(False, False))[0]) == 1
    assert len(cell_polygons(pos, np.zeros(1), None, None, box, periodic=(True, False))[0]) == 2
    phi = np.linspace(0, 2 * np.pi, 20, endpoint=False)
    contour = (pos[0] + np.stack([np.cos(phi), np.sin(phi)], -1))[None]
    assert periodic_copies(contour, box)[0].shape[0] == 4
    assert periodic_copies(contour, box, (True, False))[0].shape[0] == 2
    assert periodic_copies(contour, box, (False, False))[0].shape[0] == 1


def test_the_snapshot_draws_the_wall():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle

    from fcsweep.results.figures.frames import snapshot

    conf0 = _well_of(10, 12.0)
    p = _hex_patch(conf0, 2.0)
    conf = _well_of(len(p), 12.0)
    N = len(p)
    fig = snapshot(p, np.zeros(N), None, None, conf.host, np.full(N, 3.6), np.zeros(N, bool), conf=conf)
    circles = [a for a in fig.axes[0].patches if isinstance(a, Circle)]
    assert len(circles) == 1 and circles[0].radius == pytest.approx(conf.size)
    plt.close(fig)
    ch, q = _channel_lattice(8, 6, 2.0)
    fig = snapshot(q, np.zeros(len(q)), None, None, ch.host, np.full(len(q), 3.6), np.zeros(len(q), bool), conf=ch)
    ys = sorted(line.get_ydata()[0] for line in fig.axes[0].lines if len(line.get_ydata()) == 2)
    assert ys == pytest.approx([ch.y_lo, ch.y_hi])
    plt.close(fig)


def test_exported_defects_of_a_confined_frame_are_the_counted_ones():
    from types import SimpleNamespace

    from fcsweep.results.cells import _frame_of

    conf0 = _well_of(100, 20.0)
    p = _hex_patch(conf0, 2.0)
    conf = _well_of(len(p), 20.0)
    N = len(p)
    traj = SimpleNamespace(box=conf.host, step=np.array([0]), time=np.array([0.0]))
    cf = _frame_of(traj, 0, p, np.zeros((N, 2), np.int64), np.zeros(N), np.zeros((N, 0)), np.zeros((N, 0)), True,
                   None, conf)
    assert not cf.defect.any() and (cf.n_sides != 6).any()  # the rim is not counted


# ------------------------------------------------------------------ analyze + aggregate of a swept boundary

SWEEP = """
output: {out}
seed: 1
replicates: 1
grid:
  eta: [0.1]
  v0: [0.03]
  boundary: [periodic, well, channel]
model: {{N: 36, density: 0.9, Dr: 1.0, dt: 0.005, modes: 6, initial: disordered}}
run: {{steps: 3000, sample_every: 50, checkpoint_every: 500, transient: 0.2}}
"""


def _confined_positions(params, rng, T):
    """Jittered lattice sites of a run (host-box coordinates) and its box."""
    from fcsweep.model.confinement import confinement_of_params
    from fcsweep.model.lattice import hexagonal_lattice

    N = int(params["N"])
    lattice, box = hexagonal_lattice(N, params["density"])
    conf = confinement_of_params(params)
    if conf is None:
        base = lattice
    elif conf.kind == "channel":
        assert conf.host[0] == pytest.approx(box[0]) and conf.size == pytest.approx(box[1])
        base = lattice + np.array([0.0, conf.y_lo + 0.5 * box[1] / math.sqrt(N)])  # 6 rows, half a row off
        box = conf.host
    else:
        sites = _hex_patch(conf, 2.0 * C.lattice_spacing(conf, N) / 2.0, inset=0.0)
        base = sites[np.argsort(np.linalg.norm(sites - conf.centre, axis=1))[:N]]
        box = conf.host
    x = base[None] + 0.01 * rng.standard_normal((T, N, 2))
    return x, np.asarray(box, float)


def _write_run(path, params, seed, T=61):
    import h5py

    rng = np.random.default_rng(seed)
    N = int(params["N"])
    x, box = _confined_positions(params, rng, T)
    image = np.floor_divide(x, box).astype(np.int32)
    steps = np.arange(T, dtype=np.int64) * 50
    with h5py.File(path, "w") as f:
        f.create_group("h5md").attrs["version"] = [1, 1]
        cells = f.create_group("particles/cells")
        cells.create_group("box").create_dataset("edges", data=box)
        for name, val in (("position", x - image * box), ("image", image), ("theta", rng.uniform(0, 6.28, (T, N))),
                          ("shape_a", np.zeros((T, N, 5))), ("shape_b", np.zeros((T, N, 5)))):
            g = cells.create_group(name)
            g.create_dataset("step", data=steps)
            g.create_dataset("time", data=steps * params["dt"])
            g.create_dataset("value", data=val)
        par = f.create_group("parameters")
        for k, v in params.items():
            par.attrs[k] = v


def test_aggregate_carries_the_boundary_and_the_wall_pressure(tmp_path):
    import json

    import xarray as xr

    from fcsweep.config import parse_config
    from fcsweep.results.aggregate import aggregate_sweep, build_dataset
    from fcsweep.results.analyze import analyze_sweep

    cfg = parse_config(SWEEP.format(out=tmp_path / "sweep"))
    for k, spec in enumerate(cfg.runs()):
        rd = tmp_path / "sweep" / "runs" / spec.run_id
        rd.mkdir(parents=True)
        _write_run(rd / "trajectory.h5", {**dict(spec.params), "run_id": spec.run_id}, k)
        (rd / "status.json").write_text(json.dumps({"status": "done", "reason": ""}))
    res = analyze_sweep(cfg)
    assert [s for _, s, _ in res] == ["done"] * 3, res
    ds = build_dataset(cfg)
    assert sorted(ds["boundary"].values.tolist()) == ["channel", "periodic", "well"]
    assert ds["boundary"].attrs["long_name"]
    sel = {b: ds.sel(boundary=b).squeeze() for b in ("periodic", "well", "channel")}
    assert np.isnan(sel["periodic"]["wall_pressure"]) and np.isnan(sel["periodic"]["area_fraction"])
    assert sel["periodic"]["msd_bounded"] == 0 and sel["periodic"]["n_counted_cells"] == 36
    for b in ("well", "channel"):
        assert np.isfinite(sel[b]["wall_pressure"]) and np.isfinite(sel[b]["wall_pressure_err"])
        assert sel[b]["area_fraction"] == pytest.approx(0.9)
        assert sel[b]["msd_bounded"] == 1 and 0 < sel[b]["n_counted_cells"] < 36
        assert int(sel[b]["kthny_reason_code"]) == reason_value("not_periodic")
    aggregate_sweep(cfg)  # the string coordinate writes and reads back
    with xr.open_dataset(tmp_path / "sweep" / "phase_diagram.nc") as back:
        assert sorted(back["boundary"].values.tolist()) == ["channel", "periodic", "well"]
        assert np.isfinite(back["wall_pressure"].sel(boundary="well")).all()
