"""The commands that set up and compute a sweep: ``validate``, ``schema``, ``bench``,
``simulate``, ``list-runs`` and ``compile``."""

from __future__ import annotations

import json
import shlex
import sys
from pathlib import Path

import click

from fcsweep.cli.common import (CONFIG_ARG, OUTPUT_OPT, check_space, config_arg, err_line, load, runs_or_exit,
                                say)
from fcsweep.config import builtin_demo_path


@click.command()
@click.argument("config", type=click.Path(dir_okay=False))
def validate(config):
    """Check a config file, its output directory and disk space; print the number of runs
    or every problem (their count, then one line each; exit 2)."""
    cfg = load(config, to_run=True)
    specs = cfg.runs()
    check_space(cfg, specs, f"invalid config: {config}: output: ")
    click.echo(f"{config}: OK, {len(specs)} runs "
               f"({' x '.join(f'{k}[{len(v)}]' for k, v in cfg.grid.items())} x {cfg.replicates} replicate(s)), "
               f"{cfg.run.steps} steps each, output {Path(cfg.output).resolve()}")


@click.command()
def schema():
    """Print the JSON Schema of sweep files (for editors' YAML completion: e.g. a first line
    `# yaml-language-server: $schema=fcsweep-schema.json`)."""
    from fcsweep.config import json_schema

    click.echo(json.dumps(json_schema(), indent=2))


@click.command()
@CONFIG_ARG
@click.option("--compare", "-c", multiple=True, type=click.Choice(["binary", "linear", "arc"]),
              help="Also time these quadratures at the same settings (repeatable).")
@click.option("--steps", type=click.IntRange(min=1), default=None,
              help="Timed steps per block at N = 1024 (scaled by 1024/N; median of 5 blocks) "
                   "[default: 1e5 cell-steps per block; other values are not cached].")
@click.option("--warm", type=click.IntRange(min=0), default=None,
              help="Steps of the probe start (a disordered start of the run's cells) before timing "
                   "[default: 4e5 cell-steps].")
@click.option("--threads", type=click.IntRange(min=1), default=1, show_default=True,
              help="numba threads per run while timing (1: CPU time; more: wall time on free cores).")
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True,
              help="Processes for the wall-time estimate (capped at the cores).")
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
def bench(config, compare, steps, warm, threads, workers, as_json):
    """Time the step on this machine for each cost setting of a sweep and estimate the
    sweep's CPU and wall time (without CONFIG: the built-in demo).  The timings replace
    this machine's cached ones, which `simulate --dry-run` and `status` use."""
    from fcsweep.sweep.bench import bench_report, bench_sweep, format_bench
    from fcsweep.sweep.warmup import compile_kernels

    cfg = load(config, to_run=True)
    log = None if as_json else say
    compile_kernels(log)
    rows = bench_sweep(cfg, steps=steps, warm=warm, quadratures=list(compare) or None, threads=threads, log=log)
    report = bench_report(cfg, rows, threads=threads, workers=workers)
    if as_json:
        click.echo(json.dumps(report, indent=1))
        return
    for line in format_bench(cfg, rows, report):
        click.echo(line)


@click.command()
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
@click.option("--dry-run", "-n", is_flag=True,
              help="Say which runs would start, resume or be skipped, with the estimated CPU and wall "
                   "time; write nothing.")
def simulate(config, output, workers, executor, scheduler, task_index, retry_failed, force,
             lock_timeout, log_every, quiet, dry_run):
    """Compute the runs of a sweep (skips done runs, resumes interrupted ones).

    Without CONFIG, runs the built-in demo sweep into ./fcsweep-demo.  The first use
    compiles the numba kernels (minutes; cached afterwards, see `fcsweep compile`).
    """
    from fcsweep.io.locks import DEFAULT_STALE_AFTER
    from fcsweep.sweep.executors import select_runs
    from fcsweep.sweep.options import SweepOptions, dask_missing
    from fcsweep.sweep.progress import Progress

    cfg = load(config, output, to_run=True)
    if executor == "auto":
        executor = "process" if workers > 1 else "serial"
    if executor == "dask" and not scheduler:
        click.echo("fcsweep: --executor dask needs --scheduler ADDRESS (e.g. tcp://host:8786)", err=True)
        sys.exit(2)
    if executor == "dask" and dask_missing():
        say(dask_missing())
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
    check_space(cfg, specs)
    src = config or f"built-in demo ({builtin_demo_path().name})"
    out_dir = Path(cfg.output).resolve()
    options = SweepOptions(executor=executor, workers=workers, scheduler=scheduler, force=force,
                           retry_failed=retry_failed, stale_after=lock_timeout or DEFAULT_STALE_AFTER)
    if dry_run:
        from fcsweep.sweep.plan import print_plan

        print_plan(cfg, specs, options, source=src, out_dir=out_dir,
                   processes=workers if executor == "process" else 1, advice_arg=config_arg(config, output),
                   echo=click.echo, log=say)
        return
    click.echo(f"fcsweep: {len(specs)} run(s) of {src} -> {out_dir} [{executor}"
               f"{', ' + str(workers) + ' workers' if executor == 'process' else ''}]", err=True)
    from fcsweep.sweep.launch import simulate_runs

    if executor != "dask" and _any_to_compute(cfg, specs, force):  # Dask workers compile on their hosts
        from fcsweep.sweep.warmup import compile_kernels

        compile_kernels(None if quiet else say)
    progress = Progress(len(specs), log_every=log_every, enabled=not quiet)
    again = " ".join(shlex.quote(a) for a in sys.argv[1:]) or "simulate"
    code = simulate_runs(cfg, specs, options, progress=progress, say=err_line, resume=f"fcsweep {again}",
                         advice_arg=config_arg(config, output))
    if code:
        sys.exit(code)


def _any_to_compute(cfg, specs, force: bool) -> bool:
    """Whether some selected run is not done yet (then the kernels are needed)."""
    from fcsweep.io import schema
    from fcsweep.io.sweepdir import run_state

    return bool(specs) and (force or any(run_state(cfg.run_dir(s.run_id)).state != schema.DONE for s in specs))


@click.command("list-runs")
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--count", is_flag=True, help="Print only the number of runs.")
@click.option("--json", "as_json", is_flag=True, help="All parameters of every run as JSON.")
def list_runs(config, output, count, as_json):
    """Index, id and parameters of every run (the index is what --task-index takes;
    points `fcsweep refine` added to the output directory, -o, included)."""
    cfg = load(config, output)
    specs = runs_or_exit(cfg)
    if count:
        click.echo(len(specs))
        return
    if as_json:
        click.echo(json.dumps([{"index": s.index, "run_id": s.run_id, "replicate": s.replicate,
                                "params": dict(s.params)} for s in specs], indent=1))
        return
    for s in specs:
        click.echo(f"{s.index:>5}  {s.run_id}  {s.label()}")


@click.command("compile")
def compile_cmd():
    """Compile the numba kernels now (once per fcsweep version; `simulate` does it
    otherwise on first use) and say where they are cached.  Shows a progress bar with an
    estimate on a terminal, one line per stage otherwise."""
    from fcsweep.sweep.warmup import cache_dir, compile_kernels, kernels_cached

    was = kernels_cached()
    seconds = compile_kernels(say)
    state = "already compiled; loaded" if was else "compiled"
    click.echo(f"kernels {state} in {seconds:.1f} s; cache {cache_dir()}")
