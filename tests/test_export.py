"""Trajectories in the viewers people use: GSD read back by gsd, OVITO and MDAnalysis, VTK
PolyData series read back by VTK (pyvista), each with the trajectory's positions, shapes and
per-cell data; the run directory is only read."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import gsd.hoomd
import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from conftest import dense_config
from fcsweep.analysis import shapes, voronoi
from fcsweep.results.export import (cell_contours, cluster_ids, export_gsd, export_vtk, parse_frames,
                                     periodic_copies)
from fcsweep.io.trajectory import open_trajectory
from fcsweep.cli import cli
from fcsweep.config import load_config
from fcsweep.model.shape import radius
from fcsweep.sweep.runner import run_one

#: One small run: 16 deformable cells, fast and persistent enough to move, 11 frames.
TINY = """
output: {out}
seed: 5
grid:
  v0: [0.3]
model: {{N: 16, eta: 0.05, Dr: 0.5, modes: 4, contour_points: 24}}
run: {{steps: 200, sample_every: 20, checkpoint_every: 100}}
"""


def _tree_digest(root: Path) -> dict:
    return {str(p.relative_to(root)): (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """(config path, trajectory path, the run directory's digest before any export)."""
    root = tmp_path_factory.mktemp("export")
    path = root / "tiny.yaml"
    path.write_text(TINY.format(out=root / "sweep"))
    cfg = load_config(path)
    spec = cfg.runs()[0]
    assert run_one(cfg, spec).outcome == "done"
    traj = cfg.run_dir(spec.run_id) / "trajectory.h5"
    return path, traj, _tree_digest(traj.parent)


@pytest.fixture(scope="module")
def exported(run, tmp_path_factory):
    """Every export flavour of the tiny run, into a directory outside the run."""
    _, traj, _ = run
    out = tmp_path_factory.mktemp("exported")
    return {
        "gsd": export_gsd(traj, out / "run.gsd", progress=False),
        "unwrapped": export_gsd(traj, out / "unwrapped.gsd", unwrapped=True, frames="::5", progress=False),
        "polygons": export_gsd(traj, out / "polygons.gsd", polygons=True, frames="-1", progress=False),
        "vtk": export_vtk(traj, out / "vtk", progress=False),
        "ascii": export_vtk(traj, out / "ascii", binary=False, frames="0,-1", progress=False),
        "images": export_vtk(traj, out / "images", images=True, frames="-1", progress=False),
        "no_defects": export_gsd(traj, out / "fast.gsd", defects=False, frames="0", progress=False),
    }


def _truth(traj_path, k):
    """(pos, theta, a, b, q, defect) of frame k straight from the trajectory."""
    t = open_trajectory(traj_path)
    pos = t.read("position", [k])[0]
    a, b = t.read("shape_a", [k])[0], t.read("shape_b", [k])[0]
    defect = voronoi.defect_mask(voronoi.voronoi_neighbors(pos, t.box).n_sides)
    return pos, t.read("theta", [k])[0], a, b, shapes.shape_indices(a, b), defect


# ------------------------------------------------------------------ pure pieces

@pytest.mark.parametrize("spec, want", [
    (None, list(range(10))), ("all", list(range(10))), ("-1", [9]), (3, [3]),
    ("0:10:4", [0, 4, 8]), ("::-3", [9, 6, 3, 0]), ("0, -1, 0", [0, 9]), ("8:", [8, 9]), ([1, -2], [1, 8]),
])
def test_frame_specs(spec, want):
    assert parse_frames(spec, 10).tolist() == want


@pytest.mark.parametrize("spec", ["10", "-11", "1:2:0", "a", "1:2:3:4", "5:5"])
def test_bad_frame_specs_are_refused(spec):
    with pytest.raises(ValueError, match="frames"):
        parse_frames(spec, 10)


def test_cluster_ids_label_the_defect_clusters_largest_first():
    pos, _, _, _, box = dense_config(N=64, seed=3, jitter=0.35)
    vn = voronoi.voronoi_neighbors(pos, box)
    defect = voronoi.defect_mask(vn.n_sides)
    ids = cluster_ids(defect, vn.i, vn.j)
    assert defect.any()
    assert np.array_equal(ids >= 0, defect)
    sizes = np.bincount(ids[defect])
    assert sizes.tolist() == voronoi.defect_clusters(defect, vn.i, vn.j).tolist()  # 0 = largest, no gaps
    bonded = defect[vn.i] & defect[vn.j]
    assert np.array_equal(ids[vn.i[bonded]], ids[vn.j[bonded]])  # neighbouring defects share a cluster


def test_contours_enclose_the_cell_area():
    """The model keeps every cell's area at pi R0^2 (a0 of the modes): a finely sampled
    contour encloses it to the trapezoidal rule's round-off, whatever the modes."""
    pos, theta, a, b, _ = dense_config(N=16, seed=1, deform=0.3)
    R0 = 1.7
    xy = cell_contours(pos, theta, a, b, R0, points=512)
    x, y = xy[..., 0], xy[..., 1]
    area = 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)
    # polygon area = pi R0^2 (1 - O(K^-2)) for smooth shapes: 512 points, modes n <= 6 -> < 1e-3
    assert np.allclose(area, np.pi * R0**2, rtol=1e-3)
    assert np.all(area > 0)  # counterclockwise, as VTK and GSD polygons expect


