"""The ``fcsweep`` command group: its commands in :data:`COMMAND_ORDER` and the console
entry point :func:`main`."""

from __future__ import annotations

import click

from fcsweep.cli.common import say
from fcsweep.cli.measure import measure
from fcsweep.cli.results import aggregate, analyze, export, movie, plot, refine, status
from fcsweep.cli.run import bench, compile_cmd, list_runs, schema, simulate, validate

__all__ = ["cli", "main", "COMMAND_ORDER"]


#: Order of the commands in ``--help``: the order of the work, then the helpers.  Every
#: command is listed (tests/test_cli.py checks it).
COMMAND_ORDER = ("validate", "bench", "simulate", "status", "analyze", "aggregate", "plot", "refine", "movie",
                 "export", "measure", "list-runs", "schema", "compile")


class WorkflowGroup(click.Group):
    """A group that lists its commands in :data:`COMMAND_ORDER`, not alphabetically."""

    def list_commands(self, ctx):
        rank = {name: i for i, name in enumerate(COMMAND_ORDER)}
        return sorted(self.commands, key=lambda n: (rank.get(n, len(rank)), n))


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


for _command in (validate, bench, simulate, status, analyze, aggregate, plot, refine, movie, export, measure,
                 list_runs, schema, compile_cmd):
    cli.add_command(_command)


def main() -> None:
    """Console entry point ``fcsweep`` (:func:`fcsweep.io.failures.run_main`: SIGINT /
    SIGTERM before a command set its own handling exit 130 / 143 with one line)."""
    from fcsweep.io.failures import run_main

    run_main(cli, "fcsweep", say)
