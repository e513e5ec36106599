"""Command line: ``fcsweep simulate | status | list-runs | validate | bench | analyze | aggregate | plot``.

Every command takes an optional CONFIG (a sweep YAML file); without one it uses the
built-in demo sweep (``fcsweep/data/smoke.yaml``, identical to ``configs/smoke.yaml``),
which writes to ``./fcsweep-demo``.

Exit codes: 0 success; 1 some run failed or was left unfinished (the others completed);
2 invalid config or usage, or not enough disk space (nothing was written); 128 + signal
number when stopped by a signal (SIGINT 130, SIGTERM 143, SIGUSR1 138) after every
running run wrote a checkpoint.
"""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import click

from fcsweep.config import ConfigError, SweepConfig, builtin_demo_path, check_runnable, load_config

CONFIG_ARG = click.argument("config", required=False, type=click.Path(dir_okay=False))
OUTPUT_OPT = click.option(
    "--output", "-o", type=click.Path(file_okay=False), default=None,
    help="Override the config's output directory.",
)


def _load(config: str | None, output: str | None = None, *, to_run: bool = False) -> SweepConfig:
    """The sweep config (exit 2 on any problem); ``to_run`` adds the checks that concern
    integrating it (:func:`fcsweep.config.check_runnable`), not reading its results."""
    path = Path(config) if config else builtin_demo_path()
    try:
        cfg = load_config(path)
        if to_run:
            check_runnable(cfg)
    except ConfigError as exc:
        click.echo(f"fcsweep: invalid config: {exc}", err=True)
        sys.exit(2)
    if output:
        cfg = cfg.with_output(output)
    return cfg


def _check_space(cfg: SweepConfig, specs, what: str = "") -> None:
    """Exit 2 unless the output directory can be created and the largest trajectory still
    to write fits in its free space; warn if all of them together may not."""
    from fcsweep.sweep.space import check_space

    try:
        note = check_space(cfg, specs)
    except OSError as exc:
        click.echo(f"fcsweep: {what}{exc.strerror or exc}", err=True)
        sys.exit(2)
    if note:
        click.echo(f"fcsweep: warning: {note}", err=True)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="fcsweep")
def cli() -> None:
    """Simulate and sweep the Fourier contour cell model of active deformable cells."""


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True,
              help="Runs computed at once on this machine (process pool).")
@click.option("--executor", type=click.Choice(["auto", "serial", "process", "dask"]), default="auto",
              show_default=True, help="auto: serial for 1 worker, process pool otherwise.")
@click.option("--scheduler", default=None, help="Dask scheduler address for --executor dask, e.g. tcp://host:8786.")
@click.option("--task-index", type=click.IntRange(min=0), default=None,
              help="Run only run number I (job arrays; see `fcsweep list-runs`).")
@click.option("--retry-failed", is_flag=True, help="Run only the runs whose status is failed.")
@click.option("--force", is_flag=True, help="Recompute runs even if done (ignores checkpoints).")
@click.option("--lock-timeout", type=click.FloatRange(min=1), default=None,
              help="Seconds without heartbeat after which a run lock is stale on any host [60].")
@click.option("--log-every", type=click.FloatRange(min=0), default=30.0, show_default=True,
              help="Seconds between progress lines when stderr is not a terminal.")
