"""Command line, in the order of the work: ``fcsweep validate | bench | simulate | status |
analyze | aggregate | plot | movie | export | refine``, ``measure`` for segmented images of
real cells, and the helpers ``list-runs`` and ``compile``.

Every command takes an optional CONFIG (a sweep YAML file); without one it uses the
built-in demo sweep (``fcsweep/data/smoke.yaml``, identical to ``configs/smoke.yaml``),
which writes to ``./fcsweep-demo``.  Every command that reads or writes a sweep prints
the output directory it resolved.

Exit codes: 0 success; 1 some run failed or was left unfinished (the others completed),
or a results command (status, analyze, aggregate, plot, movie, export) found nothing to work on
in the output directory (nothing was written), or aggregate found finished runs without
a usable analysis, or a results file could not be written after others were; 2 invalid
config or usage, or not enough disk space, or a read-only sweep (nothing was written);
128 + signal number when stopped by a signal (SIGINT 130, SIGTERM 143, SIGUSR1 138) after
every running run wrote a checkpoint, or every earlier result of a results command was
left intact (:func:`fcsweep.io.failures.results_command`).
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
        if output:
            cfg = cfg.with_output(output)  # with that directory's refinement points
    except ConfigError as exc:
        click.echo(f"fcsweep: invalid config: {exc}", err=True)
        sys.exit(2)
    return cfg


#: Order of the commands in ``--help``: the order of the work, then the helpers.
COMMAND_ORDER = ("validate", "bench", "simulate", "status", "analyze", "aggregate", "plot", "refine", "movie",
                 "export", "measure", "list-runs", "compile")


class WorkflowGroup(click.Group):
    """A group that lists its commands in :data:`COMMAND_ORDER`, not alphabetically."""

    def list_commands(self, ctx):
        rank = {name: i for i, name in enumerate(COMMAND_ORDER)}
        return sorted(self.commands, key=lambda n: (rank.get(n, len(rank)), n))


def _rows(cfg, *, verify: bool = False):
    """:func:`fcsweep.sweep.status.collect_status` with the analysis settings that
    `fcsweep analyze` would use now, so that analyses made with others read ``stale``."""
    from fcsweep.results.analyze import config_settings, settings_with
    from fcsweep.sweep.status import collect_status

    settings = settings_with(config_settings(cfg), transient=cfg.run.transient)
    return collect_status(cfg, analysis_settings=settings, verify=verify)


def _say(msg: str) -> None:
    click.echo(f"fcsweep: {msg}", err=True)


def _err(line: str) -> None:
    """Echo a whole line (prefix included) to stderr: the ``say`` of the sweep functions."""
    click.echo(line, err=True)


def _announce(cfg: SweepConfig) -> Path:
    """Print and return the resolved output directory of ``cfg``."""
    out = Path(cfg.output).resolve()
    _say(f"output directory {out}")
    return out


def _nothing(msg: str) -> None:
    """A results command found nothing to work on: say so and exit 1 (nothing written)."""
    _say(msg)
    sys.exit(1)


def _config_arg(config: str | None, output: str | None) -> str:
    """How the user named the sweep, for advice lines (``configs/x.yaml -o out``)."""
    return " ".join(x for x in (config or "", f"-o {output}" if output else "") if x)


def _wrong_dir_hint(config, output) -> str:
    if config or output:
        return "is this the config (and -o) that wrote the sweep?"
    return "without CONFIG every command uses the built-in demo in ./fcsweep-demo; give your sweep's config"


def _check_space(cfg: SweepConfig, specs, what: str = "") -> None:
    """Exit 2 unless the output directory can be created and the largest trajectory still
    to write fits in its free space; warn if all of them together may not."""
    from fcsweep.sweep.launch import space_code

    code = space_code(cfg, specs, _err, what)
    if code:
        sys.exit(code)


@click.group(cls=WorkflowGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="fcsweep")
def cli() -> None:
    """Simulate and sweep the Fourier contour cell model of active deformable cells.

    \b
    A sweep, step by step (without CONFIG: the built-in demo, into ./fcsweep-demo):
      fcsweep validate CONFIG     check the config, count the runs
      fcsweep bench CONFIG        time the step here, estimate the sweep's cost
      fcsweep simulate CONFIG     compute the runs (--dry-run: what it would do)
      fcsweep status CONFIG       runs done / running / failed, analysed or not
      fcsweep analyze CONFIG      observables of every finished run
      fcsweep aggregate CONFIG    one phase_diagram.nc
      fcsweep plot CONFIG         figures; `fcsweep movie RUN CONFIG` for a movie

    \b
    Experiments: fcsweep measure IMAGES  the same observables from segmented images
    """


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
    out_dir = Path(cfg.output).resolve()
    stale_after = lock_timeout or DEFAULT_STALE_AFTER
    if dry_run:
        _dry_run(cfg, specs, src, out_dir, workers if executor == "process" else 1, force, retry_failed,
                 stale_after, _config_arg(config, output))
        return
    click.echo(f"fcsweep: {len(specs)} run(s) of {src} -> {out_dir} [{executor}"
               f"{', ' + str(workers) + ' workers' if executor == 'process' else ''}]", err=True)
    from fcsweep.sweep.launch import simulate_runs

    if executor != "dask" and _any_to_compute(cfg, specs, force):  # Dask workers compile on their hosts
        from fcsweep.sweep.warmup import compile_kernels

        compile_kernels(None if quiet else _say)
    progress = Progress(len(specs), log_every=log_every, enabled=not quiet)
    again = " ".join(shlex.quote(a) for a in sys.argv[1:]) or "simulate"
    code = simulate_runs(cfg, specs, progress=progress, say=_err, resume=f"fcsweep {again}",
                         advice_arg=_config_arg(config, output), executor=executor, workers=workers,
                         scheduler=scheduler, force=force, retry_failed=retry_failed, stale_after=stale_after)
    if code:
        sys.exit(code)


def _any_to_compute(cfg, specs, force: bool) -> bool:
    """Whether some selected run is not done yet (then the kernels are needed)."""
    from fcsweep.io.status import read_status

    return bool(specs) and (force or any((read_status(cfg.run_dir(s.run_id)) or {}).get("status") != "done"
                                         for s in specs))


def _dry_run(cfg, specs, src, out_dir, processes, force, retry_failed, stale_after, arg) -> None:
    """Print what `simulate` would do and what it would cost; write nothing."""
    from fcsweep.sweep.bench import STARTUP_CPU_S, cpu_share, estimate_costs, wall_time
    from fcsweep.sweep.plan import ACTIONS, plan_runs
    from fcsweep.sweep.progress import format_duration

    plans = plan_runs(cfg, specs, force=force, retry_failed=retry_failed, stale_after=stale_after)
    click.echo(f"dry run: {len(specs)} run(s) of {src} -> {out_dir} (nothing is written)")
    work = [p for p in plans if p.steps_left > 0]
    costs, source = estimate_costs(cfg, work, log=_say) if work else ([], "")
    cost = {p.spec.index: c for p, c in zip(work, costs)}
    click.echo(f"{'idx':>4}  {'run_id':12}  {'action':8}  {'from step':>9}  {'steps':>9}  {'est. wall':>9}  "
               "parameters")
    for p in plans:
        est = format_duration(cost[p.spec.index][1]) if p.spec.index in cost else ""
        click.echo(f"{p.spec.index:>4}  {p.spec.run_id:12}  {p.action:8}  {p.from_step:>9}  {p.steps_left:>9}  "
                   f"{est:>9}  {p.spec.label()}" + (f"  ({p.note})" if p.note else ""))
    n = {a: sum(p.action == a for p in plans) for a in ACTIONS}
    click.echo(", ".join(f"{n[a]} to {a}" if a in ("start", "resume", "extend", "skip") else f"{n[a]} {a}"
                         for a in ACTIONS if n[a] or a in ("start", "resume", "skip")))
    if work:
        cpu = STARTUP_CPU_S + sum(c for c, _ in costs)
        wall = STARTUP_CPU_S + wall_time([w for _, w in costs], processes)
        click.echo(f"estimated {format_duration(cpu)} of CPU and about {format_duration(wall)} of wall time on "
                   f"{processes} process(es) with a free core each, start-up included [{source}]")
        share = cpu_share()
        if share < 0.9:
            click.echo(f"note: other jobs share this machine now (this process gets {share:.0%} of a core): "
                       f"at this load the wall time would be about {format_duration(wall / share)}")
    for line in _plan_advice(n, arg):
        click.echo(line)


def _plan_advice(n: dict, arg: str) -> list[str]:
    cmd = f"fcsweep simulate {arg}".rstrip()
    out = []
    if n["blocked"]:
        out.append(f"{n['blocked']} run(s) hold results of other run settings: `{cmd} --force` recomputes them, "
                   "or give another output directory (-o)")
    if n["failed"]:
        out.append(f"{n['failed']} run(s) failed earlier and are not rerun: `{cmd} --retry-failed`")
    if n["locked"]:
        out.append(f"{n['locked']} run(s) are being computed by another process")
    return out


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option("--verify", is_flag=True,
              help="Read every checksum of finished trajectories; mark damaged ones corrupt (exit 1).")
def status(config, output, as_json, verify):
    """Table of runs: done / running / interrupted / failed / corrupt / pending, with
    progress, whether each is analysed (yes / stale / no), and what to do next."""
    from fcsweep.sweep.status import advice, format_status

    cfg = _load(config, output)
    out = Path(cfg.output).resolve() if as_json else _announce(cfg)  # --json: only JSON
    rows = _rows(cfg, verify=verify)
    started = any(r["state"] != "pending" or r["steps_done"] for r in rows)
    if as_json:
        click.echo(json.dumps(rows, indent=1))
    elif started:
        click.echo(f"sweep {out}")
        *table, summary = format_status(rows).splitlines()
        click.echo("\n".join(table))
        for line in advice(rows, _config_arg(config, output)):
            click.echo(f"next: {line}")
        click.echo(summary)  # the last line, as scripts expect
    if not started:
        _nothing(f"nothing simulated in {out}: all {len(rows)} runs are pending "
                 f"({_wrong_dir_hint(config, output)})")
    if verify and any(r["state"] == "corrupt" for r in rows):
        sys.exit(1)


@cli.command("list-runs")
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--count", is_flag=True, help="Print only the number of runs.")
@click.option("--json", "as_json", is_flag=True, help="All parameters of every run as JSON.")
def list_runs(config, output, count, as_json):
    """Index, id and parameters of every run (the index is what --task-index takes;
    points `fcsweep refine` added to the output directory, -o, included)."""
    cfg = _load(config, output)
    specs = _runs(cfg)
    if count:
        click.echo(len(specs))
        return
    if as_json:
        click.echo(json.dumps([{"index": s.index, "run_id": s.run_id, "replicate": s.replicate,
                                "params": dict(s.params)} for s in specs], indent=1))
        return
    for s in specs:
        click.echo(f"{s.index:>5}  {s.run_id}  {s.label()}")


@cli.command()
@CONFIG_ARG
@click.option("--compare", "-c", multiple=True, type=click.Choice(["binary", "linear", "arc"]),
              help="Also time these quadratures at the same settings (repeatable).")
@click.option("--steps", type=click.IntRange(min=1), default=None,
              help="Timed steps per block at N = 1024 (scaled by 1024/N; median of 5 blocks) "
                   "[default: 1e5 cell-steps per block; other values are not cached].")
@click.option("--warm", type=click.IntRange(min=0), default=None,
              help="Steps off the lattice before timing [default: 4e5 cell-steps].")
@click.option("--threads", type=click.IntRange(min=1), default=1, show_default=True,
              help="numba threads per run while timing (1: CPU time; more: wall time on free cores).")
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True,
              help="Processes for the wall-time estimate (capped at the cores).")
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
def bench(config, compare, steps, warm, threads, workers, as_json):
    """Time the step on this machine for each cost setting of a sweep and estimate the
    sweep's CPU and wall time (without CONFIG: the built-in demo).  The timings replace
    this machine's cached ones, which `simulate --dry-run` and `status` use."""
    from fcsweep.sweep.bench import bench_sweep, cpu_share, sweep_seconds, wall_time
    from fcsweep.sweep.layout import worker_layout
    from fcsweep.sweep.progress import format_duration
    from fcsweep.sweep.warmup import compile_kernels

    cfg = _load(config, to_run=True)
    log = None if as_json else _say
    compile_kernels(log)
    rows = bench_sweep(cfg, steps=steps, warm=warm, quadratures=list(compare) or None, threads=threads, log=log)
    per_run = sweep_seconds(cfg, [r for r in rows if r.own])  # its own rules, not the --compare ones
    cpu = sum(c for c, _ in per_run)
    processes, _ = worker_layout(workers)
    wall = wall_time([w for _, w in per_run], processes)
    share = cpu_share()
    cpu_min = sum(r.cpu_seconds_min for r in rows if r.own)  # run.until: every run settles at its first check
    if as_json:
        click.echo(json.dumps({"rows": [{**r.setting, "runs": r.runs, "cell_steps": r.cell_steps,
                                         "cell_steps_min": r.cell_steps_min, "cell_steps_per_s": r.rate,
                                         "cpu_seconds": r.cpu_seconds, "cpu_seconds_min": r.cpu_seconds_min,
                                         "spread": r.spread}
                                        for r in rows],
                               "sweep_cpu_seconds": cpu, "sweep_cpu_seconds_min": cpu_min, "processes": processes,
                               "sweep_wall_seconds": wall, "threads": threads, "cpu_share_now": share},
                              indent=1))
        return
    click.echo(f"{'N':>6} {'modes':>5} {'K':>4} {'quadrature':>10} {'integrator':>16} {'runs':>5} "
               f"{'cell-steps/s':>13} {'us/cell-step':>12} {'spread':>6} {'CPU time of these runs':>23}")
    for r in rows:
        st = r.setting
        click.echo(f"{st['N']:>6} {st['modes']:>5} {st['contour_points']:>4} {st['quadrature']:>10} "
                   f"{st['integrator']:>16} {r.runs:>5} {r.rate:>13.3e} {1e6 / r.rate:>12.3f} {r.spread:>6.0%} "
                   f"{format_duration(r.cpu_seconds):>23}")
    click.echo(f"sweep ({len(cfg.runs())} runs, {cfg.run.steps} steps each, its own quadratures): "
               f"{format_duration(cpu)} of CPU at {threads} thread(s) per run, writing included; "
               f"about {format_duration(wall)} wall on {processes} process(es)")
    if share < 0.9:
        click.echo(f"note: other jobs share this machine (this process gets {share:.0%} of a core now); the CPU "
                   f"times hold, the wall time assumes free cores (at this load: about "
                   f"{format_duration(wall / share)})")
    if cfg.run.until:
        from fcsweep.sweep.bench import first_stop

        click.echo(f"with run.until: between {format_duration(cpu_min)} (every run settled at its first check, "
                   f"{first_stop(cfg.run)} steps) and {format_duration(cpu)} of CPU (every run to the cap, "
                   f"{cfg.run.steps} steps), plus the checks")


