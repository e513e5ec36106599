"""fcsweep: simulate and sweep the Fourier contour cell model of active deformable cells.

The names a notebook needs are here (imported on first use, so that ``import fcsweep`` stays
light):

>>> import fcsweep
>>> sim = fcsweep.Simulation.create(64, eta=0.3, v0=0.2, Dr=0.1, seed=1)   # doctest: +SKIP
>>> frames = sim.run(200, every=2)                                          # doctest: +SKIP
>>> ds = fcsweep.observables(frames)                                        # doctest: +SKIP

- ``Simulation``: the engine (:class:`fcsweep.simulation.Simulation`): ``create``, ``advance``,
  ``run`` (frames in memory), ``save`` / ``load``; ``SimParams`` and ``State``, its parameters
  and state;
- ``Frames``: recorded frames (:class:`fcsweep.frames.Frames`);
- ``observables``: a run's observables, errors and labels as an ``xarray.Dataset``
  (:func:`fcsweep.api.observables`);
- ``phase_diagram``: a sweep config simulated, analysed and aggregated
  (:func:`fcsweep.api.phase_diagram`);
- ``AnalysisSettings``: the analysis settings (:class:`fcsweep.model.settings.AnalysisSettings`);
- ``load_config``: a sweep YAML file, validated (:func:`fcsweep.config.load_config`);
- ``measure``: observables of segmented images (:func:`fcsweep.measure.measure`).
"""

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("fcsweep")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

#: Public name -> the module that defines it.
_HOMES = {
    "Simulation": "fcsweep.simulation", "SimParams": "fcsweep.simulation", "State": "fcsweep.simulation",
    "SimulationError": "fcsweep.simulation", "Frames": "fcsweep.frames", "observables": "fcsweep.api",
    "phase_diagram": "fcsweep.api", "AnalysisSettings": "fcsweep.model.settings", "load_config": "fcsweep.config",
}

__all__ = ["__version__", "measure", *_HOMES]


def __getattr__(name):
    if name == "measure":  # ``fcsweep.measure(labels, ...)``: the module is callable
        return import_module("fcsweep.measure")
    if name in _HOMES:
        return getattr(import_module(_HOMES[name]), name)
    raise AttributeError(f"module 'fcsweep' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), "measure", *_HOMES])
