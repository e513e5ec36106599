"""Run many runs: serially, on a local process pool, or on a Dask distributed cluster.

Every executor calls :func:`fcsweep.sweep.runner.run_one` per run, so locking, resuming
and status files behave the same everywhere.  Workers of the process pool are started with
the ``spawn`` context (safe with numba and threads); there are at most as many as cores,
and each gets ``cores // processes`` numba threads, so processes x threads never exceeds
the cores (:func:`worker_layout`).  Dask runs use one numba thread each.
Dask workers must see the same file system path as the submitting process.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing as mp
import os
import signal
import threading
import time
from typing import Sequence

from fcsweep.config import RunSpec, SweepConfig, check_runnable
from fcsweep.io import schema
from fcsweep.io.locks import DEFAULT_STALE_AFTER
from fcsweep.io.status import read_status
from fcsweep.sweep.layout import worker_layout
from fcsweep.sweep.progress import Progress
from fcsweep.sweep.runner import RunOutcome, run_one

__all__ = ["run_sweep", "select_runs", "worker_layout", "EXECUTORS"]

EXECUTORS = ("serial", "process", "dask")
_POLL = 0.5
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
        specs = [s for s in specs if (read_status(cfg.run_dir(s.run_id)) or {}).get("status") == schema.FAILED]
    return specs


def _sigterm(signum, frame):
    raise SystemExit(128 + signum)


def _init_worker(threads: int) -> None:
    signal.signal(signal.SIGTERM, _sigterm)  # release the run lock on termination
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


def _task(cfg: SweepConfig, spec: RunSpec, force: bool, stale_after: float, skip_failed: bool) -> RunOutcome:
    """Picklable unit of work for pools and Dask."""
    if skip_failed:
        st = read_status(cfg.run_dir(spec.run_id)) or {}
        if st.get("status") == schema.FAILED:
            return RunOutcome(spec.index, spec.run_id, "failed",
                              f"failed earlier ({st.get('reason', '')}); use --retry-failed")
    return run_one(cfg, spec, force=force, stale_after=stale_after)


def _spec_task(spec: RunSpec, cfg: SweepConfig, force: bool, stale_after: float, skip_failed: bool) -> RunOutcome:
    """:func:`_task` with the run first, for ``Client.map``; one run per worker process
    at a time (start Dask workers with ``--nthreads 1`` and several ``--nworkers``)."""
    with _THREAD_RUN_LOCK:
        # one numba thread per run: a Dask worker process runs one run at a time and a
        # node runs one worker process per core
        _set_numba_threads(1)
        return _task(cfg, spec, force, stale_after, skip_failed)


def _describe(o: RunOutcome, spec: RunSpec) -> str:
    text = {
        "done": "computed",
        "skipped": "skipped (already done)",
        "locked": "skipped (held by another process)",
        "failed": "FAILED",
    }[o.outcome]
    extra = f": {o.message}" if o.message and o.outcome != "skipped" else ""
    wall = f" in {o.wall_seconds:.1f}s" if o.outcome == "done" else ""
    return f"run {o.index} {o.run_id} [{spec.label()}] {text}{wall}{extra}"


def run_sweep(
    cfg: SweepConfig,
    specs: Sequence[RunSpec],
    *,
    executor: str = "serial",
    workers: int = 1,
    scheduler: str | None = None,
    progress: Progress | None = None,
    force: bool = False,
    retry_failed: bool = False,
    stale_after: float = DEFAULT_STALE_AFTER,
) -> list[RunOutcome]:
    """Compute ``specs`` and return one :class:`RunOutcome` per run (same order).

    Parameters
    ----------
    executor : {"serial", "process", "dask"}
        ``serial`` runs in this process; ``process`` uses a spawn-context
        ``ProcessPoolExecutor`` with ``workers`` processes; ``dask`` submits to the
        distributed scheduler at ``scheduler`` (e.g. ``tcp://host:8786``).
    retry_failed : bool
        If False, runs whose status is ``failed`` are not recomputed (reported failed).
    """
    check_runnable(cfg)  # ConfigError before any run starts
    progress = progress or Progress(len(specs), enabled=False)
    skip_failed = not (retry_failed or force)
    if executor not in EXECUTORS:
        raise ValueError(f"executor {executor!r} is not one of {EXECUTORS}")
    if executor == "serial" or (executor == "process" and workers <= 1):
        out = []
        for spec in specs:
            if skip_failed and (read_status(cfg.run_dir(spec.run_id)) or {}).get("status") == schema.FAILED:
                o = _task(cfg, spec, force, stale_after, True)
            else:
                o = run_one(cfg, spec, force=force, stale_after=stale_after,
                            progress=lambda s, step, n: progress.update(s.run_id, s.label(), step, n))
            progress.run_finished(spec.run_id, _describe(o, spec), computed=o.wall_seconds > 0)
            out.append(o)
        return out
    if executor == "process":
        workers, threads = worker_layout(workers)
        ctx = mp.get_context("spawn")
        with cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker,
                                    initargs=(threads,)) as pool:
            futs = [pool.submit(_task, cfg, s, force, stale_after, skip_failed) for s in specs]
            try:
                return _collect(cfg, specs, futs, progress, workers,
                                done=lambda f: f.done(), result=lambda f: f.result())
            except BaseException:  # SIGTERM / Ctrl-C: stop workers so they release their locks
                for f in futs:
                    f.cancel()
                for proc in list(getattr(pool, "_processes", {}).values()):
                    proc.terminate()
                raise
    # dask
    if not scheduler:
        raise ValueError("--executor dask needs --scheduler ADDRESS (e.g. tcp://host:8786)")
    from distributed import Client

    with Client(scheduler, timeout="30s", set_as_default=False) as client:
        futs = client.map(
            _spec_task, specs, cfg=cfg, force=force, stale_after=stale_after, skip_failed=skip_failed,
            pure=False, key=[f"fcsweep-{s.run_id}-{time.time_ns()}" for s in specs],
        )
        try:
            n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        except Exception:  # noqa: BLE001
            n_workers = 1
        return _collect(cfg, specs, futs, progress, n_workers,
                        done=lambda f: f.done(), result=lambda f: f.result())


def _collect(cfg, specs, futs, progress: Progress, width: int, *, done, result) -> list[RunOutcome]:
    """Wait for futures, showing per-run progress read from status.json files."""
    outcomes: list[RunOutcome | None] = [None] * len(specs)
    pending = list(range(len(specs)))
    while pending:
        still = []
        for i in pending:
            if done(futs[i]):
                spec = specs[i]
                try:
                    o = result(futs[i])
                except Exception as exc:  # noqa: BLE001 - worker died (killed, OOM, ...)
                    o = RunOutcome(spec.index, spec.run_id, "failed", f"worker error: {type(exc).__name__}: {exc}")
                outcomes[i] = o
                progress.run_finished(spec.run_id, _describe(o, spec), computed=o.wall_seconds > 0)
            else:
                still.append(i)
        pending = still
        for i in pending[: 2 * width]:
            spec = specs[i]
            st = read_status(cfg.run_dir(spec.run_id)) or {}
            if st.get("status") == schema.RUNNING and st.get("run_id") == spec.run_id:
                progress.update(spec.run_id, spec.label(), int(st.get("steps_done", 0)), int(st.get("steps", 1)))
        if pending:
            time.sleep(_POLL)
    return outcomes  # type: ignore[return-value]