@cli.command()
@click.argument("config", type=click.Path(dir_okay=False))
def validate(config):
    """Check a config file, its output directory and disk space; print the number of runs
    or every problem (their count, then one line each; exit 2)."""
    cfg = _load(config, to_run=True)
    specs = cfg.runs()
    _check_space(cfg, specs, f"invalid config: {config}: output: ")
    click.echo(f"{config}: OK, {len(specs)} runs "
               f"({' x '.join(f'{k}[{len(v)}]' for k, v in cfg.grid.items())} x {cfg.replicates} replicate(s)), "
               f"{cfg.run.steps} steps each, output {Path(cfg.output).resolve()}")


@cli.command()
def schema():
    """Print the JSON Schema of sweep files (for editors' YAML completion: e.g. a first line
    `# yaml-language-server: $schema=fcsweep-schema.json`)."""
    import json

    from fcsweep.config import json_schema

    click.echo(json.dumps(json_schema(), indent=2))


@cli.command("compile")
def compile_cmd():
    """Compile the numba kernels now (once per fcsweep version; `simulate` does it
    otherwise on first use) and say where they are cached."""
    from fcsweep.sweep.warmup import cache_dir, compile_kernels, kernels_cached

    was = kernels_cached()
    seconds = compile_kernels(_say)
    state = "already compiled; loaded" if was else "compiled"
    click.echo(f"kernels {state} in {seconds:.1f} s; cache {cache_dir()}")


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True)
@click.option("--force", is_flag=True, help="Recompute existing analysis files.")
def analyze(config, output, workers, force):
    """Analyse every finished run (writes analysis.h5 beside each trajectory)."""
    from fcsweep.results.analyze import UNWRITTEN, analyze_sweep
    from fcsweep.io.failures import probe_writable, results_command
    from fcsweep.sweep.status import summary_line

    cfg = _load(config, output)
    out = _announce(cfg)
    rows = _rows(cfg)
    if not any(r["state"] == "done" for r in rows):
        _nothing(f"nothing to analyse in {out}: no run is done ({summary_line(rows)}; "
                 f"{_wrong_dir_hint(config, output)})")
    old = [r for r in rows if r.get("outdated")]
    if old:
        _say(f"{len(old)} done run(s) were computed with other run settings than this config "
             f"({old[0]['outdated']}); they are analysed as they are")
    with results_command(_say):
        probe_writable(out)
        results = analyze_sweep(cfg, workers=workers, force=force, say=_say)
    n = {w: sum(st == w for _, st, _ in results) for w in ("done", "failed", UNWRITTEN)}
    for run_id, st, msg in results:
        click.echo(f"{run_id}  {st}  {msg}")
    if n[UNWRITTEN]:
        why = next(msg for _, st, msg in results if st == UNWRITTEN)
        _say(f"{n[UNWRITTEN]} analysis file(s) could not be written (previous ones kept), {n['done']} written, "
             f"{n['failed']} failed; first: {why}")
        sys.exit(1 if n["done"] else 2)
    if n["failed"]:
        sys.exit(1)


