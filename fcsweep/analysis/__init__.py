"""Observables of the Fourier contour model: arrays in, arrays out.

Modules
-------
frames     per-cell time series read in pieces (blocks of frames or of cells)
msd        drift-subtracted, window-averaged mean squared displacement (freud.msd)
diffusion  long-time diffusion coefficient D_s, D0 = v0^2 / (2 Dr) and D_eff = D_s / D0
collective spatial statistical inefficiency of per-cell quantities
cage       cage-relative MSD, F_s, tau_alpha and the cage-breaking test
shapes     shape index q per cell and frame, its mean and histogram
voronoi    periodic Voronoi neighbours (freud), defect cells, defect clusters
voronoi_open  Voronoi neighbours of an open (non-periodic) field of view
order      hexatic order psi6, |Psi6|, G6(r) and the translational cut G_r(dx, 0)
kthny      KTHNY fits of G6, G_r and C_G1 and the KTHNY label
phase      solid / fluid / soft-fluid and percolation labels, with confidence or undetermined
points     the labels of a grid point from its replicates (and starts)
reasons    the declared reason codes every label carries beside its reason text
stats      time averages of correlated series with honest errors; replicate reduction
percolation  Fisher exponent of defect cluster sizes, calibrated on exact percolation
fss        finite-size collapse of the largest defect cluster
run_observables  every observable of one run from its arrays (compute_observables)
verdict    is a run's answer settled: the ``run.until`` targets against its scalars

Nothing here opens a file (no h5py, netCDF4, fcsweep.io or xarray file I/O; a test
checks it): reading trajectories and run directories and writing analysis.h5,
phase_diagram.nc, figures, movies and exports is :mod:`fcsweep.results`.
"""
