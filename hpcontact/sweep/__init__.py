"""Parameter sweeps: job spec → tasks → MPI schedule → per-rank journals → xarray data set.

Modules, one job each: ``spec`` (TOML → checked axes and fixed fields), ``tasks`` (distinct
scenes, keys, cost estimates, chunks), ``kinds`` (the solver and validator of a scene kind:
contact or slip), ``schedule`` (MPI team and the shared atomic counter),
``journal`` (per-rank HDF5 journals), ``dataset`` (entries → netCDF4), ``progress`` (progress
lines, summary) and ``driver`` (``run_sweep`` and the ``hpcontact run`` command line).
"""