def _analysed(cfg) -> tuple[int, str]:
    """Number of done runs with an analysis.h5 (up to date or stale), and what to do
    when there is none: analyse the done runs, or simulate, or look elsewhere."""
    rows = _rows(cfg)
    n = sum(r["analysis"] in ("yes", "stale") for r in rows)
    done = sum(r["state"] == "done" for r in rows)
    if done:
        return n, f"{done} run(s) are done but not analysed: `fcsweep analyze` first"
    if any(r["state"] != "pending" for r in rows):
        return n, "no run is done yet (see `fcsweep status`)"
    return n, "nothing simulated here"


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
def aggregate(config, output):
    """Collect per-run analyses into <output>/phase_diagram.nc."""
    import xarray as xr

    from fcsweep.results.aggregate import aggregate_sweep, point_summaries, replicate_error_check, unanalysed_runs
    from fcsweep.io.failures import probe_writable, results_command, signals_held

    cfg = _load(config, output)
    out = _announce(cfg)
    n, why = _analysed(cfg)
    if not n:
        _nothing(f"nothing to aggregate in {out}: {why} ({_wrong_dir_hint(config, output)})")
    with results_command(_say):
        probe_writable(out)
        path = aggregate_sweep(cfg, say=_say)
    click.echo(str(path))
    with signals_held(), xr.open_dataset(path) as ds:  # xarray's file locks: no signal inside
        missing = unanalysed_runs(ds)
        check = replicate_error_check(ds)
        for line in point_summaries(ds):
            click.echo(line)
    for name, (chi2, points) in check.items():
        click.echo(f"replicate check: {name} chi2/dof median {chi2:.2f} over {points} point(s)"
                   + (" -- per-run errors look too small" if chi2 > 2 else ""))
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
@click.option("--measured", multiple=True, type=click.Path(),
              help="A measure.nc of `fcsweep measure` (or its directory) to draw beside the simulated points "
                   "on the <q> - rho_d plane (repeatable).")
