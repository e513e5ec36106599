"""Results commands lose nothing (issue 37): a write that fails for a reason of the
environment (full disk, quota, read-only directory) or is interrupted leaves every earlier
analysis.h5 and phase_diagram.nc byte for byte, no temporary file, and one line naming
the file, the cause and what to do; exit 2 when nothing was written, 1 when part was.

The failures are injected (``FCSWEEP_TEST_WRITE_ERROR``, monkeypatch), so these tests run
everywhere; tests/test_results_kills.py kills real processes and fills a real (tmpfs)
file system.
"""

from __future__ import annotations

import errno
import os

import pytest
from click.testing import CliRunner

import results_sweep as rs
from results_sweep import analysed, sweep  # noqa: F401 - the shared fixtures
from fcsweep.cli import cli
from fcsweep.io import failures
from fcsweep.io.failures import classify, remove_stale
from fcsweep.io.sweepdir import atomic_write


def _run(args, **env):
    r = CliRunner(env=env).invoke(cli, args)
    assert "Traceback" not in r.output, r.output
    assert r.exception is None or isinstance(r.exception, SystemExit), repr(r.exception)
    return r


def _lines(r, word):
    return [ln for ln in r.stderr.splitlines() if word in ln]


# ------------------------------------------------------------------ atomic_write itself

@pytest.mark.parametrize("exc", [KeyboardInterrupt, SystemExit, failures.Terminated, ValueError])
def test_every_error_inside_a_write_keeps_the_old_file_and_removes_the_temporary(tmp_path, exc):
    old = tmp_path / "a.h5"
    old.write_bytes(b"old")

    def writer(tmp):
        tmp.write_bytes(b"half")
        raise exc()

    with pytest.raises(exc):
        atomic_write(old, writer, fsync=True)
    assert old.read_bytes() == b"old" and os.listdir(tmp_path) == ["a.h5"]


def test_library_errors_without_errno_are_classified():
    h5 = OSError("Can't close file (file write failed: time = x, filename = 'f', errno = 28, "
                 "error message = 'No space left on device')")
    assert classify(h5, "f").errno == errno.ENOSPC
    assert classify(OSError(errno.EDQUOT, "quota"), "f").space
    assert classify(OSError(errno.EROFS, "ro"), "f").errno == errno.EROFS
    assert classify(ValueError("bad data"), "f") is None
    assert classify(KeyboardInterrupt(), "f") is None


def test_netcdf_error_is_no_space_only_when_the_disk_is_full(tmp_path, monkeypatch):
    """netCDF4 says "NetCDF: HDF error" for a full disk: the free space decides."""
    import shutil
    from collections import namedtuple

    usage = namedtuple("usage", "total used free")
    nc = RuntimeError("NetCDF: HDF error")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10, 10, 0))
    assert classify(nc, "x.nc", free_at=tmp_path / "t").errno == errno.ENOSPC
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10 << 30, 0, 10 << 30))
    assert classify(nc, "x.nc", free_at=tmp_path / "t") is None


def test_stale_temporaries_of_dead_writers_only(tmp_path):
    dead = tmp_path / ".analysis.h5.999999999.tmp"
    mine = tmp_path / f".analysis.h5.{os.getppid()}.tmp"  # a live process
    movie = tmp_path / ".movie.mp4.999999999.tmp.mp4"
    for p in (dead, mine, movie):
        p.write_bytes(b"x")
    assert sorted(remove_stale(tmp_path)) == sorted([dead, movie])
    assert mine.exists()


# ------------------------------------------------------------------ analyze / aggregate

def test_analyze_force_on_a_full_disk_keeps_every_analysis(sweep):
    cfg, out, before = sweep
    r = _run(["analyze", str(cfg), "--force"], FCSWEEP_TEST_WRITE_ERROR="analysis.h5:ENOSPC")
    assert r.exit_code == 2, r.output
    assert _lines(r, "could not be written") and _lines(r, "no space left on device; free space there")
    assert r.stdout.count("not written") == 4
    assert rs.results(out) == before and not rs.temporaries(out)
    assert not list(out.glob("runs/*/analysis_error.txt"))
    assert _run(["aggregate", str(cfg)]).exit_code == 0  # nothing lost: all 4 still analysed


def test_analyze_goes_on_after_one_unwritable_run_and_counts_it(sweep, monkeypatch):
    import fcsweep.results.analyze as pipeline

    cfg, out, before = sweep
    real = pipeline._write_h5
    first = sorted(out.glob("runs/*"))[0].name

    def write(tmp, traj, *a):
        if traj.params["run_id"] == first:
            raise OSError(errno.EDQUOT, "Disk quota exceeded")
        real(tmp, traj, *a)

    monkeypatch.setattr(pipeline, "_write_h5", write)
    r = _run(["analyze", str(cfg), "--force"])
    assert r.exit_code == 1, r.output
    assert _lines(r, "1 analysis file(s) could not be written (previous ones kept), 3 written")
    assert f"cannot write {out / 'runs' / first / 'analysis.h5'}: disk quota exceeded" in r.stdout
    assert rs.results(out)[f"runs/{first}/analysis.h5"] == before[f"runs/{first}/analysis.h5"]
    assert not rs.temporaries(out)