def test_periodic_copies_cover_both_sides_of_the_box():
    pos, theta, a, b, box = dense_config(N=36, seed=2)
    xy = cell_contours(pos, theta, a, b)
    all_xy, owner = periodic_copies(xy, box)
    assert np.array_equal(owner[:36], np.arange(36)) and len(owner) > 36
    lo, hi = all_xy.min(axis=1), all_xy.max(axis=1)
    assert np.all((hi > 0) & (lo < box))  # every copy shows inside the box
    assert np.allclose(all_xy - xy[owner], np.round((all_xy - xy[owner]) / box) * box)


# ------------------------------------------------------------------ files: gsd and the run directory

def test_export_never_touches_the_run_directory(run, exported):
    _, traj, before = run
    assert all(not Path(p).resolve().is_relative_to(traj.parent.resolve()) for p in exported.values())
    assert _tree_digest(traj.parent) == before


def test_gsd_holds_the_trajectory_in_a_2d_box(run, exported):
    _, traj_path, _ = run
    t = open_trajectory(traj_path)
    with gsd.hoomd.open(str(exported["gsd"]), "r") as f:
        assert len(f) == t.n_frames
        for k in (0, t.n_frames - 1):
            fr = f[k]
            pos, theta, a, b, q, defect = _truth(traj_path, k)
            assert fr.configuration.dimensions == 2 and fr.configuration.step == t.step[k]
            assert np.allclose(fr.configuration.box, [*t.box, 0, 0, 0, 0], rtol=1e-6)
            # HOOMD's box is centred at the origin; float32 positions
            assert np.allclose(fr.particles.position[:, :2] + t.box / 2, pos, atol=1e-5)
            assert np.all(fr.particles.position[:, 2] == 0)
            assert np.array_equal(fr.particles.image[:, :2], t.read("image", [k])[0])
            w, z = fr.particles.orientation[:, 0], fr.particles.orientation[:, 3]
            assert np.allclose(np.cos(theta), w**2 - z**2, atol=1e-6)
            assert np.allclose(np.sin(theta), 2 * w * z, atol=1e-6)
            assert np.allclose(fr.log["particles/q"], q, rtol=1e-6)
            assert np.array_equal(fr.log["particles/defect"].astype(bool), defect)
            assert np.allclose(fr.log["particles/a3"], a[:, 1], atol=1e-7)
            assert np.allclose(fr.log["particles/b2"], b[:, 0], atol=1e-7)
            assert fr.log["fcsweep/time"][0] == t.time[k]
        params = json.loads(f[0].log["fcsweep/parameters"].tobytes().decode())
        assert params["run_id"] == t.params["run_id"] and f[0].log["fcsweep/v0"][0] == 0.3
    with gsd.hoomd.open(str(exported["no_defects"]), "r") as f:
        names = set(f[0].log)
    assert "particles/q" in names and not names & {"particles/defect", "particles/cluster", "particles/n_sides"}
    with gsd.hoomd.open(str(exported["unwrapped"]), "r") as f:
        assert len(f) == 3
        for fr, k in zip(f, (0, 5, 10)):
            assert np.allclose(fr.particles.position[:, :2] + t.box / 2, t.unwrapped([k])[0], atol=1e-5)
            assert not fr.particles.image.any()