def plot(config, output, run, frame, outdir, measured):
    """Figures of the sweep (phase diagram and companions) or a snapshot of one run."""
    _headless()
    from fcsweep.results.figures import NothingToPlot, plot_sweep
    from fcsweep.results.analyze import DATASET_FILE
    from fcsweep.io.failures import results_command

    missing = [m for m in measured if not (Path(m).is_file() or (Path(m) / "measure.nc").is_file())]
    if missing:
        _say(f"--measured {missing[0]}: no measure.nc there (run `fcsweep measure` first)")
        sys.exit(2)
    cfg = _load(config, output)
    out = _announce(cfg)
    if run is not None:
        _trajectory_or_exit(cfg, run, out, config, output)
    elif not (out / DATASET_FILE).exists():
        n, why = _analysed(cfg)
        if not n:
            _nothing(f"nothing to plot in {out}: no phase_diagram.nc, {why} ({_wrong_dir_hint(config, output)})")
    try:
        with results_command(_say, "--outdir"):
            paths = plot_sweep(cfg, run=run, frame=frame, outdir=Path(outdir) if outdir else None, measured=measured)
    except NothingToPlot as exc:
        _nothing(str(exc))
    for p in paths:
        click.echo(str(p))


def _headless() -> None:
    """Select matplotlib's Agg backend: the commands write figure files and show none, on
    machines without a display too (importing the figure module leaves the backend alone)."""
    import matplotlib

    matplotlib.use("Agg")