def test_aggregate_on_a_full_disk_keeps_the_dataset(sweep):
    cfg, out, before = sweep
    r = _run(["aggregate", str(cfg)], FCSWEEP_TEST_WRITE_ERROR="phase_diagram.nc:ENOSPC")
    assert r.exit_code == 2, r.output
    assert _lines(r, f"cannot write {out / 'phase_diagram.nc'}: no space left on device")
    assert rs.results(out) == before and not rs.temporaries(out)


@pytest.mark.parametrize("command", ["analyze", "aggregate"])
def test_read_only_sweep_is_refused_before_any_work(sweep, command):
    """Injected EROFS: root ignores permissions, so a chmod test could not fail under root
    (tests/test_results_kills.py has the chmod one, skipped under root)."""
    cfg, out, before = sweep
    r = _run([command, str(cfg), "--force"] if command == "analyze" else [command, str(cfg)],
             FCSWEEP_TEST_WRITE_ERROR="*:EROFS")
    assert r.exit_code == 2
    assert _lines(r, f"cannot write {out}: read-only file system; this command writes into the sweep directory")
    assert rs.results(out) == before and not rs.temporaries(out)


@pytest.mark.parametrize("exc,code", [(KeyboardInterrupt, 130), (failures.Terminated, 143)])
def test_signal_during_a_write_exits_128_plus_n_and_keeps_the_old_file(sweep, monkeypatch, exc, code):
    import fcsweep.results.analyze as pipeline

    cfg, out, before = sweep
    real = pipeline._write_h5

    def write(tmp, *a):
        real(tmp, *a)
        raise exc()

    monkeypatch.setattr(pipeline, "_write_h5", write)
    r = _run(["analyze", str(cfg), "--force"])
    assert r.exit_code == code and _lines(r, "every result written before is intact")
    assert rs.results(out) == before and not rs.temporaries(out)


def test_stale_temporary_of_a_killed_analysis_is_removed_and_said(sweep):
    cfg, out, before = sweep
    stale = sorted(out.glob("runs/*"))[1] / ".analysis.h5.999999999.tmp"
    stale.write_bytes(b"half an analysis")
    r = _run(["analyze", str(cfg)])
    assert r.exit_code == 0 and _lines(r, f"removed {stale}, left by a killed analysis")
    assert not rs.temporaries(out)


# ------------------------------------------------------------------ export / plot

def test_export_on_a_full_disk_says_so_and_leaves_the_old_export(sweep, tmp_path):
    cfg, out, _ = sweep
    pytest.importorskip("gsd")
    gsd = tmp_path / "x.gsd"
    gsd.write_bytes(b"previous export")
    r = _run(["export", "0", str(cfg), "--frames", "0:2", "--no-defects", "--out", str(gsd)],
             FCSWEEP_TEST_WRITE_ERROR="x.gsd:ENOSPC")
    assert r.exit_code == 2
    assert _lines(r, f"cannot write {gsd}: no space left on device; free space there or give --out")
    assert gsd.read_bytes() == b"previous export" and not rs.temporaries(tmp_path)


def test_plot_on_a_full_disk_says_so(sweep, tmp_path):
    cfg, out, _ = sweep
    figs = tmp_path / "figs"
    r = _run(["plot", str(cfg), "--outdir", str(figs)], FCSWEEP_TEST_WRITE_ERROR="*.png:ENOSPC")
    assert r.exit_code == 2 and _lines(r, "no space left on device; free space there or give --outdir")
    assert not rs.temporaries(tmp_path)


def test_signals_during_a_write_are_held_and_handled_after_it(tmp_path):
    """A SIGTERM inside a write lands after the rename (never between a library's lock
    acquire and release): raising handlers raise then, flag handlers get their flag."""
    import signal

    target = tmp_path / "a.nc"
    target.write_text("old")
    seen = []

    def writer(tmp):
        tmp.write_text("half")
        os.kill(os.getpid(), signal.SIGTERM)
        assert not seen  # still held
        tmp.write_text("complete")

    old = signal.signal(signal.SIGTERM, lambda s, f: seen.append(s))
    try:
        atomic_write(target, writer)
    finally:
        signal.signal(signal.SIGTERM, old)
    assert seen == [signal.SIGTERM] and target.read_text() == "complete"
    with failures.sigterm_raises(), pytest.raises(failures.Terminated):
        atomic_write(target, writer)
    assert target.read_text() == "complete" and os.listdir(tmp_path) == ["a.nc"]
