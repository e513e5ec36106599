"""Run many runs: serially, on a local process pool, or on a Dask distributed cluster.

Every executor calls :func:`fcsweep.sweep.runner.run_one` per run, so locking, resuming
and status files behave the same everywhere.  Workers of the process pool are started with
the ``spawn`` context (safe with numba and threads); there are at most as many as cores,
and each gets ``cores // processes`` numba threads, so processes x threads never exceeds
the cores (:func:`worker_layout`).  Dask runs use one numba thread each.
Dask workers must see the same file system path as the submitting process.

Stopping (SIGTERM, SIGINT, SIGUSR1 -- :mod:`fcsweep.sweep.interrupt`): no new run is
started; every running run writes a checkpoint at its current step and is reported
``interrupted``.  Pool workers get the signal forwarded (and install the same flag
handler); Dask runs poll a distributed ``Event`` set by the submitting process.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import os
import threading
import time
from typing import Sequence

from fcsweep.config import RunSpec, SweepConfig, check_runnable
from fcsweep.io import schema
from fcsweep.io.locks import DEFAULT_STALE_AFTER
from fcsweep.io.machine import worker_layout
from fcsweep.io.rundir import RunDirectory
from fcsweep.io.sweepdir import run_state
from fcsweep.sweep import interrupt
from fcsweep.sweep.options import EXECUTORS, SweepOptions
from fcsweep.sweep.progress import Progress
from fcsweep.sweep.runner import RunOutcome, run_one

__all__ = ["run_sweep", "select_runs", "worker_layout", "unfinished", "EXECUTORS", "SweepOptions"]

_POLL = 0.5
#: Seconds that running runs get to checkpoint after a stop request before pool workers
#: are terminated (they then resume from their previous checkpoint).
STOP_GRACE = 120.0
#: Seconds between two looks of a Dask run at the stop event.
_DASK_STOP_POLL = 2.0
#: One run at a time per process for Dask worker threads: numba's parallel kernels may not
#: be launched from several threads at once with every threading layer (workqueue).
_THREAD_RUN_LOCK = threading.Lock()


def select_runs(cfg: SweepConfig, *, task_index: int | None = None, retry_failed: bool = False) -> list[RunSpec]:
    """Runs an invocation handles: all, one (``task_index``), or only failed ones."""
    specs = cfg.runs()
    if task_index is not None:
        if not 0 <= task_index < len(specs):
            raise IndexError(f"--task-index {task_index} is out of range; this sweep has runs 0..{len(specs) - 1}")
        specs = [specs[task_index]]
    if retry_failed:
        specs = [s for s in specs if run_state(cfg.run_dir(s.run_id)).state == schema.FAILED]
    return specs


def _init_worker(threads: int) -> None:
    interrupt.install()  # SIGTERM/SIGINT: checkpoint the current run, start no other
    os.environ["NUMBA_NUM_THREADS"] = str(threads)
    _set_numba_threads(threads)
    from fcsweep.sweep.warmup import compile_kernels

    compile_kernels()  # load the cached kernels now, not inside the first run's wall time


def _set_numba_threads(threads: int) -> None:
    """numba threads for runs started from the calling thread (numba's setting is per
    thread), at most what numba was started with."""
    try:
        import numba

        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    except Exception:  # noqa: BLE001 - numba missing or threads already fixed
        pass


def _task(cfg: SweepConfig, spec: RunSpec, options: SweepOptions, stop=None, progress=None) -> RunOutcome:
    """Picklable unit of work for pools and Dask.  With ``options.skip_failed``, a run that
    failed for a reason a relaunch does not fix (not an I/O error) is reported, not rerun."""
    return run_one(cfg, spec, force=options.force, stale_after=options.stale_after, stop=stop, progress=progress,
                   retry_failed=not options.skip_failed)


class _DaskStop:
    """Stop flag of a Dask run: the distributed ``Event`` the submitter sets, polled at
    most every few seconds."""

    def __init__(self, name: str):
        self.name, self.last, self.value = name, 0.0, None

    def __call__(self) -> str | None:
        now = time.monotonic()
        if self.value is None and now - self.last >= _DASK_STOP_POLL:
            self.last = now
            try:
                from distributed import Event

                if Event(self.name).is_set():
                    self.value = "stop requested by the submitting process"
            except Exception:  # noqa: BLE001 - scheduler unreachable: keep computing
                pass
        return self.value


def _spec_task(spec: RunSpec, cfg: SweepConfig, options: SweepOptions, stop_event: str | None = None) -> RunOutcome:
    """:func:`_task` with the run first, for ``Client.map``; one run per worker process
    at a time (start Dask workers with ``--nthreads 1`` and several ``--nworkers``)."""
    stop = _DaskStop(stop_event) if stop_event else None
    with _THREAD_RUN_LOCK:
        # one numba thread per run: a Dask worker process runs one run at a time and a
        # node runs one worker process per core
        _set_numba_threads(1)
        return _task(cfg, spec, options, stop=stop)


def _describe(o: RunOutcome, spec: RunSpec) -> str:
    text = {
        "done": "computed",
        "skipped": "skipped (already done)",
        "locked": "skipped (held by another process)",
        "interrupted": "interrupted",
        "failed": "FAILED",
    }[o.outcome]
    extra = f": {o.message}" if o.message and o.outcome != "skipped" else ""
    wall = f" in {o.wall_seconds:.1f}s" if o.outcome == "done" else ""
    return f"run {o.index} {o.run_id} [{spec.label()}] {text}{wall}{extra}"


def run_sweep(
    cfg: SweepConfig,
    specs: Sequence[RunSpec],
    options: SweepOptions | None = None,
    *,
    progress: Progress | None = None,
) -> list[RunOutcome]:
    """Compute ``specs`` and return one :class:`RunOutcome` per run (same order).

    Parameters
    ----------
    cfg : SweepConfig
    specs : sequence of RunSpec
    options : SweepOptions
        Executor, workers, scheduler, force, retry_failed, stale_after
        (:class:`fcsweep.sweep.options.SweepOptions`; default ``SweepOptions()``: serial,
        failed runs reported, not rerun).
    progress : Progress, optional
    """
    check_runnable(cfg)  # ConfigError before any run starts
    progress = progress or Progress(len(specs), enabled=False)
    options = options or SweepOptions()
    executor, workers = options.executor, options.workers
    if executor == "serial" or (executor == "process" and workers <= 1):
        out = []
        for spec in specs:
            o = _task(cfg, spec, options,
                      progress=lambda s, step, n: progress.update(s.run_id, s.label(), step, n))
            if not (o.outcome == "interrupted" and o.message == "not started"):
                progress.run_finished(spec.run_id, _describe(o, spec), computed=o.wall_seconds > 0)
            out.append(o)
        return out
    if executor == "process":
        workers, threads = worker_layout(workers)
        ctx = mp.get_context("spawn")
        with cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                                    initargs=(threads,)) as pool:
            futs = [pool.submit(_task, cfg, s, options) for s in specs]

            def on_stop(signum: int) -> None:
                for f in futs:
                    f.cancel()  # not yet handed to a worker
                for proc in list(getattr(pool, "_processes", {}).values()):
                    try:
                        os.kill(proc.pid, signum)  # the worker checkpoints its run, starts no other
                    except OSError:
                        pass

            def give_up() -> None:
                for proc in list(getattr(pool, "_processes", {}).values()):
                    proc.terminate()

            try:
                return _collect(cfg, specs, futs, progress, workers, done=lambda f: f.done(),
                                result=lambda f: f.result(), on_stop=on_stop, give_up=give_up)
            except BaseException:
                give_up()
                raise
    # dask
    if not options.scheduler:
        raise ValueError("--executor dask needs --scheduler ADDRESS (e.g. tcp://host:8786)")
    from distributed import Client, Event

    with Client(options.scheduler, timeout="30s", set_as_default=False) as client:
        event_name = f"fcsweep-stop-{os.getpid()}-{time.time_ns()}"
        futs = client.map(
            _spec_task, specs, cfg=cfg, options=options,
            stop_event=event_name, pure=False, key=[f"fcsweep-{s.run_id}-{time.time_ns()}" for s in specs],
        )
        try:
            n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        except Exception:  # noqa: BLE001
            n_workers = 1

        def on_stop(signum: int) -> None:
            Event(event_name, client=client).set()  # running runs checkpoint, queued ones return at once

        return _collect(cfg, specs, futs, progress, n_workers, done=lambda f: f.done(),
                        result=lambda f: f.result(), on_stop=on_stop, give_up=lambda: client.cancel(futs))


def unfinished(cfg: SweepConfig, outcomes: Sequence[RunOutcome],
               stale_after: float = DEFAULT_STALE_AFTER) -> list[RunOutcome]:
    """Runs skipped as held by another process whose holder is gone: not done and not held
    by a lock with a live heartbeat (e.g. a worker killed on another host).  A sweep that
    ends with such runs is not complete; the next launch (after the lock goes stale, at
    most ``stale_after`` seconds) computes them."""
    out = []
    for o in outcomes:
        if o.outcome != "locked":
            continue
        rd = RunDirectory(cfg.run_dir(o.run_id), o.run_id, o.index)
        if rd.state(stale_after) != schema.DONE and rd.live_lock(stale_after) is None:
            out.append(o)
    return out


def _collect(cfg, specs, futs, progress: Progress, width: int, *, done, result, on_stop=None,
             give_up=None) -> list[RunOutcome]:
    """Wait for futures, showing per-run progress read from status.json files.  On a stop
    request, ``on_stop(signum)`` is called once; after :data:`STOP_GRACE` seconds,
    ``give_up()``, and unfinished futures are reported interrupted."""
    outcomes: list[RunOutcome | None] = [None] * len(specs)
    pending = list(range(len(specs)))
    stopped_at = None
    while pending:
        sig = interrupt.requested()
        if sig is not None and stopped_at is None:
            stopped_at = time.monotonic()
            if on_stop is not None:
                on_stop(sig)
        if stopped_at is not None and time.monotonic() - stopped_at > STOP_GRACE:
            if give_up is not None:
                give_up()
            for i in pending:
                outcomes[i] = RunOutcome(specs[i].index, specs[i].run_id, "interrupted",
                                         f"no checkpoint within {STOP_GRACE:.0f} s; resumes from the previous one")
            break
        still = []
        for i in pending:
            if done(futs[i]):
                spec = specs[i]
                try:
                    o = result(futs[i])
                except cf.CancelledError:
                    o = RunOutcome(spec.index, spec.run_id, "interrupted", "not started")
                except Exception as exc:  # noqa: BLE001 - worker died (killed, OOM, ...)
                    if stopped_at is not None:
                        o = RunOutcome(spec.index, spec.run_id, "interrupted", f"worker stopped: {exc}")
                    else:
                        o = RunOutcome(spec.index, spec.run_id, "failed",
                                       f"worker error: {type(exc).__name__}: {exc}")
                outcomes[i] = o
                if not (o.outcome == "interrupted" and o.message == "not started"):
                    progress.run_finished(spec.run_id, _describe(o, spec), computed=o.wall_seconds > 0)
            else:
                still.append(i)
        pending = still
        for i in pending[: 2 * width]:
            spec = specs[i]
            rs = run_state(cfg.run_dir(spec.run_id))
            st = rs.st
            if rs.state == schema.RUNNING and st.get("run_id") == spec.run_id:
                progress.update(spec.run_id, spec.label(), int(st.get("steps_done", 0)), int(st.get("steps", 1)))
        if pending:
            time.sleep(_POLL)
    return outcomes  # type: ignore[return-value]