def _trajectory_or_exit(cfg, run, out, config, output) -> Path:
    """The finished trajectory of run ``run``; exit 2 for an unknown run, 1 if not done."""
    from fcsweep.results.locate import run_trajectory

    try:
        traj = run_trajectory(cfg, run)
    except ValueError as exc:
        _say(str(exc))
        sys.exit(2)
    if not traj.exists():
        _nothing(f"run {run} has no finished trajectory in {out} ({traj.parent.name}; "
                 f"{_wrong_dir_hint(config, output)})")
    return traj


@cli.command()
@click.argument("run")
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--fps", type=click.IntRange(min=1, max=120), default=10, show_default=True,
              help="Movie frames per second.")
@click.option("--every", type=click.IntRange(min=1), default=1, show_default=True,
              help="Use every k-th recorded frame.")
@click.option("--dpi", type=click.IntRange(min=50, max=600), default=120, show_default=True,
              help="Resolution of the rendered frames.")
@click.option("--out", "out_file", type=click.Path(dir_okay=False), default=None,
              help="Movie file [<run directory>/movie.mp4].")
def movie(run, config, output, fps, every, dpi, out_file):
    """MP4 movie of one run: contours coloured by q, defects marked, with a progress bar.

    RUN is a run id or index of the sweep CONFIG (default: the built-in demo), or the
    path of a trajectory.h5.  Needs the `movie` extra: pip install 'fcsweep[movie]'.
    """
    _headless()
    from fcsweep.results.figures import movie_run
    from fcsweep.io.failures import results_command

    if run.endswith(".h5") and Path(run).is_file():
        traj = Path(run)
    else:
        cfg = _load(config, output)
        out = _announce(cfg)
        traj = _trajectory_or_exit(cfg, run, out, config, output)
    try:
        with results_command(_say, "--out"):
            path = movie_run(traj, out_file, fps=fps, every=every, dpi=dpi)
    except ImportError as exc:
        _say(str(exc))
        sys.exit(2)
    click.echo(str(path))


