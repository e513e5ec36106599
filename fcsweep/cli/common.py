"""What the commands share: the CONFIG argument and ``--output`` option, loading a config
(exit 2 on any problem), the lines on stderr, the exits of a results command that found
nothing to work on, and the run table every results command reads."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from fcsweep.config import ConfigError, SweepConfig, builtin_demo_path, check_runnable, load_config

CONFIG_ARG = click.argument("config", required=False, type=click.Path(dir_okay=False))
OUTPUT_OPT = click.option(
    "--output", "-o", type=click.Path(file_okay=False), default=None,
    help="Override the config's output directory.",
)


def load(config: str | None, output: str | None = None, *, to_run: bool = False) -> SweepConfig:
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


def status_rows(cfg, *, verify: bool = False):
    """:func:`fcsweep.sweep.status.collect_status` with the analysis settings that
    `fcsweep analyze` would use now, so that analyses made with others read ``stale``."""
    from fcsweep.results.analyze import config_settings, settings_with
    from fcsweep.sweep.status import collect_status

    settings = settings_with(config_settings(cfg), transient=cfg.run.transient)
    return collect_status(cfg, analysis_settings=settings, verify=verify)


def say(msg: str) -> None:
    """Echo ``fcsweep: <msg>`` to stderr."""
    click.echo(f"fcsweep: {msg}", err=True)


def err_line(line: str) -> None:
    """Echo a whole line (prefix included) to stderr: the ``say`` of the sweep functions."""
    click.echo(line, err=True)


def announce(cfg: SweepConfig) -> Path:
    """Print and return the resolved output directory of ``cfg``."""
    out = Path(cfg.output).resolve()
    say(f"output directory {out}")
    return out


def nothing(msg: str) -> None:
    """A results command found nothing to work on: say so and exit 1 (nothing written)."""
    say(msg)
    sys.exit(1)


def config_arg(config: str | None, output: str | None) -> str:
    """How the user named the sweep, for advice lines (``configs/x.yaml -o out``)."""
    return " ".join(x for x in (config or "", f"-o {output}" if output else "") if x)


def wrong_dir_hint(config, output) -> str:
    """What to check when a results command finds nothing: the config and -o, or that
    without CONFIG the built-in demo's directory was read."""
    if config or output:
        return "is this the config (and -o) that wrote the sweep?"
    return "without CONFIG every command uses the built-in demo in ./fcsweep-demo; give your sweep's config"


def check_space(cfg: SweepConfig, specs, what: str = "") -> None:
    """Exit 2 unless the output directory can be created and the largest trajectory still
    to write fits in its free space; warn if all of them together may not."""
    from fcsweep.sweep.launch import space_code

    code = space_code(cfg, specs, err_line, what)
    if code:
        sys.exit(code)


def analysed(cfg) -> tuple[int, str]:
    """Number of done runs with an analysis.h5 (up to date or stale), and what to do
    when there is none: analyse the done runs, or simulate, or look elsewhere."""
    rows = status_rows(cfg)
    n = sum(r["analysis"] in ("yes", "stale") for r in rows)
    done = sum(r["state"] == "done" for r in rows)
    if done:
        return n, f"{done} run(s) are done but not analysed: `fcsweep analyze` first"
    if any(r["state"] != "pending" for r in rows):
        return n, "no run is done yet (see `fcsweep status`)"
    return n, "nothing simulated here"


def headless() -> None:
    """Select matplotlib's Agg backend: the commands write figure files and show none, on
    machines without a display too (importing the figure module leaves the backend alone)."""
    import matplotlib

    matplotlib.use("Agg")


def trajectory_or_exit(cfg, run, out, config, output) -> Path:
    """The finished trajectory of run ``run``; exit 2 for an unknown run, 1 if not done."""
    from fcsweep.results.locate import run_trajectory

    try:
        traj = run_trajectory(cfg, run)
    except ValueError as exc:
        say(str(exc))
        sys.exit(2)
    if not traj.exists():
        nothing(f"run {run} has no finished trajectory in {out} ({traj.parent.name}; "
                f"{wrong_dir_hint(config, output)})")
    return traj


def run_argument(run, config, output) -> Path:
    """The trajectory a RUN argument names: the path of a ``trajectory.h5`` as given, else a
    run id or index of the sweep ``config`` (:func:`trajectory_or_exit`)."""
    if run.endswith(".h5") and Path(run).is_file():
        return Path(run)
    cfg = load(config, output)
    out = announce(cfg)
    return trajectory_or_exit(cfg, run, out, config, output)


def or_exit(call):
    """``call()``, or exit 2 with the message when the refinement file does not fit the config."""
    try:
        return call()
    except ConfigError as exc:
        click.echo(f"fcsweep: invalid config: {exc}", err=True)
        sys.exit(2)


def runs_or_exit(cfg: SweepConfig) -> list:
    """The runs of a sweep, refined points included (exit 2 if the refinement file does not fit)."""
    return or_exit(cfg.runs)
