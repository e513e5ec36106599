"""Before a sweep starts: can its output directory be created, and do its trajectories fit?"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path
from typing import Sequence

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.io import schema
from fcsweep.io.rundir import free_bytes
from fcsweep.io.sweepdir import run_state
from fcsweep.sweep.length import extension_of
from fcsweep.sweep.runner import SPACE_MARGIN, trajectory_bytes

__all__ = ["check_space", "check_output_dir"]


def check_output_dir(output) -> None:
    """Raise ``OSError`` unless ``output`` exists as a writable directory or can be created:
    its nearest existing ancestor is a directory in which a directory can be made (tried
    with a temporary directory, removed at once: permission bits do not stop root, and
    read-only mounts or /proc refuse only the real thing)."""
    p = Path(output).absolute()
    probe = p
    cannot = f"output directory {str(output)!r} cannot be created"
    try:
        while not probe.exists() and probe.parent != probe:
            probe = probe.parent
        if not probe.is_dir():
            raise OSError(errno.ENOTDIR, f"{cannot}: {probe} is not a directory")
        if not os.access(probe, os.W_OK | os.X_OK):
            raise OSError(errno.EACCES, f"{cannot} or written: no write permission in {probe}")
        os.rmdir(tempfile.mkdtemp(prefix=".fcsweep-probe-", dir=probe))
    except OSError as exc:
        if exc.filename is None and str(exc.strerror).startswith(cannot):
            raise
        raise OSError(exc.errno, f"{cannot} in {probe}: {exc.strerror or exc}") from None


def check_space(cfg: SweepConfig, specs: Sequence[RunSpec]) -> str | None:
    """Compare the trajectories still to be written with the free space of the output.

    Raises ``OSError(ENOSPC)`` if even the largest single run cannot fit (its trajectory,
    uncompressed, plus the copy made when it is repacked at the end); returns a warning if
    all of them together may not fit (compression usually saves 10-30 % on positions),
    else ``None``.  Also checks :func:`check_output_dir`.
    """
    check_output_dir(cfg.output)
    todo = [s for s in specs if _to_write(cfg, s)]
    if not todo:
        return None
    sizes = [trajectory_bytes(cfg, s) for s in todo]
    free = free_bytes(cfg.output)
    biggest = 2 * max(sizes) + SPACE_MARGIN  # the partial file and its repacked copy
    if biggest > free:
        raise OSError(errno.ENOSPC, f"not enough disk space in {cfg.output}: one run's trajectory needs up to "
                                    f"{_mib(biggest)} (uncompressed, while it is repacked), {_mib(free)} free; "
                                    f"store fewer frames (run.sample_every) or fields (output.fields)")
    total = sum(sizes) + SPACE_MARGIN
    if total > free:
        return (f"the {len(todo)} trajectories still to write need up to {_mib(total)} uncompressed and "
                f"{_mib(free)} are free in {cfg.output}; runs that do not fit will fail with "
                "'no space left on device' and resume once space is freed")
    return None


def _to_write(cfg: SweepConfig, spec: RunSpec) -> bool:
    """Whether the run will write a trajectory: not done, or done and to be extended (its
    trajectory is then rewritten in full)."""
    rs = run_state(cfg.run_dir(spec.run_id))
    return rs.state != schema.DONE or extension_of(cfg.run, rs.st) is not None


def _mib(n: int) -> str:
    return f"{n / 2**30:.1f} GiB" if n >= 2**30 else f"{n / 2**20:.1f} MiB"