@cli.command()
@click.argument("run")
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--format", "fmt", type=click.Choice(["gsd", "vtk"]), default="gsd", show_default=True,
              help="gsd: one file for OVITO / MDAnalysis / freud; vtk: .vtp series + .pvd for ParaView.")
@click.option("--frames", default="all", show_default=True,
              help="Frames to export: all, an index (-1 = last), a slice 0:100:10, or a comma list.")
@click.option("--out", "out_path", type=click.Path(), default=None,
              help="GSD file or VTK directory [./<run id>.gsd or ./<run id>_vtk].")
@click.option("--unwrapped", is_flag=True, help="Unwrapped centroids instead of wrapped ones with image counts.")
@click.option("--polygons", is_flag=True,
              help="GSD: each cell its own type with its contour as a Polygon shape (true shapes in OVITO).")
@click.option("--images", is_flag=True, help="VTK: also draw periodic copies of cells crossing the box edge.")
@click.option("--ascii", "as_ascii", is_flag=True, help="VTK: ascii instead of base64 binary data.")
@click.option("--no-defects", is_flag=True,
              help="Leave out defect / n_sides / cluster (skips a Voronoi tessellation per frame: faster for large N).")
def export(run, config, output, fmt, frames, out_path, unwrapped, polygons, images, as_ascii, no_defects):
    """Export one run for viewers: GSD (OVITO, MDAnalysis) or VTK (ParaView), with q,
    defect flag, defect cluster id and Fourier coefficients per cell, and a progress bar.

    RUN is a run id or index of the sweep CONFIG (default: the built-in demo), or the
    path of a trajectory.h5.  The run directory is only read.
    """
    from fcsweep.results.export import export_gsd, export_vtk
    from fcsweep.io.trajectory import TrajectoryError
    from fcsweep.io.failures import results_command

    if run.endswith(".h5") and Path(run).is_file():
        traj = Path(run)
    else:
        cfg = _load(config, output)
        out = _announce(cfg)
        traj = _trajectory_or_exit(cfg, run, out, config, output)
    run_id = traj.parent.name if traj.name == "trajectory.h5" else traj.stem
    try:
        with results_command(_say, "--out"):
            if fmt == "gsd":
                path = export_gsd(traj, out_path or f"{run_id}.gsd", frames=frames, unwrapped=unwrapped,
                                  polygons=polygons, defects=not no_defects)
            else:
                path = export_vtk(traj, out_path or f"{run_id}_vtk", frames=frames, unwrapped=unwrapped,
                                  images=images, binary=not as_ascii, defects=not no_defects)
    except (ImportError, ValueError) as exc:
        _say(str(exc))
        sys.exit(2)
    except TrajectoryError as exc:
        _nothing(str(exc))
    click.echo(str(path))


