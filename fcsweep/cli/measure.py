"""``fcsweep measure``: the simulations' observables of segmented images of real cells."""

from __future__ import annotations

import sys

import click

from fcsweep.cli.common import say
from fcsweep.model.settings import PERCOLATION_THRESHOLD


@click.command()
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
@click.option("--percolation-threshold", type=click.FloatRange(0, 1), default=PERCOLATION_THRESHOLD, show_default=True,
              help="rho_d above which a frame is percolated.")
@click.option("--neighbours", type=click.Choice(["voronoi", "contact"]), default="voronoi", show_default=True,
              help="Defect graph: Voronoi of the centroids (the paper's rule) or touching masks.")
@click.option("--v0", type=click.FloatRange(min=0), default=None,
              help="Cell speed in --length-unit per --time-unit, if known (with --Dr: D_eff).")
@click.option("--Dr", "Dr", type=click.FloatRange(min=0, min_open=True), default=None,
              help="Rotational diffusion in 1 / --time-unit, if known (active-Brownian fit of D_s).")
@click.option("--label-binary", is_flag=True,
              help="Label a binary (0/1 or 0/255) mask by its connected components instead of refusing it "
                   "(touching cells then merge: a segmentation's labels are better).")
def measure(images, output, pixel_size, frame_interval, times, length_unit, time_unit, modes, percolation_threshold,
            neighbours, v0, Dr, label_binary):
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
        say("no IMAGES: measuring the built-in example (64 simulated cells, eta = 0.01, v0 = 0.06, "
            "10 px per R0; lengths in R0)")
    try:
        with results_command(say, "--output"):
            path = measure_to_dir(images, output, pixel_size=pixel_size, frame_interval=frame_interval,
                                  length_unit=length_unit, time_unit=time_unit, times=times, modes=modes,
                                  percolation_threshold=percolation_threshold, v0=v0, Dr=Dr,
                                  neighbours=neighbours, label_binary=label_binary)
    except (ImportError, MeasureInputError) as exc:
        say(str(exc))
        sys.exit(2)
    click.echo(str(path))
