"""The analysis read in pieces (fcsweep.analysis.frames) gives the numbers of the arrays held whole.

The MSD, D_eff, the cage measure and the q statistics of a run are computed a block of
cells or of frames at a time when their input is a frame source; each cell's own window
MSD is freud's on the same displacements, only the sums over cells are split, so every
number agrees with the all-at-once functions to rounding (relative 1e-12 asked; the sums
differ in their last bits only). The blocks are made tiny here (a few cells, one or two
frames) so that every split is exercised.
"""

from __future__ import annotations

import numpy as np
import pytest

from fcsweep.analysis import diffusion, frames, shapes
from fcsweep.analysis.cage import cage_breaking
from fcsweep.analysis.frames import ArrayFrames
from fcsweep.analysis.msd import msd_curve, msd_curve_streamed
from fcsweep.analysis.run_observables import RunFrames, compute_observables, frame_plan
from fcsweep.model.lattice import hexagonal_lattice
from fcsweep.results.analyze import read_run_frames, settings_with, trajectory_observables

REL = 1e-12


@pytest.fixture
def tiny_blocks(monkeypatch):
    """Blocks of about 7 cells over all frames read, computed on 3 at a time; single
    frames; a cache of 2 frames."""
    monkeypatch.setattr(frames, "BLOCK_BYTES", 7 * 60 * 16)
    monkeypatch.setattr(frames, "WORK_BYTES", 3 * 60 * 16)
    monkeypatch.setattr(frames, "CACHE_BYTES", 1)


def _creeping(T=60, N=64, step=0.08, seed=5):
    """Cells random-walking off a triangular lattice with a common drift, unwrapped."""
    lattice, box = hexagonal_lattice(N)
    rng = np.random.default_rng(seed)
    walk = np.cumsum(step * rng.standard_normal((T, N, 2)), axis=0) + np.linspace(0, 3.0, T)[:, None, None]
    return lattice[None] + walk, np.asarray(box, dtype=float)


def _same(a, b, rel=REL):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    assert np.array_equal(np.isnan(a), np.isnan(b))
    ok = ~np.isnan(a)
    np.testing.assert_allclose(a[ok], b[ok], rtol=rel, atol=rel * max(1e-300, np.max(np.abs(a[ok]), initial=0.0)))


@pytest.mark.parametrize("drift", [True, False])
def test_msd_by_blocks_of_cells_is_the_msd_of_all(tiny_blocks, drift):
    x, _ = _creeping()
    src = ArrayFrames(x)
    assert len(src.cell_blocks()) > 5  # the split is exercised
    _same(msd_curve_streamed(src, subtract_drift=drift), msd_curve(x, subtract_drift=drift, n_blocks=1)[0])


@pytest.mark.parametrize("T", [60, 200])  # one time block (compared with two) and several
def test_diffusion_estimate_streamed_equals_held(tiny_blocks, T):
    x, _ = _creeping(T=T)
    t = np.arange(T) * 5.0
    held = diffusion.estimate_diffusion(t, x, Dr=0.1, min_block_persistence=1.0)
    streamed = diffusion.estimate_diffusion(t, ArrayFrames(x), Dr=0.1, min_block_persistence=1.0)
    assert held.n_time_blocks == streamed.n_time_blocks and (T < 100 or held.n_time_blocks > 2)
    for name, value in held.__dict__.items():
        if isinstance(value, (bool, int, np.bool_)):
            assert getattr(streamed, name) == value, name
        else:
            _same(getattr(streamed, name), value)


def test_cage_breaking_from_single_frames_equals_held(tiny_blocks):
    x, box = _creeping(step=0.3)
    t = np.arange(x.shape[0]) * 5.0
    held, streamed = cage_breaking(t, x, box), cage_breaking(t, ArrayFrames(x), box)
    assert np.isfinite(held.D_late)  # the cages broke: the added lags are exercised too
    for name, value in held.__dict__.items():
        _same(getattr(streamed, name), value, rel=0.0)  # the same arithmetic on the same frames


def test_q_statistics_by_blocks_of_frames(tiny_blocks):
    rng = np.random.default_rng(2)
    q = 3.6 + 0.3 * rng.random((7, 50))
    acc = shapes.QStatistics()
    for k in range(0, 7, 2):
        acc.add(q[k:k + 2])
    got, ref = acc.result(), shapes.q_statistics(q)
    for name in ("q_mean", "q_std", "q_frac_above", "q_hist"):
        _same(got[name], ref[name])
    _same(got["q_mean_frames"], q.mean(axis=1), rel=0.0)


def _write_run(path, T=40, N=64, seed=4):
    """A trajectory file of wrapped, creeping cells with small random shapes."""
    from fcsweep.io.h5md import append_frames, create_trajectory

    x, box = _creeping(T=T, N=N, step=0.15, seed=seed)
    img = np.floor(x / box).astype(np.int32)
    rng = np.random.default_rng(seed)
    a, b = 0.02 * rng.standard_normal((2, T, N, 5))
    create_trajectory(path, n_cells=N, box=box, modes_width=5, fields=("position", "image", "shape_a", "shape_b"),
                      parameters={"R0": 1.0, "v0": 0.05, "Dr": 0.1, "modes": 6}, dt=0.005, frames_per_chunk=3)
    append_frames(path, [{"position": x[k] - img[k] * box, "image": img[k], "shape_a": a[k], "shape_b": b[k],
                          "step": 1000 * k, "time": 5.0 * k, "projections": 0} for k in range(T)])


def test_a_trajectory_read_in_pieces_gives_the_observables_of_the_arrays_held(tmp_path, monkeypatch):
    from fcsweep.io.trajectory import open_trajectory

    _write_run(tmp_path / "trajectory.h5")
    traj = open_trajectory(tmp_path / "trajectory.h5")
    s = settings_with({"structure_frames": 6, "correlation_frames": 2, "shape_frames": 9, "correlations": "fft"},
                      transient=0.2)
    lazy = read_run_frames(traj, s)
    plan = frame_plan(traj.n_frames, s)
    np.testing.assert_array_equal(lazy.unwrapped.cells(5, 9), traj.unwrapped(plan.frames)[:, 5:9])
    np.testing.assert_array_equal(lazy.positions[2], traj.read("position", plan.structure_frames)[2])
    held = RunFrames(**{**lazy.__dict__, "shape_a": traj.read("shape_a", plan.shape_frames),
                        "shape_b": traj.read("shape_b", plan.shape_frames),
                        "positions": traj.read("position", plan.structure_frames),
                        "unwrapped": traj.unwrapped(plan.frames)})
    ref_sc, ref_cv, _ = compute_observables(held, s)  # one block: every array whole
    monkeypatch.setattr(frames, "BLOCK_BYTES", 5 * 40 * 16)
    monkeypatch.setattr(frames, "WORK_BYTES", 2 * 40 * 16)
    monkeypatch.setattr(frames, "CACHE_BYTES", 1)
    sc, cv, _ = trajectory_observables(open_trajectory(tmp_path / "trajectory.h5"), s)
    assert np.isfinite(ref_sc["D_eff"]) and np.isfinite(ref_sc["q_mean"]) and np.isfinite(ref_sc["cage_msd_ratio"])
    for k, v in ref_sc.items():
        if isinstance(v, str):
            assert sc[k] == v, k
        else:
            _same(sc[k], v)
    for k, (c, v) in ref_cv.items():
        _same(cv[k][0], c)
        _same(cv[k][1], v)
