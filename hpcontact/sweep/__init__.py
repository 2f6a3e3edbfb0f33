"""Parameter sweeps: job spec → tasks → MPI schedule → per-rank journals → xarray data set.

Modules, one job each: ``spec`` (TOML → checked axes and fixed fields), ``tasks`` (distinct
scenes, keys, cost estimates, chunks), ``costmodel`` (seconds and memory before a run: ``--dry-run``),
``schedule`` (MPI team and the shared atomic counter),
``journal`` (per-rank append-only journals), ``columns`` (a rank's outcomes as arrays per
variable, joined by rank 0), ``dataset`` (entries → labelled data set and
back: ``open_dataset``), ``netcdf`` (its compact, CF-checkable file), ``units`` (CF units of
scaled quantities), ``progress``
(progress lines, summary), ``guard`` (unusable outputs, the run lock), ``provenance`` (version,
revision, numerics fingerprint, resolved scenes), ``signals`` (stopping every rank), ``faults``
(fault injection for tests), ``arguments`` (the ``hpcontact run`` flags and exit statuses) and
``driver`` (``run_sweep`` and the ``hpcontact run`` command) and ``accuracy_study`` (the
accuracy-versus-cost sweep, every scene with cold kernels). The scene kinds and their solvers
live below: ``hpcontact.problems.kinds`` and ``hpcontact.accuracy.task_function``.
"""
