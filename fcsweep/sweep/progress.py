"""Progress display: tqdm bars on an interactive terminal, plain log lines otherwise."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


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
        if now - self._last_log.get(key, 0.0) >= self.log_every:
            self._last_log[key] = now
            pct = 100.0 * step / max(steps, 1)
            print(f"[{time.strftime('%H:%M:%S')}] run {key} {label}: step {step}/{steps} ({pct:.0f}%)",
                  file=self.stream, flush=True)

    def run_finished(self, key: str, msg: str) -> None:
        """A run is over (done, skipped, locked or failed)."""
        self.finished += 1
        bar = self._bars.pop(key, None)
        if bar is not None:
            bar.close()
        if self._overall is not None:
            self._overall.update(1)
        self.log(f"[{self.finished}/{self.total}] {msg}")

    def close(self) -> None:
        for bar in self._bars.values():
            bar.close()
        if self._overall is not None:
            self._overall.close()
