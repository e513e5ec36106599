"""The results of a sweep on disk: read run directories and trajectories, write
``analysis.h5``, ``phase_diagram.nc``, figures, movies and exports.

The numbers come from :mod:`fcsweep.analysis` (arrays in, arrays out); this layer does
the files around them.

Modules
-------
analyze    analyze_run / analyze_sweep: trajectory -> analysis.h5, the analysis settings
aggregate  build_dataset / aggregate_sweep: per-run files -> phase_diagram.nc
reduce     replicate means, point labels, Fisher exponents, FSS collapses, attributes, status flags
settle     assess_trajectory: the in-run ``run.until`` check on a partial trajectory
locate     where a sweep's results lie: a run's trajectory, the dataset
cells      the frames an export reads (per-cell quantities, contours)
export     GSD export (OVITO, MDAnalysis, freud) and the export dispatcher
vtk        VTK XML PolyData export (ParaView, VisIt, pyvista)
figures    drawing (dataset or arrays -> Figure) and plot_sweep / snapshot_run / movie_run (files)
"""
