"""Results commands killed, on a full file system, in a read-only tree (issue 37).

- Kills at the named points of every atomic write (``FCSWEEP_TEST_KILL_AT=<file>:<point>``,
  :mod:`fcsweep.io.failures`), in ``-j`` workers too, and SIGKILL / SIGTERM / SIGINT at
  random times: every analysis.h5 and phase_diagram.nc stays readable, and the next run of
  the command exits 0 and leaves no temporary file.
- A real tmpfs filled to the last byte (needs root and ``mount``: skipped with the reason
  otherwise): analyze --force, aggregate, export, plot and movie exit 1 or 2 with one line
  naming the lack of space, no traceback, earlier results byte for byte; after space is
  freed analyze --force and aggregate succeed.
- A read-only run tree by chmod (skipped under root, which ignores permissions: the
  injected EROFS of tests/test_results_writes.py covers it there).
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest
import xarray as xr
from click.testing import CliRunner

import results_sweep as rs
from results_sweep import analysed, sweep  # noqa: F401 - the shared fixtures
from fcsweep.cli import cli

ROOT = Path(__file__).resolve().parent.parent


def _env(**extra):
    return {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": "1", **extra}


def _cli(args, timeout=300, **env):
    return subprocess.run([sys.executable, "-m", "fcsweep.cli", *args], env=_env(**env), capture_output=True,
                          text=True, timeout=timeout)


def _readable(out: Path) -> None:
    for p in out.glob("runs/*/analysis.h5"):
        with h5py.File(p, "r") as f:
            assert "observables" in f, p
    if (out / "phase_diagram.nc").exists():
        with xr.open_dataset(out / "phase_diagram.nc") as ds:
            assert "phase" in ds


def _again(cmd, cfg, out):
    """The next run of the command exits 0, says nothing went wrong, leaves no temporary."""
    r = _cli(cmd(cfg))
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    assert not rs.temporaries(out)
    _readable(out)


ANALYZE = lambda cfg: ["analyze", str(cfg), "--force"]  # noqa: E731
ANALYZE_J = lambda cfg: ["analyze", str(cfg), "--force", "-j", "2"]  # noqa: E731
AGGREGATE = lambda cfg: ["aggregate", str(cfg)]  # noqa: E731


@pytest.mark.slow
def test_kill_before_the_dataset_rename(sweep):
    cfg, out, before = sweep
    r = _cli(AGGREGATE(cfg), FCSWEEP_TEST_KILL_AT="phase_diagram.nc:before-rename")
    assert r.returncode == -signal.SIGKILL
    assert rs.results(out) == before and rs.temporaries(out)  # the killed writer's file is left ...
    _again(AGGREGATE, cfg, out)  # ... and removed by the next aggregate


@pytest.mark.slow
@pytest.mark.parametrize("point", ["written", "before-rename", "after-rename"])
@pytest.mark.parametrize("cmd,name", [(ANALYZE, "analysis.h5"), (ANALYZE_J, "analysis.h5"),
                                      (AGGREGATE, "phase_diagram.nc")], ids=["analyze", "analyze-j2", "aggregate"])
def test_kill_at_every_named_point(sweep, cmd, name, point):
    cfg, out, before = sweep
    r = _cli(cmd(cfg), FCSWEEP_TEST_KILL_AT=f"{name}:{point}:2" if name == "analysis.h5" else f"{name}:{point}")
    assert r.returncode != 0
    assert "Traceback" not in r.stderr
    _readable(out)
    if point != "after-rename" and cmd is not ANALYZE_J:
        assert rs.results(out) == before or name == "analysis.h5"  # analyses before the kill were replaced
    _again(cmd, cfg, out)


@pytest.mark.slow
@pytest.mark.parametrize("cmd", [ANALYZE, AGGREGATE], ids=["analyze", "aggregate"])
def test_random_kills(sweep, cmd):
    """10 signals at random times during each command (SIGKILL, SIGTERM, SIGINT), after it
    started (printed the output directory: before that Python is still importing, nothing
    is written, and Python's own handling applies).  Killed by SIGINT / SIGTERM (-2 / -15
    here) is what a shell reports as 130 / 143, as for the exit codes the command sets."""
    cfg, out, _ = sweep
    rng = random.Random(37)
    t0 = time.monotonic()
    assert _cli(cmd(cfg)).returncode == 0
    span = time.monotonic() - t0
    for _ in range(10):
        sig = rng.choice([signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
        p = subprocess.Popen([sys.executable, "-m", "fcsweep.cli", *cmd(cfg)], env=_env(),
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        first = p.stderr.readline()
        assert "output directory" in first, first
        time.sleep(rng.uniform(0.0, 0.8 * span))
        p.send_signal(sig)
        err = first + p.communicate(timeout=300)[1]
        assert p.returncode in (0, -signal.SIGKILL, 130, 143, -signal.SIGINT, -signal.SIGTERM), (sig, p.returncode, err)
        assert "Traceback" not in err, err
        if p.returncode != -signal.SIGKILL:
            assert not rs.temporaries(out), err
        _readable(out)
    _again(cmd, cfg, out)


@pytest.mark.skipif(hasattr(os, "geteuid") and os.geteuid() == 0,
                    reason="root ignores permissions; tests/test_results_writes.py injects EROFS instead")
def test_read_only_tree_by_chmod(sweep):
    cfg, out, before = sweep
    dirs = [out, *out.glob("runs/*")]
    for d in dirs:
        d.chmod(0o555)
    try:
        for cmd in (ANALYZE, AGGREGATE):
            r = _cli(cmd(cfg))
            assert r.returncode == 2 and "permission denied" in r.stderr, r.stderr
            assert "Traceback" not in r.stderr
        assert rs.results(out) == before
    finally:
        for d in dirs:
            d.chmod(0o755)


@pytest.fixture
def tiny_fs(tmp_path):
    """A 16 MB tmpfs (root and mount needed)."""
    mnt = tmp_path / "fs"
    mnt.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=16m", "tmpfs", str(mnt)], capture_output=True, text=True)
    if r.returncode:
        pytest.skip(f"mount not permitted here: {r.stderr.strip()}")
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], check=False)


def _fill(mnt: Path) -> Path:
    """Fill the file system to the last byte."""
    filler = mnt / "filler"
    with open(filler, "wb", buffering=0) as f:
        for block in (1 << 16, 1):
            try:
                while f.write(b"\0" * block):
                    pass
            except OSError:
                pass
    return filler


def test_full_file_system(analysed, tiny_fs):
    cfg = rs.copy(analysed, tiny_fs)
    out = tiny_fs / "sweep"
    before = rs.results(out)
    filler = _fill(tiny_fs)
    pytest.importorskip("gsd")
    commands = {
        "analyze": ANALYZE(cfg),
        "aggregate": AGGREGATE(cfg),
        "export": ["export", "0", str(cfg), "--frames", "0:3", "--out", str(tiny_fs / "x.gsd")],
        "plot": ["plot", str(cfg)],
        "movie": ["movie", "0", str(cfg), "--every", "20", "--dpi", "50"],
    }
    for name, args in commands.items():
        r = CliRunner().invoke(cli, args)
        assert r.exit_code in (1, 2), (name, r.output)
        assert "Traceback" not in r.output and "no space left on device" in r.stderr, (name, r.output)
        assert rs.results(out) == before, name
        assert not rs.temporaries(tiny_fs), name
    filler.unlink()
    for args in (ANALYZE(cfg), AGGREGATE(cfg)):
        r = CliRunner().invoke(cli, args)
        assert r.exit_code == 0, r.output
    _readable(out)
