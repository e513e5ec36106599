"""`fcsweep measure`: label images of model cells give back the cells' own q and rho_d;
every reader gives the same dataset; broken input is refused with exit 2."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner
from measure_render import exact_q, jittered_cells, render, render_overlapping
from PIL import Image

import fcsweep
from fcsweep.results.export import cell_contours
from fcsweep.analysis.voronoi_open import open_voronoi
from fcsweep.cli import cli
from fcsweep.measure import MeasureInputError, measure, read_seg_npy
from fcsweep.measure import readers as measure_readers
from fcsweep.model.shape import bounding_radius


def _centroids(pos, theta, a, b):
    """Exact area centroids of the model contours (polygons of 400 points)."""
    c = cell_contours(pos, theta, a, b, points=400)
    x, y = c[..., 0], c[..., 1]
    x1, y1 = np.roll(x, -1, 1), np.roll(y, -1, 1)
    cr = x * y1 - x1 * y
    A = cr.sum(1) / 2
    return np.stack([((x + x1) * cr).sum(1) / (6 * A), ((y + y1) * cr).sum(1) / (6 * A)], 1)


def _scene(n_side, seed, spacing, sweeps, step=0.3):
    pos, theta, a, b = jittered_cells(n_side, np.random.default_rng(seed), spacing=spacing, sweeps=sweeps,
                                      step=step)
    fov = (1.0, pos[:, 0].max() - 1.0, 0.5, pos[:, 1].max() - 0.5)  # cuts the outer cells
    return pos, theta, a, b, fov


def _exact_rho_d(ds, pos, theta, a, b, fov):
    """rho_d of the same cells on the same open-boundary rule, from their exact centroids
    (cells cut by the image edge keep the centroid of their visible part, which is all an
    image has of them)."""
    lab = ds.label.values
    ok = lab > 0
    ref = np.stack([ds.x.values[ok], ds.y.values[ok]], 1)
    whole = ds.edge_cut.values[ok] == 0
    ref[whole] = (_centroids(pos, theta, a, b) - [fov[0], fov[2]])[lab[ok][whole] - 1]
    v = open_voronoi(ref, (0.0, fov[1] - fov[0], 0.0, fov[3] - fov[2]))
    return ((v.n_sides != 6) & v.interior).sum() / v.interior.sum()


@pytest.mark.parametrize("res", [5, 10, 20])
def test_q_and_rho_d_of_rendered_model_cells(res):
    """Model cells (modes 2..6) rasterised at 5 / 10 / 20 px per R0: q gives the model's <q> within
    0.4 / 0.15 / 0.15 % (docs/measure.md: <= 0.3 % at 5 px, <= 0.1 % at 10 and 20; the smooth cells
    take the M = 6 fit; the marching-squares contour is ~5 % high at every resolution), and rho_d
    within 0.02 of the exact centroids' (measured <= 0.01 at 5 px, 0 at 10 and 20 px over ~310
    classified cells)."""
    pos, theta, a, b, fov = _scene(20, 1, 3.0, 20)
    ds = measure(render(pos, theta, a, b, res, fov), 1.0 / res).isel(time=0)
    whole = (ds.label.values > 0) & (ds.edge_cut.values == 0)
    q_exact = exact_q(a, b)[ds.label.values[whole] - 1].mean()
    assert ds.q_mean.item() == pytest.approx(q_exact, rel={5: 0.004, 10: 0.0015, 20: 0.0015}[res])
    q_contour = (ds.perimeter_contour / np.sqrt(ds.area)).values[whole].mean()
    assert q_contour > 1.03 * q_exact  # the bias the fit removes
    assert ds.n_classified.item() > 250
    assert abs(ds.rho_d.item() - _exact_rho_d(ds, pos, theta, a, b, fov)) <= 0.02
    assert ds.n_edge_cut.item() > 0 and ds.n_boundary.item() > ds.n_edge_cut.item() / 2
    # rotation-invariant amplitudes compare with the model's body-frame modes
    c_model = np.hypot(a, b)[ds.label.values[whole] - 1]
    err = np.abs(ds.c_abs.values[whole] - c_model)
    assert np.sqrt(np.mean(err ** 2)) < 0.1 / res


@pytest.mark.slow
def test_simulated_monolayer_gives_back_its_q_and_rho_d():
    """256 cells simulated at eta = 0.01, v0 = 0.06 for 100 time units (~20 s), rendered with
    their overlaps (each pixel to the cell it is deepest in) at 5 / 10 / 20 px per R0 in a
    field of view 1 R0 inside the box: <q> within 1 % of the simulation's on the same cells
    (measured +0.29 / +0.02 / -0.06 %); rho_d within 0.02 of the cells' exact contour
    centroids on the same open-boundary rule (measured 0.002 / 0.002 / 0.006; against the
    simulation's centres, which an image cannot see, 0.020 / 0.020 / 0.002)."""
    from fcsweep.analysis.shapes import shape_indices
    from fcsweep.simulation import Simulation

    sim = Simulation.from_lattice(256, seed=3, eta=0.01, v0=0.06)
    sim.advance(20000)
    s = sim.state
    L = s.box
    fov = (1.0, L[0] - 1.0, 1.0, L[1] - 1.0)
    q_sim = shape_indices(s.a, s.b)
    cen = _centroids(s.pos, s.theta, s.a, s.b) - [fov[0], fov[2]]
    for res in (5, 10, 20):
        ds = measure(render_overlapping(s.pos, s.theta, s.a, s.b, L, res, fov), 1.0 / res).isel(time=0)
        lab = ds.label.values
        ok = lab > 0
        whole = ok & (ds.edge_cut.values == 0)
        assert whole.sum() > 150
        assert ds.q_mean.item() == pytest.approx(q_sim[lab[whole] - 1].mean(), rel=0.01)
        ref = np.stack([ds.x.values[ok], ds.y.values[ok]], 1)
        c = cen[lab[ok] - 1]
        c = c + L * np.round((ref - c) / L)  # the periodic image in the field of view
        uncut = ds.edge_cut.values[ok] == 0
        ref[uncut] = c[uncut]
        v = open_voronoi(ref, (0.0, fov[1] - fov[0], 0.0, fov[3] - fov[2]))
        assert abs(ds.rho_d.item() - ((v.n_sides != 6) & v.interior).sum() / v.interior.sum()) <= 0.02


@pytest.mark.slow
def test_simulated_movie_gives_back_its_d_s():
    """144 cells at eta = 0.1, v0 = 0.1, Dr = 0.1 (~30 s), 160 frames 0.5 apart rendered at 5 px
    per R0: D_s of the tracked cells from the images (active-Brownian fit with Dr) is the
    simulation's on the same cells' unwrapped centres within a quarter of its error
    (measured 0.00128 +- 0.00034 both), and the simulation's over all cells within 2 sigma
    (0.00170 +- 0.00047)."""
    from fcsweep.analysis.diffusion import estimate_diffusion
    from fcsweep.simulation import Simulation

    Dr = 0.1
    sim = Simulation.from_lattice(144, seed=5, eta=0.1, v0=0.1, Dr=Dr)
    sim.advance(4000)
    L = sim.state.box
    fov = (1.0, L[0] - 1.0, 1.0, L[1] - 1.0)
    frames, unwrapped = [], []
    for _ in range(160):
        s = sim.state
        frames.append(render_overlapping(s.pos, s.theta, s.a, s.b, L, 5, fov))
        unwrapped.append(s.unwrapped().copy())
        sim.advance(100)
    ds = measure(frames, 0.2, 0.5, Dr=Dr)
    ok = (ds.label.values > 0).all(0) & (ds.edge_cut.values == 0).all(0)
    assert ds.n_tracked.item() == ok.sum() > 60
    same = estimate_diffusion(ds.time.values, np.stack(unwrapped)[:, ds.label.values[0, ok] - 1], Dr=Dr)
    assert abs(ds.D_s.item() - same.D) < 0.25 * same.D_err
    every = estimate_diffusion(ds.time.values, np.stack(unwrapped), Dr=Dr)
    assert abs(ds.D_s.item() - every.D) < 2 * np.hypot(ds.D_s_err.item(), every.D_err)


@pytest.mark.slow
def test_simulated_soft_fluid_is_labelled_by_its_broken_cages():
    """144 cells at eta = 0.01, v0 = 0.25, Dr = 0.1 (~20 s), 100 frames 0.5 apart at 5 px per
    R0, no v0 or Dr given: the cages of the tracked cells break in the images (measured
    cage_msd_ratio 1.84, P = 0.999) as in the simulation's periodic cage analysis, and the
    movie is a soft fluid (<q> = 4.00 > 3.81) by its broken cages alone."""
    from fcsweep.analysis.cage import cage_breaking
    from fcsweep.simulation import Simulation

    sim = Simulation.from_lattice(144, seed=5, eta=0.01, v0=0.25, Dr=0.1)
    sim.advance(4000)
    L = sim.state.box
    fov = (1.0, L[0] - 1.0, 1.0, L[1] - 1.0)
    frames, unwrapped = [], []
    for _ in range(100):
        s = sim.state
        frames.append(render_overlapping(s.pos, s.theta, s.a, s.b, L, 5, fov))
        unwrapped.append(s.unwrapped().copy())
        sim.advance(100)
    ds = measure(frames, 0.2, 0.5)
    assert ds.n_tracked.item() > 40 and ds.cage_broken_probability.item() > 0.95
    assert cage_breaking(ds.time.values, np.stack(unwrapped), L).p_broken > 0.95
    assert int(ds.phase_movie) == 2 and "cages broken" in str(ds.phase_movie_reason.values)


@pytest.mark.parametrize("spacing, sweeps, percolated", [(2.6, 0, 0.0), (3.0, 20, 0.0), (6.0, 30, 1.0)])
def test_percolation_label_at_clear_points(spacing, sweeps, percolated):
    """A crystal (rho_d 0), a dense hard-disc fluid (~0.1) and a dilute one (~0.65): the
    percolated label is the exact centroids' answer, far from the threshold 1/2."""
    pos, theta, a, b, fov = _scene(14, 0, spacing, sweeps, step=1.0)
    ds = measure(render(pos, theta, a, b, 10, fov), 0.1).isel(time=0)
    exact = _exact_rho_d(ds, pos, theta, a, b, fov)
    assert abs(exact - 0.5) > 0.08
    assert ds.percolated.item() == percolated == float(exact > 0.5)
    if percolated:
        assert ds.spanning.item() == 1.0 and ds.largest_cluster_fraction.item() > 0.3
    else:
        assert ds.psi6.item() > (0.9 if sweeps == 0 else 0.0)


def test_open_voronoi_of_a_lattice_has_no_interior_defect():
    """A triangular lattice in a rectangle: every interior cell has 6 Voronoi sides, the
    outer ring is boundary."""
    xs, ys = np.meshgrid(np.arange(12), np.arange(12))
    pts = np.stack([(xs + 0.5 * (ys % 2)).ravel(), ys.ravel() * np.sqrt(3) / 2], 1) + 0.7
    v = open_voronoi(pts, (0.0, 12.7, 0.0, 11 * np.sqrt(3) / 2 + 1.4))
    assert v.interior.sum() >= 80
    assert np.all(v.n_sides[v.interior] == 6)
    assert not v.interior[np.argmin(pts[:, 0])]


def test_open_voronoi_interior_cells_agree_with_the_periodic_tessellation():
    """Random points in a periodic box: an interior cell's sides are those of the periodic
    Voronoi (freud), since no point outside can change them."""
    from fcsweep.analysis.voronoi import voronoi_neighbors

    rng = np.random.default_rng(5)
    pts = rng.uniform(0, 20, (400, 2))
    v = open_voronoi(pts, (0.0, 20.0, 0.0, 20.0))
    periodic = voronoi_neighbors(pts, (20.0, 20.0)).n_sides
    assert v.interior.sum() > 250
    np.testing.assert_array_equal(v.n_sides[v.interior], periodic[v.interior])


def test_tracking_by_overlap_and_msd():
    """Cells moved by small hard-disc moves (up to 0.72 R0 in all) between two frames, labels
    shuffled in the second: every uncut cell keeps its index, its displacement is the exact
    one within half a pixel (0.26 px measured), the MSD is the exact centroids' within 2 %
    (0.5 % measured), and the neighbour changes are those of the exact centroids (one T1)."""
    rng = np.random.default_rng(7)
    pos, theta, a, b, fov = _scene(12, 4, 3.0, 10)
    pos1 = pos.copy()
    rmax = bounding_radius(a, b)
    for k in rng.integers(len(pos), size=8 * len(pos)):  # moves of <= 0.3 R0 that keep cells apart
        trial = pos1[k] + rng.uniform(-0.3, 0.3, 2)
        d = np.hypot(*(pos1 - trial).T)
        d[k] = np.inf
        if np.all(d > rmax + rmax[k] + 0.05):
            pos1[k] = trial
    f0 = render(pos, theta, a, b, 10, fov)
    f1 = render(pos1, theta, a, b, 10, fov)
    perm = np.concatenate([[0], rng.permutation(f1.max()) + 1])
    ds = measure([f0, perm[f1]], 0.1)
    ok = (ds.label.values > 0).all(0) & (ds.edge_cut.values == 0).all(0)
    assert ds.n_tracked.item() == ok.sum() > 50
    true = _centroids(pos1, theta, a, b) - _centroids(pos, theta, a, b)
    cell = ds.label.values[0, ok] - 1
    assert np.all(ds.label.values[1, ok] == perm[cell + 1])  # the same cell under its new label
    disp = np.stack([ds.x.values[1, ok] - ds.x.values[0, ok], ds.y.values[1, ok] - ds.y.values[0, ok]], 1)
    assert np.abs(true[cell]).max() > 0.2 and (ds.msd.values[1] > 0.01)  # they did move
    assert np.abs(disp - true[cell]).max() < 0.05  # half a pixel (measured 0.026)
    d = true[cell] - true[cell].mean(0)
    assert ds.msd.values[1] == pytest.approx((d ** 2).sum(1).mean(), rel=0.02)
    # neighbour changes: those of the exact centroids' open Voronoi, on the same cells
    from fcsweep.measure.tracking import bond_changes

    bounds = (0.0, fov[1] - fov[0], 0.0, fov[3] - fov[2])
    bonds = []
    for k, p in enumerate((pos, pos1)):
        lab = ds.label.values[k]
        ok_k = lab > 0
        ref = np.stack([ds.x.values[k, ok_k], ds.y.values[k, ok_k]], 1)
        uncut = ds.edge_cut.values[k, ok_k] == 0
        cell_k = lab[ok_k] - 1 if k == 0 else np.argsort(perm)[lab[ok_k]] - 1
        ref[uncut] = (_centroids(p, theta, a, b) - [fov[0], fov[2]])[cell_k[uncut]]
        v = open_voronoi(ref, bounds)
        both = v.interior[v.i] & v.interior[v.j] & (v.i < v.j)
        bonds.append((np.stack([v.i[both], v.j[both]], 1), np.flatnonzero(ok_k)))
    exact = bond_changes(bonds[0][0], bonds[0][1], bonds[1][0], bonds[1][1])
    assert exact > 0 and abs(ds.bond_change_fraction.values[1] - exact) < 0.005  # one T1 among ~200 bonds
    assert np.isnan(ds.bond_change_fraction.values[0])


def test_diffusion_of_tracked_cells():
    """Dilute model cells making Gaussian steps (overlapping steps rejected) over 30 frames:
    D_s from the images agrees with the same estimator on the cells' exact centroids within
    half its error (measured 0.02558 +- 0.0029 against 0.02554 on 40 cells at 5 px per R0), and
    with the steps' sigma^2 / (2 dt) = 0.0225 within 3 sigma (1.1 sigma measured)."""
    from fcsweep.analysis.diffusion import estimate_diffusion

    rng = np.random.default_rng(11)
    pos, theta, a, b, fov = _scene(8, 5, 6.0, 0)
    rmax = bounding_radius(a, b)
    sigma, dt, frames, cen = 0.15, 0.5, [], []
    for _ in range(30):
        frames.append(render(pos, theta, a, b, 5, fov))
        cen.append(_centroids(pos, theta, a, b) - [fov[0], fov[2]])
        for k in range(len(pos)):
            trial = pos[k] + rng.normal(0, sigma, 2)
            d = np.hypot(*(pos - trial).T)
            d[k] = np.inf
            if np.all(d > rmax + rmax[k] + 0.05):
                pos[k] = trial
    ds = measure(frames, 0.2, dt, length_unit="um", time_unit="s")
    assert ds.D_s.attrs["units"] == "um2 s-1" and ds.n_tracked.item() > 20
    ok = (ds.label.values > 0).all(0) & (ds.edge_cut.values == 0).all(0)
    exact = estimate_diffusion(ds.time.values, np.stack(cen)[:, ds.label.values[0, ok] - 1], Dr=0.0)
    assert abs(ds.D_s.item() - exact.D) < 0.5 * exact.D_err  # the same cells, pixel errors only
    assert abs(ds.D_s.item() - sigma ** 2 / (2 * dt)) < 3 * ds.D_s_err.item()
    assert np.isnan(ds.D_eff.item())
    with_abp = measure(frames, 0.2, dt, v0=0.1, Dr=1.0)
    assert np.isfinite(with_abp.D_eff.item())


def test_contact_graph_of_a_confluent_monolayer_is_its_voronoi():
    """Label every pixel with its nearest seed (a confluent monolayer whose cells are the
    seeds' Voronoi cells, ~20 px across): the touching-neighbour graph gives the cells not
    cut by the edge their seeds' Voronoi sides (92 % of cells measured; a Voronoi edge
    shorter than a pixel is missed or a corner contact added), and rho_d within 0.02
    (0.006 measured)."""
    from scipy.spatial import Voronoi, cKDTree

    seeds = np.random.default_rng(2).uniform(0, 400, (400, 2))
    yy, xx = np.mgrid[0:400, 0:400]
    frame = (cKDTree(seeds).query(np.stack([xx.ravel() + 0.5, yy.ravel() + 0.5], 1))[1] + 1).reshape(400, 400)
    ds = measure(frame, neighbours="contact", track=False).isel(time=0)
    ok = ds.defect.values >= 0
    exact = np.bincount(Voronoi(seeds).ridge_points.ravel(), minlength=400)[ds.label.values[ok] - 1]
    assert ok.sum() > 300 and np.all(ok == (ds.edge_cut.values == 0))
    assert np.mean(ds.n_sides.values[ok] == exact) > 0.88
    assert abs(ds.rho_d.item() - np.mean(exact != 6)) < 0.02
    assert ds.attrs["neighbours"] == "contact"


@pytest.mark.parametrize("p_broken, q, expected", [(0.99, 3.70, 1), (0.99, 3.95, 2), (0.99, 3.81, 3),
                                                    (0.40, 3.70, 3), (float("nan"), 3.7, -1)])
def test_phase_from_cages_alone_without_d0(p_broken, q, expected):
    """Without v0 and Dr: broken cages (P >= 0.95) are "not solid", then <q> +- 0.01 against
    3.81 decides fluid (1) or soft fluid (2) with the product of the two probabilities;
    intact or untested cages leave the phase undetermined (3) or unknown (-1)."""
    from fcsweep.measure.labels import movie_labels

    nan = float("nan")
    values = dict(rho_d_movie=0.3, rho_d_movie_err=0.01, q_mean_movie=q, q_mean_movie_err=0.01, D_eff=nan,
                  D_eff_err=nan, D_s_diffusive=nan, cage_broken_probability=p_broken)
    code, conf, reason, _ = movie_labels(values, threshold=0.5)["phase"]
    assert code == expected, reason
    assert ("cages broken" in reason) == (p_broken > 0.95)
    assert movie_labels(values, threshold=0.5)["percolated"][0] == 0


@pytest.fixture(scope="module")
def stack():
    pos, theta, a, b, fov = _scene(8, 3, 3.0, 10)
    frames = [render(pos, theta, a, b, 6, fov)]
    pos2 = pos + 0.1
    frames.append(render(pos2, theta, a, b, 6, fov))
    return np.stack(frames).astype(np.uint16)


def _same(ds1, ds2):
    xr.testing.assert_identical(ds1.drop_attrs() if hasattr(ds1, "drop_attrs") else ds1,
                                ds2.drop_attrs() if hasattr(ds2, "drop_attrs") else ds2)


def test_readers_give_the_same_dataset(stack, tmp_path):
    """TIFF stack, PNG sequence (directory), Cellpose _seg.npy files and an iterator of frames."""
    tifffile = pytest.importorskip("tifffile")
    tifffile.imwrite(tmp_path / "s.tif", stack)  # contiguous: memory-mapped
    tifffile.imwrite(tmp_path / "z.tif", stack, compression="zlib")  # compressed: page by page
    tifffile.imwrite(tmp_path / "ij.tif", stack, imagej=True, metadata={"axes": "TYX"})
    (tmp_path / "png").mkdir()
    (tmp_path / "seg").mkdir()
    for k, fr in enumerate(stack):
        Image.fromarray(fr).save(tmp_path / "png" / f"f{k:03d}.png")
        np.save(tmp_path / "seg" / f"f{k:03d}_seg.npy",
                {"masks": fr, "outlines": np.zeros_like(fr), "filename": f"f{k}.tif", "chan_choose": [0, 0],
                 "diameter": 30.0}, allow_pickle=True)
    ref = measure(stack, 0.5, 2.0, length_unit="um", time_unit="min")
    for src in (tmp_path / "s.tif", tmp_path / "z.tif", tmp_path / "ij.tif", tmp_path / "png", tmp_path / "seg",
                iter(list(stack))):
        _same(ref, fcsweep.measure(src, pixel_size=0.5, frame_interval=2.0, length_unit="um", time_unit="min"))
    assert ref.x.attrs["units"] == "um" and ref.area.attrs["units"] == "um2"
    assert ref.time.attrs["units"] == "min" and list(ref.time.values) == [0.0, 2.0]
    out = tmp_path / "out"
    r = CliRunner().invoke(cli, ["measure", str(tmp_path / "seg"), "-o", str(out), "--pixel-size", "0.5",
                                 "--frame-interval", "2", "--length-unit", "um", "--time-unit", "min"])
    assert r.exit_code == 0, r.output
    with xr.open_dataset(out / "measure.nc") as disk:
        _same(ref, disk.load())


def test_time_stamps(stack):
    """Per-frame time stamps replace the interval; unequal spacing leaves the MSD out (its
    window average needs equal lags), non-increasing stamps are refused."""
    ds = measure(list(stack) + [stack[0]], times=[0.0, 2.0, 3.0])
    assert list(ds.time.values) == [0.0, 2.0, 3.0] and np.all(np.isnan(ds.msd.values))
    even = measure(list(stack) + [stack[0]], times=[1.0, 2.0, 3.0])
    assert even.msd.values[0] == 0 and np.isfinite(even.msd.values[1])
    with pytest.raises(MeasureInputError, match="must increase from frame to frame, got 0,2,1: frame 2 is at 1"):
        measure(stack, times=[0.0, 2.0, 1.0])
    with pytest.raises(MeasureInputError, match="3 time stamps given for 2 frames"):
        measure(stack, times=[0.0, 2.0, 3.0])


def test_calibration_from_imagej_and_ome_metadata(stack, tmp_path):
    """Pixel size, interval and units come from ImageJ / OME metadata; an option that
    contradicts them exits 2, one that agrees (in another spelling) is accepted."""
    tifffile = pytest.importorskip("tifffile")
    tifffile.imwrite(tmp_path / "ij.tif", stack, imagej=True, resolution=(1 / 0.5, 1 / 0.5),
                     metadata={"unit": "micron", "finterval": 2.0, "axes": "TYX"})
    tifffile.imwrite(tmp_path / "ome.tif", stack, ome=True,
                     metadata={"axes": "TYX", "PhysicalSizeX": 0.5, "PhysicalSizeY": 0.5, "PhysicalSizeXUnit": "µm",
                               "TimeIncrement": 2.0, "TimeIncrementUnit": "min"})
    ref = measure(stack, 0.5, 2.0, length_unit="um", time_unit="s")
    ij = measure(tmp_path / "ij.tif")
    _same(ref, ij)
    assert ij.attrs["pixel_size_x"] == 0.5 and ij.x.attrs["units"] == "um" and ij.time.attrs["units"] == "s"
    ome = measure(str(tmp_path / "ome.tif"), pixel_size=0.5, length_unit="µm")
    assert ome.time.attrs["units"] == "min" and ome.area.attrs["units"] == "um2"
    for opts, what in ((["--pixel-size", "0.6"], "pixel size"), (["--time-unit", "h"], "time unit")):
        r = CliRunner().invoke(cli, ["measure", str(tmp_path / "ome.tif"), "-o", str(tmp_path / "o"), *opts])
        assert r.exit_code == 2 and f"{what}" in r.output and "conflicts" in r.output, r.output


def test_builtin_example(tmp_path):
    """`fcsweep measure` without IMAGES measures the shipped example: 12 tracked frames of a
    soft monolayer (q > 3.81 on average at eta = 0.01, v0 = 0.06), lengths in R0."""
    r = CliRunner().invoke(cli, ["measure", "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    with xr.open_dataset(tmp_path / "measure.nc") as ds:
        assert ds.sizes["time"] == 12 and ds.attrs["pixel_size_x"] == 0.1
        assert 3.7 < float(ds.q_mean.mean()) < 4.2 and int(ds.n_tracked) > 10
        assert np.all(np.diff(ds.msd.values) > 0)
        assert float(ds.q_mean_movie) == pytest.approx(float(ds.q_mean.mean()), rel=1e-12)
        assert 0 < float(ds.rho_d_movie_err) < 0.1 and float(ds.D_s) > 0
        # 11 time units: the cells barely leave their cages, and without D_eff solid cannot be shown
        assert float(ds.cage_broken_probability) < 0.05 and float(ds.cage_msd_ratio) < 0.1
        assert int(ds.phase_movie) == 3 and "--v0 and --Dr" in str(ds.phase_movie_reason.values)
        # the simulation's rho_d rule: percolated iff P(rho_d > 1/2) >= 0.95, undetermined (2) between
        p = float(ds.percolated_movie_confidence)
        assert int(ds.percolated_movie) == (2 if p < 0.95 else int(float(ds.rho_d_movie) > 0.5))
    r = CliRunner().invoke(cli, ["measure", "-o", str(tmp_path), "--v0", "0.06", "--Dr", "0.01"])
    with xr.open_dataset(tmp_path / "measure.nc") as ds:  # 11 time units << 8 / Dr: D_eff decides nothing
        assert int(ds.phase_movie) == 3 and "8 / Dr" in str(ds.phase_movie_reason.values)


def test_streamed_file_is_the_python_api_dataset(tmp_path, monkeypatch):
    """The command streams measure.nc from the spool a few frames at a time; the file holds
    exactly the dataset that ``fcsweep.measure`` returns (values, dtypes, attributes)."""
    from fcsweep.measure import measure_to_file, store, write_measure
    from fcsweep.measure.command import EXAMPLE

    monkeypatch.setattr(store, "BLOCK_BYTES", 2048)  # several blocks per variable
    monkeypatch.setattr(store, "READ_CELLS", 100)
    ds = measure(EXAMPLE, 0.1, v0=0.06, Dr=0.01, track=True)
    streamed = xr.load_dataset(measure_to_file(EXAMPLE, tmp_path / "s", 0.1, v0=0.06, Dr=0.01))
    whole = xr.load_dataset(write_measure(ds, tmp_path / "w"))
    for d in (ds, streamed, whole):
        d.attrs.pop("history")
    assert streamed.identical(whole) and streamed.identical(ds)
    assert [p.name for p in (tmp_path / "s").iterdir()] == ["measure.nc"]  # the spool is removed


def test_measured_movies_drawn_beside_simulated_points(tmp_path, monkeypatch):
    """The <q> - rho_d figure: one error-bar marker per measured movie at its frame
    averages, the simulated points with theirs."""
    import matplotlib

    matplotlib.use("Agg")
    from test_figures import synthetic_dataset, with_statistics

    from fcsweep.results.figures.common import save_figure
    from fcsweep.results.figures.measured import measured_plane

    CliRunner().invoke(cli, ["measure", "-o", str(tmp_path)])
    with xr.open_dataset(tmp_path / "measure.nc") as m:
        m = m.load()
    sim = with_statistics(synthetic_dataset())
    fig = measured_plane(sim, [m, m], names=["a", "b"])
    ax = fig.axes[0]
    labels = ax.get_legend_handles_labels()[1]
    assert "measured: a" in labels and any(lab.startswith("simulated") for lab in labels)
    point = next(c for c in ax.containers if c.get_label() == "measured: a")[0]
    assert point.get_xdata()[0] == pytest.approx(float(m.q_mean_movie))
    assert point.get_ydata()[0] == pytest.approx(float(m.rho_d_movie))
    assert [p.suffix for p in save_figure(fig, tmp_path / "plane")] == [".png", ".pdf"]
    # `fcsweep plot --measured DIR` adds the figure to the sweep's
    from fcsweep.results import figures

    monkeypatch.setattr(figures, "sweep_dataset", lambda cfg: sim)
    monkeypatch.setattr(figures, "plot_dataset", lambda ds, outdir: [])
    paths = figures.plot_sweep(None, outdir=tmp_path / "figs", measured=[str(tmp_path)])
    assert [p.name for p in paths] == ["measured_q_rho.png", "measured_q_rho.pdf"]


def test_seg_npy_loader_refuses_code(tmp_path):
    """A _seg.npy whose pickle names any callable but numpy's array builders is refused, unrun."""
    marker = tmp_path / "ran"

    class Evil:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    path = tmp_path / "evil_seg.npy"
    with open(path, "wb") as fh:
        np.lib.format.write_array_header_1_0(fh, {"descr": "|O", "fortran_order": False, "shape": ()})
        pickle.dump(np.array({"masks": Evil()}, dtype=object), fh, protocol=3)
    with pytest.raises(MeasureInputError, match="refused"):
        read_seg_npy(path)
    assert not marker.exists()


def _broken(tmp_path, monkeypatch):
    tifffile = pytest.importorskip("tifffile")
    good = np.zeros((20, 20), np.uint16)
    good[5:12, 5:12] = 1
    tifffile.imwrite(tmp_path / "float.tif", good.astype(np.float32))
    tifffile.imwrite(tmp_path / "empty.tif", np.zeros((2, 20, 20), np.uint16))
    tifffile.imwrite(tmp_path / "negative.tif", np.where(good > 0, -3, 0).astype(np.int16))
    (tmp_path / "shapes").mkdir()
    Image.fromarray(good).save(tmp_path / "shapes" / "a.png")
    Image.fromarray(good[:15]).save(tmp_path / "shapes" / "b.png")
    np.save(tmp_path / "frac_seg.npy", {"masks": good * 1.5}, allow_pickle=True)
    tifffile.imwrite(tmp_path / "big.tif", good)
    np.save(tmp_path / "big_stack.npy", np.stack([good, good]))
    (tmp_path / "big_png").mkdir()
    Image.fromarray(good).save(tmp_path / "big_png" / "a.png")
    return {"float.tif": "float32", "empty.tif": "empty mask", "negative.tif": "negative label",
            "shapes": "differs from the first", "frac_seg.npy": "integers", "big.tif": "GiB",
            "big_stack.npy": "GiB", "big_png": "GiB"}


def test_broken_input_exits_2_with_one_line(tmp_path, monkeypatch):
    cases = _broken(tmp_path, monkeypatch)
    for name, words in cases.items():
        if name.startswith("big"):  # a frame larger than the memory available
            monkeypatch.setattr(measure_readers, "available_memory", lambda: 1000)
        r = CliRunner().invoke(cli, ["measure", str(tmp_path / name), "-o", str(tmp_path / "o")])
        assert r.exit_code == 2, (name, r.output)
        assert words in r.output and "Traceback" not in r.output, (name, r.output)
    assert not (tmp_path / "o").exists()  # no measure.nc, no scratch left, no empty directory made


def test_missing_extra_is_named(tmp_path, monkeypatch):
    """Without tifffile a TIFF is refused with the extra to install."""
    import builtins

    real = builtins.__import__

    def no_tifffile(name, *args, **kwargs):
        if name == "tifffile":
            raise ImportError("No module named 'tifffile'")
        return real(name, *args, **kwargs)

    (tmp_path / "x.tif").write_bytes(b"II*\x00")
    monkeypatch.setattr(builtins, "__import__", no_tifffile)
    r = CliRunner().invoke(cli, ["measure", str(tmp_path / "x.tif"), "-o", str(tmp_path / "o")])
    assert r.exit_code == 2 and "fcsweep[measure]" in r.output


def _traced_peak(fn):
    import tracemalloc

    tracemalloc.start()
    try:
        out = fn()
        return tracemalloc.get_traced_memory()[1], out
    finally:
        tracemalloc.stop()


def test_memory_does_not_grow_with_the_frames(tmp_path, monkeypatch):
    """measure.nc is written from a spool on disk, a few frames at a time: measuring 5x as many
    frames of the same movie raises the peak of the traced (Python and numpy) memory by less
    than a quarter of the time x cell output those frames add (holding that output would
    cost all of it).  What does grow is what the movie analysis needs: the centroids x, y
    of all tracks (16 of the output's 196 bytes per cell and frame) and the analysis's copies
    of the tracked ones."""
    from measure_render import drifting_frames, voronoi_base

    from fcsweep.measure import measure_to_file, store

    monkeypatch.setattr(store, "BLOCK_BYTES", 4096)  # write blocks of a few frames, as on large movies
    monkeypatch.setattr(store, "READ_CELLS", 256)

    base = voronoi_base(64, 4.0, margin=40)
    measure_to_file(drifting_frames(base, 64, 2), tmp_path / "warm")  # lazy imports, caches
    peaks, sizes = {}, {}
    for T in (4, 20):
        peaks[T], path = _traced_peak(lambda T=T: measure_to_file(drifting_frames(base, 64, T), tmp_path / str(T)))
        with xr.open_dataset(path) as ds:
            sizes[T] = sum(v.nbytes for v in ds.data_vars.values() if "cell" in v.dims)
    assert peaks[20] - peaks[4] < 0.25 * (sizes[20] - sizes[4]), (peaks, sizes)
