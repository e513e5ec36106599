"""Observables of the Fourier contour model: arrays in, arrays out.

Modules
-------
msd        drift-subtracted, window-averaged mean squared displacement (freud.msd)
diffusion  long-time diffusion coefficient D_s, D0 = v0^2 / (2 Dr) and D_eff = D_s / D0
shapes     shape index q per cell and frame, its mean and histogram
voronoi    periodic Voronoi neighbours (freud), defect cells, defect clusters
order      hexatic order psi6, |Psi6|, G6(r) and the translational cut G_r(dx, 0)
phase      solid / fluid / soft-fluid and percolation labels, with confidence or undetermined
reasons    the declared reason codes every label carries beside its reason text
stats      time averages of correlated series with honest errors; replicate reduction
percolation  Fisher exponent of defect cluster sizes, calibrated on exact percolation
trajectory reading one H5MD trajectory (file access, used by the pipeline only)
pipeline   analyze_run / analyze_sweep (files)
aggregate  build_dataset / aggregate_sweep: per-run files -> phase_diagram.nc
figures    drawing (dataset or arrays -> Figure) and plot_sweep / snapshot_run / movie_run (files)

Only :mod:`trajectory`, :mod:`pipeline`, :mod:`aggregate` and :mod:`figures` touch files; everything else takes and
returns numpy arrays so that it can be tested with known answers.
"""