def test_gsd_polygons_are_the_cell_contours(run, exported):
    _, traj_path, _ = run
    pos, theta, a, b, _, _ = _truth(traj_path, -1)
    with gsd.hoomd.open(str(exported["polygons"]), "r") as f:
        fr = f[0]
    assert fr.particles.types == [f"cell{i}" for i in range(16)]
    shape = fr.particles.type_shapes[5]
    body = np.asarray(shape["vertices"])
    assert shape["type"] == "Polygon" and body.shape == (24, 2)
    c, s = np.cos(theta[5]), np.sin(theta[5])
    world = pos[5] + body @ np.array([[c, s], [-s, c]])  # rotated by the particle's orientation
    assert np.allclose(world, cell_contours(pos, theta, a, b, 1.0, 24)[5], atol=1e-12)


# ------------------------------------------------------------------ the real viewers

def viewer(module: str):
    """The viewer's module, or a skip that says why its import failed (the `viewers`
    extra is not part of `test`: ``pip install 'fcsweep[viewers]'``)."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:  # not installed, or installed without a usable library
        pytest.skip(f"import {module} failed ({type(exc).__name__}: {exc}); "
                    "the viewers extra: pip install 'fcsweep[viewers]'")

def test_ovito_loads_the_gsd_with_q_as_a_particle_property(run, exported):
    ovito_io = viewer("ovito.io")
    _, traj_path, _ = run
    t = open_trajectory(traj_path)
    pipeline = ovito_io.import_file(str(exported["gsd"]))
    assert pipeline.source.num_frames == t.n_frames
    for k in (0, t.n_frames - 1):
        data = pipeline.compute(k)
        pos, _, _, _, q, defect = _truth(traj_path, k)
        assert data.cell.is2D and data.particles.count == 16
        got = np.asarray(data.particles.positions)
        assert np.allclose(got[:, :2] + t.box / 2, pos, atol=4 * np.finfo(np.float32).eps * t.box.max())
        assert np.allclose(np.asarray(data.particles["q"]), q, rtol=np.finfo(np.float32).eps)
        assert np.array_equal(np.asarray(data.particles["defect"]).astype(bool), defect)
        assert data.attributes["fcsweep/time"] == pytest.approx(t.time[k])


def test_ovito_unwraps_with_the_image_counts(run, tmp_path):
    """OVITO's Unwrap trajectories modifier, fed the exported image counts, gives the
    trajectory's unwrapped centroids (image counts made up on a copy of the run)."""
    ovito_io = viewer("ovito.io")
    from ovito.modifiers import UnwrapTrajectoriesModifier

    _, traj_path, _ = run
    copy = tmp_path / "trajectory.h5"
    shutil.copy(traj_path, copy)
    with h5py.File(copy, "r+") as f:
        image = f["particles/cells/image/value"]
        image[...] = np.random.default_rng(4).integers(-2, 3, image.shape)
    t = open_trajectory(copy)
    pipeline = ovito_io.import_file(str(export_gsd(copy, tmp_path / "u.gsd", progress=False)))
    pipeline.modifiers.append(UnwrapTrajectoriesModifier())
    for k in (0, t.n_frames - 1):
        got = np.asarray(pipeline.compute(k).particles.positions)[:, :2] + t.box / 2
        assert np.allclose(got, t.unwrapped([k])[0], atol=4 * np.finfo(np.float32).eps * 3 * t.box.max())


def test_ovito_renders_the_cell_shapes(exported, tmp_path):
    viewer("ovito.io")
    from ovito.io import import_file
    from ovito.modifiers import ColorCodingModifier
    from ovito.vis import OpenGLRenderer, Viewport

    pipeline = import_file(str(exported["polygons"]))
    pipeline.modifiers.append(ColorCodingModifier(property="q", start_value=3.545, end_value=3.9))
    pipeline.add_to_scene()
    try:
        vp = Viewport(type=Viewport.Type.Top)
        vp.zoom_all()
        png = tmp_path / "frame.png"
        vp.render_image(filename=str(png), size=(240, 200), renderer=OpenGLRenderer())
    except RuntimeError as exc:
        if "Vulkan" in str(exc):
            pytest.skip("no Vulkan loader/driver (Debian: apt install libvulkan1 mesa-vulkan-drivers)")
        raise
    finally:
        pipeline.remove_from_scene()
    import matplotlib.image

    rgb = matplotlib.image.imread(png)[..., :3]
    colours = np.unique(np.round(rgb.reshape(-1, 3) * 255).astype(int), axis=0)
    assert len(colours) > 16  # cells in several colours of q, not a blank canvas


