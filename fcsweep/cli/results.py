"""The commands that read a sweep's results: ``status``, ``analyze``, ``aggregate``,
``plot``, ``movie``, ``export``, and ``refine`` (which adds points and computes them)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from fcsweep.cli.common import (CONFIG_ARG, OUTPUT_OPT, analysed, announce, config_arg, err_line, headless, load,
                                nothing, run_argument, say, status_rows, trajectory_or_exit, wrong_dir_hint)
from fcsweep.config import SweepConfig


@click.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--json", "as_json", is_flag=True, help="Machine-readable output.")
@click.option("--verify", is_flag=True,
              help="Read every checksum of finished trajectories; mark damaged ones corrupt (exit 1).")
def status(config, output, as_json, verify):
    """Table of runs: done / running / interrupted / failed / corrupt / pending, with
    progress, whether each is analysed (yes / stale / no), and what to do next."""
    from fcsweep.sweep.status import advice, format_status

    cfg = load(config, output)
    out = Path(cfg.output).resolve() if as_json else announce(cfg)  # --json: only JSON
    rows = status_rows(cfg, verify=verify)
    started = any(r["state"] != "pending" or r["steps_done"] for r in rows)
    if as_json:
        click.echo(json.dumps(rows, indent=1))
    elif started:
        click.echo(f"sweep {out}")
        *table, summary = format_status(rows).splitlines()
        click.echo("\n".join(table))
        for line in advice(rows, config_arg(config, output)):
            click.echo(f"next: {line}")
        click.echo(summary)  # the last line, as scripts expect
    if not started:
        nothing(f"nothing simulated in {out}: all {len(rows)} runs are pending "
                f"({wrong_dir_hint(config, output)})")
    if verify and any(r["state"] == "corrupt" for r in rows):
        sys.exit(1)


@click.command()
@CONFIG_ARG
@OUTPUT_OPT
@click.option("--workers", "-j", type=click.IntRange(min=1), default=1, show_default=True)
@click.option("--force", is_flag=True, help="Recompute existing analysis files.")
def analyze(config, output, workers, force):
    """Analyse every finished run (writes analysis.h5 beside each trajectory)."""
    from fcsweep.results.analyze import UNWRITTEN, analyze_sweep
    from fcsweep.io.failures import probe_writable, results_command
    from fcsweep.sweep.status import summary_line

    cfg = load(config, output)
    out = announce(cfg)
    rows = status_rows(cfg)
    if not any(r["state"] == "done" for r in rows):
        nothing(f"nothing to analyse in {out}: no run is done ({summary_line(rows)}; "
                f"{wrong_dir_hint(config, output)})")
    old = [r for r in rows if r.get("outdated")]
    if old:
        say(f"{len(old)} done run(s) were computed with other run settings than this config "
            f"({old[0]['outdated']}); they are analysed as they are")
    with results_command(say):
        probe_writable(out)
        results = analyze_sweep(cfg, workers=workers, force=force, say=say)
    n = {w: sum(st == w for _, st, _ in results) for w in ("done", "failed", UNWRITTEN)}
    for run_id, st, msg in results:
        click.echo(f"{run_id}  {st}  {msg}")
    if n[UNWRITTEN]:
        why = next(msg for _, st, msg in results if st == UNWRITTEN)
        say(f"{n[UNWRITTEN]} analysis file(s) could not be written (previous ones kept), {n['done']} written, "
            f"{n['failed']} failed; first: {why}")
        sys.exit(1 if n["done"] else 2)
    if n["failed"]:
        sys.exit(1)


@click.command()
@CONFIG_ARG
@OUTPUT_OPT
def aggregate(config, output):
    """Collect per-run analyses into <output>/phase_diagram.nc."""
    import xarray as xr

    from fcsweep.results.aggregate import aggregate_sweep, point_summaries, replicate_error_check, unanalysed_runs
    from fcsweep.io.failures import probe_writable, results_command, signals_held

    cfg = load(config, output)
    out = announce(cfg)
    n, why = analysed(cfg)
    if not n:
        nothing(f"nothing to aggregate in {out}: {why} ({wrong_dir_hint(config, output)})")
    with results_command(say):
        probe_writable(out)
        path = aggregate_sweep(cfg, say=say)
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


@click.command()
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
    headless()
    from fcsweep.results.figures import NothingToPlot, plot_sweep
    from fcsweep.results.analyze import DATASET_FILE
    from fcsweep.io.failures import results_command

    missing = [m for m in measured if not (Path(m).is_file() or (Path(m) / "measure.nc").is_file())]
    if missing:
        say(f"--measured {missing[0]}: no measure.nc there (run `fcsweep measure` first)")
        sys.exit(2)
    cfg = load(config, output)
    out = announce(cfg)
    if run is not None:
        trajectory_or_exit(cfg, run, out, config, output)
    elif not (out / DATASET_FILE).exists():
        n, why = analysed(cfg)
        if not n:
            nothing(f"nothing to plot in {out}: no phase_diagram.nc, {why} ({wrong_dir_hint(config, output)})")
    try:
        with results_command(say, "--outdir"):
            paths = plot_sweep(cfg, run=run, frame=frame, outdir=Path(outdir) if outdir else None, measured=measured)
    except NothingToPlot as exc:
        nothing(str(exc))
    for p in paths:
        click.echo(str(p))


@click.command()
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
    """MP4 movie of one run: contours coloured by q, defects marked, with a progress bar
    (on a terminal; a line per quarter of the frames otherwise).

    RUN is a run id or index of the sweep CONFIG (default: the built-in demo), or the
    path of a trajectory.h5.  Needs the `movie` extra: pip install 'fcsweep[movie]'.
    """
    headless()
    from fcsweep.results.figures import movie_run
    from fcsweep.io.failures import results_command

    traj = run_argument(run, config, output)
    try:
        with results_command(say, "--out"):
            path = movie_run(traj, out_file, fps=fps, every=every, dpi=dpi,
                             progress=True if sys.stderr.isatty() else say)
    except ImportError as exc:
        say(str(exc))
        sys.exit(2)
    click.echo(str(path))


@click.command()
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

    traj = run_argument(run, config, output)
    run_id = traj.parent.name if traj.name == "trajectory.h5" else traj.stem
    try:
        with results_command(say, "--out"):
            if fmt == "gsd":
                path = export_gsd(traj, out_path or f"{run_id}.gsd", frames=frames, unwrapped=unwrapped,
                                  polygons=polygons, defects=not no_defects)
            else:
                path = export_vtk(traj, out_path or f"{run_id}_vtk", frames=frames, unwrapped=unwrapped,
                                  images=images, binary=not as_ascii, defects=not no_defects)
    except (ImportError, ValueError) as exc:
        say(str(exc))
        sys.exit(2)
    except TrajectoryError as exc:
        nothing(str(exc))
    click.echo(str(path))


@click.command()
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
    cfg = load(config, output, to_run=True)
    from fcsweep.results.aggregate import aggregate_sweep
    from fcsweep.analysis.phase import PERCOLATION_FLAGS, PHASE_FLAGS
    from fcsweep.results.analyze import analyze_sweep
    from fcsweep.sweep.options import SweepOptions
    from fcsweep.sweep.refine_loop import refine_loop

    def analyse(c: SweepConfig) -> Path:
        analyze_sweep(c, workers=workers)
        return aggregate_sweep(c)

    code = refine_loop(cfg, analyse=analyse, flag_names={"phase": PHASE_FLAGS, "percolated": PERCOLATION_FLAGS},
                       say=err_line, echo=click.echo,
                       options=SweepOptions(executor="process" if workers > 1 else "serial", workers=workers),
                       rounds=rounds, max_points=max_points, add_only=add_only, quiet=quiet, config=config)
    if code:
        sys.exit(code)