@cli.command()
@click.argument("images", nargs=-1, required=False, type=click.Path())
@click.option("--output", "-o", type=click.Path(file_okay=False), default="fcsweep-measure", show_default=True,
              help="Output directory (measure.nc).")
@click.option("--pixel-size", default=None, help="Pixel size X or X,Y in --length-unit [TIFF metadata, else 1].")
@click.option("--frame-interval", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Time between frames in --time-unit [TIFF metadata, else 1].")
@click.option("--times", default=None, help="Comma-separated time stamps of the frames (instead of --frame-interval).")
@click.option("--length-unit", default=None, help="CF/UDUNITS length unit, e.g. um [TIFF metadata, else 1].")
@click.option("--time-unit", default=None, help="CF/UDUNITS time unit, e.g. min [TIFF metadata, else 1].")
@click.option("--modes", type=click.IntRange(min=2, max=16), default=6, show_default=True,
              help="Highest Fourier mode M of the contour fit.")
@click.option("--percolation-threshold", type=click.FloatRange(0, 1), default=0.5, show_default=True,
              help="rho_d above which a frame is percolated.")
@click.option("--neighbours", type=click.Choice(["voronoi", "contact"]), default="voronoi", show_default=True,
              help="Defect graph: Voronoi of the centroids (the paper's rule) or touching masks.")
@click.option("--v0", type=click.FloatRange(min=0), default=None,
              help="Cell speed in --length-unit per --time-unit, if known (with --Dr: D_eff).")
@click.option("--Dr", "Dr", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Rotational diffusion in 1 / --time-unit, if known (active-Brownian fit of D_s).")
def measure(images, output, pixel_size, frame_interval, times, length_unit, time_unit, modes, percolation_threshold,
            neighbours, v0, Dr):
    """The simulations' observables of segmented cell images: q, Voronoi defects and their
    clusters, psi6; over a movie tracks, MSD, D_s, cages and the percolation and phase labels.

    IMAGES: integer label images (0 = background, 1..n = cells): a TIFF (2-D or T x Y x X),
    PNG files, Cellpose _seg.npy files, or directories of them (frames sorted by name).
    Without IMAGES: a built-in example, 12 frames of 64 simulated cells (lengths in R0).
    Pixel size, frame interval and units come from the options or from OME / ImageJ
    metadata; where both exist they must agree.  Writes OUTPUT/measure.nc
    (docs/measure.md).  TIFF needs the `measure` extra:
    pip install 'fcsweep[measure]'.
    """
    from fcsweep.io.failures import results_command
    from fcsweep.measure.command import measure_to_dir
    from fcsweep.measure.readers import MeasureInputError

    if not images:
        _say("no IMAGES: measuring the built-in example (64 simulated cells, eta = 0.01, v0 = 0.06, "
             "10 px per R0; lengths in R0)")
    try:
        with results_command(_say, "--output"):
            path = measure_to_dir(images, output, pixel_size=pixel_size, frame_interval=frame_interval,
                                  length_unit=length_unit, time_unit=time_unit, times=times, modes=modes,
                                  percolation_threshold=percolation_threshold, v0=v0, Dr=Dr,
                                  neighbours=neighbours)
    except (ImportError, MeasureInputError) as exc:
        _say(str(exc))
        sys.exit(2)
    click.echo(str(path))


@cli.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--rounds", "-r", type=click.IntRange(min=1), default=1, show_default=True,
              help="Refinement rounds (each adds points, then simulates, analyses and aggregates).")
@click.option("--max-points", "-p", type=click.IntRange(min=1), default=None,
              help="Most grid points added per round (highest priority first) [no limit].")
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True,
              help="Runs computed (and analysed) at once on this machine.")