def test_mdanalysis_iterates_every_frame(run, exported):
    mda = viewer("MDAnalysis")
    _, traj_path, _ = run
    t = open_trajectory(traj_path)
    u = mda.Universe(str(exported["gsd"]))
    assert u.atoms.n_atoms == 16 and u.trajectory.n_frames == t.n_frames
    seen = 0
    for ts in u.trajectory:
        pos = t.read("position", [ts.frame])[0]
        assert np.allclose(u.atoms.positions[:, :2] + t.box / 2, pos, atol=1e-5)
        assert np.allclose(ts.dimensions[:2], t.box, rtol=1e-6)
        seen += 1
    assert seen == t.n_frames


def _polylines(mesh):
    """Point ids of each polyline of a pyvista PolyData (VTK's legacy cell array layout)."""
    lines, out, i = np.asarray(mesh.lines), [], 0
    while i < len(lines):
        out.append(lines[i + 1:i + 1 + lines[i]])
        i += 1 + lines[i]
    return out


def test_vtk_files_hold_one_closed_contour_per_cell(run, exported):
    pv = viewer("pyvista")
    _, traj_path, _ = run
    t = open_trajectory(traj_path)
    reader = pv.get_reader(str(exported["vtk"]))
    assert np.allclose(reader.time_values, t.time)
    for k in (0, t.n_frames - 1):
        mesh = pv.read(exported["vtk"].parent / f"cells_{k:06d}.vtp")
        pos, theta, a, b, q, defect = _truth(traj_path, k)
        lines = _polylines(mesh)
        assert mesh.n_cells == len(lines) == 16
        phi = 2 * np.pi * np.arange(24) / 24
        R = radius(phi, a, b, 1.0)[0]
        for i, ids in enumerate(lines):
            assert len(ids) == 25 and ids[0] == ids[-1]  # 24 contour points, closed
            xy = pos[i] + R[i, :, None] * np.stack([np.cos(theta[i] + phi), np.sin(theta[i] + phi)], -1)
            assert np.allclose(mesh.points[ids[:-1], :2], xy, rtol=0, atol=1e-12)
        assert not mesh.points[:, 2].any()
        assert np.allclose(mesh.cell_data["q"], q, rtol=1e-12)
        assert np.array_equal(mesh.cell_data["defect"].astype(bool), defect)
        assert mesh.field_data["TimeValue"][0] == t.time[k] and mesh.field_data["step"][0] == t.step[k]
    ascii_last = pv.read(exported["ascii"].parent / f"cells_{t.n_frames - 1:06d}.vtp")
    assert np.array_equal(ascii_last.points, mesh.points)
    assert np.array_equal(ascii_last.cell_data["cluster"], mesh.cell_data["cluster"])
    with_images = pv.read(exported["images"].parent / f"cells_{t.n_frames - 1:06d}.vtp")
    owner = with_images.cell_data["cell"]
    assert np.array_equal(owner[:16], np.arange(16)) and set(owner[16:]) <= set(range(16))
    assert np.array_equal(with_images.cell_data["q"], mesh.cell_data["q"][owner])


# ------------------------------------------------------------------ command line

def test_export_command(run, tmp_path):
    config, traj, before = run
    out = tmp_path / "last.gsd"
    r = CliRunner().invoke(cli, ["export", "0", str(config), "--frames", "-1", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert r.output.strip().endswith(str(out)) and out.stat().st_size > 0
    r = CliRunner().invoke(cli, ["export", str(traj), "--format", "vtk", "--frames", "0:3",
                                 "--out", str(tmp_path / "v")])
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "v").iterdir()) == [
        "cells.pvd", "cells_000000.vtp", "cells_000001.vtp", "cells_000002.vtp"]
    r = CliRunner().invoke(cli, ["export", "0", str(config), "--frames", "99", "--out", str(tmp_path / "x.gsd")])
    assert r.exit_code == 2 and "out of range" in r.output
    assert not (tmp_path / "x.gsd").exists()
    assert _tree_digest(traj.parent) == before