@click.option("--quiet", "-q", is_flag=True, help="No progress output; only the summary.")
def simulate(config, output, workers, executor, scheduler, task_index, retry_failed, force,
             lock_timeout, log_every, quiet):
    """Compute the runs of a sweep (skips done runs, resumes interrupted ones).

    Without CONFIG, runs the built-in demo sweep into ./fcsweep-demo.
    """
    from fcsweep.io.locks import DEFAULT_STALE_AFTER
    from fcsweep.sweep.executors import run_sweep, select_runs
    from fcsweep.sweep.progress import Progress

    cfg = _load(config, output, to_run=True)
    if executor == "auto":
        executor = "process" if workers > 1 else "serial"
    if executor == "dask" and not scheduler:
        click.echo("fcsweep: --executor dask needs --scheduler ADDRESS (e.g. tcp://host:8786)", err=True)
        sys.exit(2)
    try:
        specs = select_runs(cfg, task_index=task_index, retry_failed=retry_failed)
    except IndexError as exc:
        click.echo(f"fcsweep: {exc}", err=True)
        sys.exit(2)
    if executor == "process":
        from fcsweep.sweep.layout import worker_layout

        processes, _ = worker_layout(workers)
        if processes < workers:
            click.echo(f"fcsweep: --workers {workers} is more than the {processes} core(s) available; "
                       f"using {processes}", err=True)
            workers = processes
    _check_space(cfg, specs)
    src = config or f"built-in demo ({builtin_demo_path().name})"
    click.echo(f"fcsweep: {len(specs)} run(s) of {src} -> {cfg.output} [{executor}"
               f"{', ' + str(workers) + ' workers' if executor == 'process' else ''}]", err=True)
    from fcsweep.sweep import interrupt
    from fcsweep.sweep.executors import unfinished

    progress = Progress(len(specs), log_every=log_every, enabled=not quiet)
    previous = interrupt.install()
    try:
        outcomes = run_sweep(cfg, specs, executor=executor, workers=workers, scheduler=scheduler,
                             progress=progress, force=force, retry_failed=retry_failed,
                             stale_after=lock_timeout or DEFAULT_STALE_AFTER)
    except (OSError, TimeoutError) as exc:
        if executor != "dask":
            raise
        click.echo(f"fcsweep: cannot reach the Dask scheduler at {scheduler}: {exc}", err=True)
        sys.exit(2)
    finally:
        progress.close()
        interrupt.restore(previous)
    counts = {k: sum(o.outcome == k for o in outcomes) for k in ("done", "skipped", "locked", "failed",
                                                                   "interrupted")}
    click.echo(
        f"fcsweep: {counts['done']} computed, {counts['skipped']} already done, "
        f"{counts['locked']} held by other processes, {counts['failed']} failed"
        + (f", {counts['interrupted']} interrupted" if counts["interrupted"] else ""), err=True)
    for o in outcomes:
        if o.outcome == "failed":
            click.echo(f"  failed: run {o.index} {o.run_id}: {o.message}", err=True)
    sig = interrupt.requested()
    if sig is not None:
        stopped = [o for o in outcomes if o.outcome == "interrupted" and o.message != "not started"]
        again = " ".join(shlex.quote(a) for a in sys.argv[1:]) or "simulate"
        click.echo(f"fcsweep: stopped by {interrupt.reason()} ({len(stopped)} run(s) checkpointed); "
                   f"resume with: fcsweep {again}", err=True)
        sys.exit(interrupt.exit_code(sig))
    lost = unfinished(cfg, outcomes, lock_timeout or DEFAULT_STALE_AFTER)
    for o in lost:
        click.echo(f"  unfinished: run {o.index} {o.run_id}: its lock holder stopped without finishing "
                   f"({o.message}); the next launch computes it", err=True)
    if counts["failed"]:
        click.echo("fcsweep: some runs failed; fix the cause and rerun (I/O failures resume by themselves, "
                   "others need --retry-failed)", err=True)
    if counts["failed"] or lost:
        sys.exit(1)


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option("--verify", is_flag=True,
              help="Read every checksum of finished trajectories; mark damaged ones corrupt (exit 1).")
def status(config, output, as_json, verify):
    """Table of runs: done / running / interrupted / failed / corrupt / pending, with progress."""
    from fcsweep.sweep.status import collect_status, format_status

    cfg = _load(config, output)
    rows = collect_status(cfg, verify=verify)
    if as_json:
        click.echo(json.dumps(rows, indent=1))
    else:
        click.echo(f"sweep {cfg.output}")
        click.echo(format_status(rows))
    if verify and any(r["state"] == "corrupt" for r in rows):
        sys.exit(1)


@cli.command("list-runs")
@CONFIG_ARG
@click.option("--count", is_flag=True, help="Print only the number of runs.")
@click.option("--json", "as_json", is_flag=True, help="All parameters of every run as JSON.")
def list_runs(config, count, as_json):
    """Index, id and parameters of every run (the index is what --task-index takes)."""
    cfg = _load(config)
    specs = cfg.runs()
    if count:
        click.echo(len(specs))
        return
    if as_json:
        click.echo(json.dumps([{"index": s.index, "run_id": s.run_id, "replicate": s.replicate,
                                "params": dict(s.params)} for s in specs], indent=1))
        return
    for s in specs:
        click.echo(f"{s.index:>5}  {s.run_id}  {s.label()}")


def _duration(seconds: float) -> str:
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


@cli.command()
@CONFIG_ARG
@click.option("--compare", "-c", multiple=True, type=click.Choice(["binary", "linear", "arc"]),
              help="Also time these quadratures at the same settings (repeatable).")
@click.option("--steps", type=click.IntRange(min=1), default=200, show_default=True,
              help="Timed steps per block at N = 1024 (scaled by 1024/N; best of 3 blocks).")
@click.option("--warm", type=click.IntRange(min=0), default=2000, show_default=True,
              help="Steps off the lattice before timing.")
