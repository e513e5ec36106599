"""A newcomer's first hour (issue 48): importing fcsweep changes no process-wide numba
setting, the kernels cache in their source-hash directory, a cold compile runs in stages
(two processes) that give the demo's step everything it needs, and movie frames after
the first redraw only what changes, pixel for pixel as a full drawing."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from fake_trajectory import FakeTrajectory


def _python(code: str, env=None) -> str:
    """Run ``code`` in a new interpreter (``env`` added to this one's; None removes a name)."""
    full = {k: v for k, v in {**os.environ, **(env or {})}.items() if v is not None}
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                         env=full, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def test_importing_the_kernels_leaves_numbas_cache_setting_alone(tmp_path):
    """numba.config.CACHE_DIR is what it was (another library's cached functions go where
    they always go), and every kernel's own cache is in the source-hash directory."""
    out = _python("""
        import numba.core.config as config
        before = config.CACHE_DIR
        import fcsweep, fcsweep.simulation
        from fcsweep.kernels import cache_dir, step, rates
        print(repr(before) == repr(config.CACHE_DIR))
        for d in (step.run_chunk, step.compute_rates, rates.all_rates):
            print(d._cache._cache_path.startswith(str(cache_dir())))
        print(cache_dir())
    """, env={"NUMBA_CACHE_DIR": str(tmp_path)})
    lines = out.split()
    assert lines[:4] == ["True"] * 4
    assert lines[4].startswith(str(tmp_path / "fcsweep-"))


def test_a_users_own_cached_function_is_cached_where_numba_puts_it(tmp_path):
    """With fcsweep imported, a user's cache=True function writes to its own __pycache__,
    not into fcsweep's kernel cache (what a process-wide CACHE_DIR did)."""
    mod = tmp_path / "user_mod.py"
    mod.write_text("from numba import njit\n\n@njit(cache=True)\ndef twice(x):\n    return 2 * x\n")
    cache = tmp_path / "fcsweep-cache"
    _python(f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        import fcsweep.kernels.step  # the kernels are decorated
        import user_mod
        assert user_mod.twice(2) == 4
    """, env={"XDG_CACHE_HOME": str(cache), "NUMBA_CACHE_DIR": None})
    assert list((tmp_path / "__pycache__").glob("user_mod.twice-*.nbi"))
    assert not list(cache.rglob("user_mod*"))


def test_the_cache_is_named_after_the_kernel_and_model_sources(tmp_path):
    """The directory's tag hashes the kernels and the model modules they import (the
    contact-arc constants in model/rates.py: numba would not see them change), and
    $XDG_CACHE_HOME is honoured."""
    from pathlib import Path

    import fcsweep.kernels.cache as cache

    kernels = sorted(Path(cache.__file__).parent.glob("*.py"))
    assert Path(cache.__file__).parents[1] / "model" / "rates.py" in cache.model_sources(kernels)
    out = _python("from fcsweep.kernels import cache_dir; print(cache_dir())",
                  env={"XDG_CACHE_HOME": str(tmp_path), "NUMBA_CACHE_DIR": None})
    got = Path(out.strip())
    assert got.parent == tmp_path / "fcsweep" and got.name.startswith("numba-") and len(got.name) == 18


def test_compile_stages_name_every_kernel_the_step_calls():
    """The stages cover the non-inlined kernels of the step once each (a kernel compiled in
    two stages would be compiled twice), and each leaf job has as many argument types as
    its kernel has parameters."""
    import inspect

    from fcsweep.sweep.warmup import STAGES, leaf_jobs

    names = [k for _, _, kernels, _ in STAGES for k in kernels]
    assert len(names) == len(set(names))
    for stage in ("rates", "others"):
        jobs = leaf_jobs(stage)
        kernels = next(k for name, _, k, _ in STAGES if name == stage)
        assert [f"{d.py_func.__module__.rsplit('.', 1)[1]}.{d.__name__}" for d, _ in jobs] == list(kernels)
        for disp, sig in jobs:
            assert len(sig) == len(inspect.signature(disp.py_func).parameters)


def test_compile_says_each_stage_once_with_an_estimate_when_not_on_a_terminal(monkeypatch):
    """Not on a terminal: a line at the start with the estimate, one per stage, one at the
    end; no bar (kernels loaded from the cache here, as if cold)."""
    import fcsweep.sweep.warmup as warmup

    monkeypatch.setattr(warmup, "kernels_cached", lambda: False)
    lines = []
    warmup.compile_kernels(lines.append, tick=3600, parallel=False, progress=False)
    assert lines[0].startswith("compiling kernels (first use") and " min (one process)" in lines[0]
    stage_lines = [ln for ln in lines if ln.startswith("compiled the ")]
    assert len(stage_lines) == len(warmup.STAGES)
    assert "about" in stage_lines[0] and "s left" in stage_lines[0]
    assert lines[-1].startswith("kernels compiled in") and len(lines) == len(warmup.STAGES) + 2


@pytest.mark.slow
def test_a_cold_parallel_compile_leaves_nothing_for_the_demo_to_compile(tmp_path):
    """From an empty cache, `compile_kernels(parallel=True)` (two processes and the step)
    writes every kernel once (one signature per leaf kernel, no second overload), and the
    demo's own step (N = 64, 6 modes, 40 points, binary) then compiles nothing (about
    five minutes on two cores)."""
    env = {"NUMBA_CACHE_DIR": str(tmp_path)}
    _python("from fcsweep.sweep.warmup import compile_kernels; compile_kernels(parallel=True)", env)
    out = _python("""
        from numba.core import event
        compiled = []
        class Seen(event.Listener):
            def on_start(self, e):
                compiled.append(e.data["dispatcher"].py_func.__qualname__)
            def on_end(self, e):
                pass
        event.register("numba:compile", Seen())
        from fcsweep.config import builtin_demo_path, load_config
        from fcsweep.simulation import Simulation
        p = dict(load_config(builtin_demo_path()).runs()[0].params)
        keys = ("modes", "contour_points", "quadrature", "Dr", "dt", "density")
        sim = Simulation.from_lattice(int(p["N"]), eta=p["eta"], v0=p["v0"], seed=1, **{k: p[k] for k in keys})
        sim.advance(5)
        print(compiled)
    """, env)
    assert out.strip() == "[]"
    from fcsweep.sweep.warmup import STAGES

    index = {f.name.split("-")[0]: f for f in tmp_path.rglob("*.nbi")}
    for _, _, kernels, _ in STAGES:
        for k in kernels:
            assert k in index, f"{k} was not cached"
            assert len(list(index[k].parent.glob(index[k].name.replace(".nbi", ".*.nbc")))) == 1, k


def _Frames(n_frames=12):
    """The parts of a trajectory that movie frames read: 16 cells drifting, one defect."""
    return FakeTrajectory(n_frames, step=0.05)


def _render(traj, blit: bool, frames=None):
    from fcsweep.results import figures as plots
    from fcsweep.results.figures.frames import _frame, _frame_title

    art = plots.FrameArtist(traj.box, width=plots.SLIDE, dpi=100, style=plots.SLIDE_STYLE)
    art._blit = blit
    out = []
    for k in frames if frames is not None else range(traj.n_frames):
        pos, theta, a, b, q, _, radii, rho = _frame(traj, k)
        defect = np.arange(len(pos)) == k % len(pos)
        art.draw(pos, theta, a, b, q, defect, _frame_title(traj, k, rho, plain_time=True), radii)
        out.append(art.rgb())
    return out


def test_movie_frames_redrawn_in_part_equal_whole_drawings():
    """Each frame of a movie figure (redrawing only cells, dots and title over the first
    frame's drawing) equals a new figure drawn whole and laid out, but for a few
    antialiased edge pixels (none at 120 dpi; a dozen values of 10^6 at 100 dpi)."""
    traj = _Frames(6)
    fast = _render(traj, True)
    for k in (0, 3, 5):
        whole = _render(traj, False, [k, k])[-1]  # drawn twice: constrained layout settled
        assert fast[k].shape == whole.shape
        differ = np.count_nonzero(fast[k] != whole)  # a few antialiased edge pixels at most
        assert differ <= 1e-4 * whole.size, f"frame {k}: {differ} of {whole.size} values differ"


def test_movie_frames_after_the_first_are_several_times_faster():
    """The partial redraw is what makes `fcsweep movie` fast: after the first frame a
    frame costs at most a third of a whole drawing (measured here about a seventh)."""
    traj = _Frames(13)

    def per_frame(blit):
        _render(traj, blit, [0])  # fonts and mathtext caches warm
        t0 = time.perf_counter()
        _render(traj, blit, range(1))
        first = time.perf_counter() - t0
        t0 = time.perf_counter()
        _render(traj, blit)
        return (time.perf_counter() - t0 - first) / (traj.n_frames - 1)

    assert per_frame(False) > 3 * per_frame(True)


def test_movie_progress_is_a_line_per_quarter_when_logged(tmp_path, monkeypatch):
    pytest.importorskip("imageio_ffmpeg")
    import fcsweep.io.trajectory as trajectory
    from fcsweep.results import figures as plots

    monkeypatch.setattr(trajectory, "open_trajectory", lambda p: _Frames(8))
    lines = []
    plots.movie_run(tmp_path / "trajectory.h5", tmp_path / "m.mp4", dpi=60, progress=lines.append)
    assert lines == [f"movie: {n}/8 frames" for n in (2, 4, 6, 8)]
