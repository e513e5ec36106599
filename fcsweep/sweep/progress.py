"""Progress display: tqdm bars on an interactive terminal, plain log lines otherwise.

Plain lines (batch logs) carry the rate and an estimated time to completion: per run,
steps per second since the run was first seen here; for the sweep, the wall time per
computed run since the sweep started, and the time left for the remaining runs at that
pace (runs in parallel included, since it is measured on the wall clock).
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "format_duration"]


def format_duration(seconds: float) -> str:
    """``42 s``, ``12 min``, ``3.4 h`` (rounded for people, not for scripts)."""
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


class Progress:
    """Overall progress over runs plus per-run step progress.

    Parameters
    ----------
    total : int
        Number of runs this invocation handles.
    stream : file, optional
        Where to write (default ``sys.stderr``).
    interactive : bool, optional
        Force bars (True) or log lines (False); default: ``stream.isatty()``.
    log_every : float
        Seconds between plain log lines about running runs.
    """

    def __init__(self, total: int, stream: TextIO | None = None, interactive: bool | None = None,
                 log_every: float = 30.0, enabled: bool = True):
        self.stream = stream or sys.stderr
        self.enabled = enabled
        if interactive is None:
            interactive = bool(getattr(self.stream, "isatty", lambda: False)())
        self.interactive = interactive and enabled
        self.total = total
        self.log_every = log_every
        self.finished = 0
        self.computed = 0
        self._start = time.time()
        self._first_seen: dict[str, tuple[float, int]] = {}
        self._last_log: dict[str, float] = {}
        self._bars: dict[str, object] = {}
        self._overall = None
        if self.interactive:
            from tqdm.auto import tqdm

            self._tqdm = tqdm
            self._overall = tqdm(total=total, desc="runs", unit="run", file=self.stream, position=0)

    def log(self, msg: str) -> None:
        """A line that is always shown (above the bars when interactive)."""
        if not self.enabled:
            return
        if self.interactive:
            self._tqdm.write(msg, file=self.stream)
        else:
            print(msg, file=self.stream, flush=True)

    def update(self, key: str, label: str, step: int, steps: int) -> None:
        """Per-run progress (bar, or a log line at most every ``log_every`` seconds)."""
        if not self.enabled:
            return
        if self.interactive:
            bar = self._bars.get(key)
            if bar is None:
                used = {getattr(b, "pos", 0) for b in self._bars.values()}
                free = next(i for i in range(1, len(used) + 2) if i not in used and -i not in used)
                bar = self._tqdm(total=steps, desc=label[:40], unit="step", leave=False,
                                 file=self.stream, position=free)
                self._bars[key] = bar
            bar.n = step
            bar.refresh()
            return
        now = time.time()
        t0, s0 = self._first_seen.setdefault(key, (now, step))
        if now - self._last_log.get(key, 0.0) >= self.log_every:
            self._last_log[key] = now
            pct = 100.0 * step / max(steps, 1)
            rate = (step - s0) / (now - t0) if now > t0 and step > s0 else 0.0
            tail = f", {rate:.3g} steps/s, ETA {format_duration((steps - step) / rate)}" if rate > 0 else ""
            print(f"[{time.strftime('%H:%M:%S')}] run {key} {label}: step {step}/{steps} ({pct:.0f}%){tail}",
                  file=self.stream, flush=True)

    def run_finished(self, key: str, msg: str, *, computed: bool = True) -> None:
        """A run is over (done, skipped, locked or failed); ``computed`` is False for runs
        that took no time (skipped), which do not count towards the rate."""
        self.finished += 1
        self.computed += bool(computed)
        self._first_seen.pop(key, None)
        bar = self._bars.pop(key, None)
        if bar is not None:
            bar.close()
        if self._overall is not None:
            self._overall.update(1)
        self.log(f"[{self.finished}/{self.total}] {msg}{self._sweep_eta()}")

    def _sweep_eta(self) -> str:
        """``; 5.0 min per run, about 40 min left`` once a run has been computed here."""
        left = self.total - self.finished
        elapsed = time.time() - self._start
        if self.interactive or not self.computed or not left or elapsed <= 0:
            return ""
        per_run = elapsed / self.computed
        return f"; {format_duration(per_run)} per run, about {format_duration(left * per_run)} left"

    def close(self) -> None:
        for bar in self._bars.values():
            bar.close()
        if self._overall is not None:
            self._overall.close()