@click.option("--threads", type=click.IntRange(min=1), default=1, show_default=True,
              help="numba threads per run while timing.")
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True,
              help="Processes for the wall-time estimate (capped at the cores).")
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
def bench(config, compare, steps, warm, threads, workers, as_json):
    """Time the step on this machine for each cost setting of a sweep and estimate the
    sweep's CPU and wall time (without CONFIG: the built-in demo)."""
    from fcsweep.sweep.bench import bench_sweep
    from fcsweep.sweep.layout import worker_layout

    cfg = _load(config, to_run=True)
    log = None if as_json else (lambda msg: click.echo(f"fcsweep: {msg}", err=True))
    rows = bench_sweep(cfg, steps=steps, warm=warm, quadratures=list(compare) or None, threads=threads, log=log)
    own = [r for r in rows if r.own]  # the sweep's time: its own rules, not the --compare ones
    cpu = sum(r.cpu_seconds for r in own)
    processes, _ = worker_layout(workers)
    wall = max(cpu / processes, max(r.cpu_seconds / r.runs for r in own))  # no run is split
    if as_json:
        click.echo(json.dumps({"rows": [{**r.setting, "runs": r.runs, "cell_steps": r.cell_steps,
                                         "cell_steps_per_s": r.rate, "cpu_seconds": r.cpu_seconds} for r in rows],
                               "sweep_cpu_seconds": cpu, "processes": processes,
                               "sweep_wall_seconds": wall, "threads": threads}, indent=1))
        return
    click.echo(f"{'N':>6} {'modes':>5} {'K':>4} {'quadrature':>10} {'runs':>5} {'cell-steps/s':>13} "
               f"{'us/cell-step':>12} {'CPU time of these runs':>23}")
    for r in rows:
        st = r.setting
        click.echo(f"{st['N']:>6} {st['modes']:>5} {st['contour_points']:>4} {st['quadrature']:>10} {r.runs:>5} "
                   f"{r.rate:>13.3e} {1e6 / r.rate:>12.3f} {_duration(r.cpu_seconds):>23}")
    click.echo(f"sweep ({len(cfg.runs())} runs, {cfg.run.steps} steps each, its own quadratures): "
               f"{_duration(cpu)} of CPU at {threads} thread(s) per run; about {_duration(wall)} "
               f"wall on {processes} process(es)")


@cli.command()
@click.argument("config", type=click.Path(dir_okay=False))
def validate(config):
    """Check a config file, its output directory and disk space; print the number of runs
    or the first problem (one line, exit 2)."""
    cfg = _load(config, to_run=True)
    specs = cfg.runs()
    _check_space(cfg, specs, f"invalid config: {config}: output: ")
    click.echo(f"{config}: OK, {len(specs)} runs "
               f"({' x '.join(f'{k}[{len(v)}]' for k, v in cfg.grid.items())} x {cfg.replicates} replicate(s)), "
               f"{cfg.run.steps} steps each, output {cfg.output}")


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True)
@click.option("--force", is_flag=True, help="Recompute existing analysis files.")
def analyze(config, output, workers, force):
    """Analyse every finished run (writes analysis.h5 beside each trajectory)."""
    from fcsweep.analysis.pipeline import analyze_sweep

    cfg = _load(config, output)
    results = analyze_sweep(cfg, workers=workers, force=force)
    failed = 0
    for run_id, st, msg in results:
        click.echo(f"{run_id}  {st}  {msg}")
        failed += st == "failed"
    if failed:
        sys.exit(1)


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
def aggregate(config, output):
    """Collect per-run analyses into <output>/phase_diagram.nc."""
    import xarray as xr

    from fcsweep.analysis.aggregate import aggregate_sweep, unanalysed_runs

    cfg = _load(config, output)
    path = aggregate_sweep(cfg)
    click.echo(str(path))
    with xr.open_dataset(path) as ds:
        missing = unanalysed_runs(ds)
    if missing:
        click.echo(f"{len(missing)} finished run(s) have no usable analysis (NaN in the dataset): "
                   + ", ".join(f"{r} ({w})" for r, w in missing) + "; see `fcsweep analyze`", err=True)
        sys.exit(1)


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--run", "run", default=None, help="Plot one run (id or index) instead of the sweep.")
@click.option("--frame", type=int, default=-1, show_default=True, help="Frame for snapshot plots.")
@click.option("--outdir", type=click.Path(file_okay=False), default=None, help="Where figures go.")
def plot(config, output, run, frame, outdir):
    """Figures of the sweep (phase diagram) or of one run."""
    from fcsweep.analysis.figures import plot_sweep

    cfg = _load(config, output)
    for p in plot_sweep(cfg, run=run, frame=frame, outdir=Path(outdir) if outdir else None):
        click.echo(str(p))


def main() -> None:
    """Console entry point ``fcsweep``."""
    cli(prog_name="fcsweep")


if __name__ == "__main__":  # pragma: no cover
    main()