@click.option("--add-only", is_flag=True,
              help="Only analyse, aggregate and add one round of points; compute nothing (job arrays).")
@click.option("--quiet", "-q", is_flag=True, help="No progress output.")
def refine(config, output, rounds, max_points, workers, add_only, quiet):
    """Add grid points where labels change, then simulate, analyse and aggregate them.

    Completes the sweep first (simulate, analyze, aggregate: done runs are reused); then,
    each round, adds the midpoint of every pair of neighbours along a swept axis whose
    phase or percolation labels differ or are undetermined (geometric midpoints on
    log ranges), records the points in <output>/refinement.json and computes them.
    With --add-only, one round of points is added from the runs done so far and their
    run indices printed, for a job array to compute.
    """
    cfg = _load(config, output, to_run=True)
    from fcsweep.results.aggregate import aggregate_sweep
    from fcsweep.analysis.phase import PERCOLATION_FLAGS, PHASE_FLAGS
    from fcsweep.results.analyze import analyze_sweep
    from fcsweep.sweep.refine_loop import refine_loop

    def analyse(c: SweepConfig) -> Path:
        analyze_sweep(c, workers=workers)
        return aggregate_sweep(c)

    code = refine_loop(cfg, analyse=analyse, flag_names={"phase": PHASE_FLAGS, "percolated": PERCOLATION_FLAGS},
                       say=_err, echo=click.echo, rounds=rounds, max_points=max_points, workers=workers,
                       add_only=add_only, quiet=quiet, config=config)
    if code:
        sys.exit(code)


def _or_exit(call):
    """``call()``, or exit 2 with the message when the refinement file does not fit the config."""
    try:
        return call()
    except ConfigError as exc:
        click.echo(f"fcsweep: invalid config: {exc}", err=True)
        sys.exit(2)


def _runs(cfg: SweepConfig) -> list:
    """The runs of a sweep, refined points included (exit 2 if the refinement file does not fit)."""
    return _or_exit(cfg.runs)


def main() -> None:
    """Console entry point ``fcsweep`` (:func:`fcsweep.io.failures.run_main`: SIGINT /
    SIGTERM before a command set its own handling exit 130 / 143 with one line)."""
    from fcsweep.io.failures import run_main

    run_main(cli, "fcsweep", _say)


if __name__ == "__main__":  # pragma: no cover
    main()
