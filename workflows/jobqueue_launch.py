#!/usr/bin/env python
"""Run a sweep on a PBS / SLURM / LSF / SGE cluster through dask-jobqueue.

The launcher (run it on a login node, e.g. inside ``tmux``) starts a Dask scheduler,
submits ``--jobs`` batch jobs that each start one Dask worker, and hands the sweep's runs
to them (``fcsweep simulate --executor dask`` does the same against a scheduler you
started yourself).  Workers need the same Python environment and the sweep's output
directory on a shared file system.  Interrupting the launcher loses nothing: run it again
and finished runs are skipped, interrupted ones resume from their checkpoints.

Install: ``pip install "fcsweep[cluster]"`` (adds dask-jobqueue).  (The file is not called
``dask_jobqueue.py``: run as a script, that name would shadow the package itself.)

``--interface ib0`` (or ``eth1``...) picks the network interface the scheduler and the
workers listen on, for clusters whose compute nodes reach the login node only over a
fast internal network.

Examples
--------
::

    python workflows/jobqueue_launch.py configs/phase.yaml --system slurm --jobs 8 \\
        --queue normal --walltime 24:00:00 --memory 4GB --account myproj
    python workflows/jobqueue_launch.py configs/phase.yaml --system pbs --dry-run   # print the job script
    python workflows/jobqueue_launch.py configs/smoke.yaml --local --jobs 2        # no batch system

Exit codes as ``fcsweep simulate``: 0 ok, 1 some run failed, 2 bad config or arguments.
"""

from __future__ import annotations

import argparse
import sys

SYSTEMS = {"slurm": "SLURMCluster", "pbs": "PBSCluster", "lsf": "LSFCluster", "sge": "SGECluster"}


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("config", help="sweep YAML file")
    p.add_argument("--system", choices=sorted(SYSTEMS), default="slurm", help="batch system [slurm]")
    p.add_argument("--jobs", type=int, default=4, help="batch jobs (= Dask workers) to start [4]")
    p.add_argument("--cores", type=int, default=1, help="cores per job; one run per core [1]")
    p.add_argument("--memory", default="2GB", help="memory per job [2GB]")
    p.add_argument("--walltime", default="24:00:00", help="wall time per job [24:00:00]")
    p.add_argument("--queue", default=None, help="queue / partition")
    p.add_argument("--account", default=None, help="account / project to charge")
    p.add_argument("--job-extra", action="append", default=[], help="extra scheduler directive (repeatable)")
    p.add_argument("--interface", default=None,
                   help="network interface of scheduler and workers, e.g. ib0 (default: the hostname's)")
    p.add_argument("--dry-run", action="store_true", help="print the batch job script and exit")
    p.add_argument("--local", action="store_true", help="use a LocalCluster instead of a batch system")
    p.add_argument("--retry-failed", action="store_true", help="run only failed runs")
    return p.parse_args(argv)


def make_cluster(args: argparse.Namespace):
    """A dask-jobqueue cluster (or a loopback LocalCluster with ``--local``)."""
    if args.local:
        from distributed import LocalCluster

        # like a batch job: one single-threaded worker process per core
        return LocalCluster(n_workers=args.jobs * args.cores, threads_per_worker=1, processes=True,
                            host="127.0.0.1", dashboard_address=None)
    try:
        import dask_jobqueue
    except ImportError:
        sys.exit("dask-jobqueue is not installed: pip install 'fcsweep[cluster]' (or use --local)")
    cls = getattr(dask_jobqueue, SYSTEMS[args.system])
    kwargs = dict(
        cores=args.cores,
        processes=args.cores,  # one single-threaded worker process per core
        memory=args.memory,
        walltime=args.walltime,
        queue=args.queue,
        account=args.account,
        job_extra_directives=list(args.job_extra),
        job_script_prologue=["export NUMBA_NUM_THREADS=1 OMP_NUM_THREADS=1"],
        job_name="fcsweep",
        interface=args.interface,
    )
    if args.system == "lsf":
        kwargs.pop("account")
        kwargs["project"] = args.account
    return cls(**{k: v for k, v in kwargs.items() if v is not None})


def main(argv=None) -> int:
    args = parse_args(argv)
    from fcsweep.config import ConfigError, load_config

    try:
        cfg = load_config(args.config)
    except ConfigError as exc:
        print(f"invalid config: {exc}", file=sys.stderr)
        return 2
    from fcsweep.sweep import interrupt

    cluster = make_cluster(args)
    previous = interrupt.install()  # SIGTERM/Ctrl-C: every running run checkpoints first
    try:
        if args.dry_run:
            local = f"LocalCluster {cluster.scheduler_address}"
            print(cluster.job_script() if hasattr(cluster, "job_script") else local)
            return 0
        if not args.local:
            cluster.scale(jobs=args.jobs)
        from fcsweep.sweep.executors import run_sweep, select_runs
        from fcsweep.sweep.options import SweepOptions
        from fcsweep.sweep.progress import Progress

        specs = select_runs(cfg, retry_failed=args.retry_failed)
        print(f"{len(specs)} run(s) -> {cfg.output} via {cluster.scheduler_address}", file=sys.stderr)
        progress = Progress(len(specs), log_every=300)
        try:
            options = SweepOptions(executor="dask", scheduler=cluster.scheduler_address,
                                   retry_failed=args.retry_failed)
            outcomes = run_sweep(cfg, specs, options, progress=progress)
        finally:
            progress.close()
    finally:
        interrupt.restore(previous)
        cluster.close()
    from fcsweep.sweep.executors import unfinished

    failed = [o for o in outcomes if o.outcome == "failed"]
    lost = unfinished(cfg, outcomes)
    print(f"{sum(o.outcome == 'done' for o in outcomes)} computed, {len(failed)} failed", file=sys.stderr)
    for o in failed + lost:
        print(f"  {o.outcome if o in failed else 'unfinished'}: run {o.index} {o.run_id}: {o.message}",
              file=sys.stderr)
    sig = interrupt.requested()
    if sig is not None:
        print(f"stopped by {interrupt.reason()}; run the same command again to resume", file=sys.stderr)
        return interrupt.exit_code(sig)
    return 1 if failed or lost else 0


if __name__ == "__main__":
    sys.exit(main())
