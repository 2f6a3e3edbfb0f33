"""Parameter sweeps: job spec → tasks → MPI schedule → per-rank journals → xarray data set.

The sweep by role, one package each (every module's docstring states its job):

* ``space``: the parameter space — ``parse`` (TOML → checked tables), ``axes`` (axis values and
  field types, from ``hpcontact.fields``), ``spec`` (the checked ``Spec``), ``enumeration``
  (runs of points, each distinct scene validated), ``tasks`` (distinct scenes, keys, chunks),
  ``adaptive_settings`` (the ``[adaptive]`` table);
* ``cost``: seconds and memory before a run — ``task_cost`` and ``grids`` (a task's work),
  ``engine`` (the one module that reads kernels and discretizations), ``rates``,
  ``calibration`` and ``calibration_file`` (the machine's rates), ``estimate`` and ``replay``
  (a run's totals and its schedule);
* ``run``: the run itself — ``records``, ``shares``, ``resume`` (rank 0's decision from the
  journals), ``rounds`` (``execute``), ``assembly`` and ``summary``, ``dry_run``, ``command``
  (``hpcontact run``), ``arguments``, ``schedule`` (MPI team, shared counter), ``signals``,
  ``guard`` (unusable outputs, the run lock), ``progress``, ``faults`` (fault injection for
  tests);
* ``data``: what a run keeps — ``journal`` (per-rank journals), ``columns``, ``dataset``
  (entries → labelled data set, ``open_dataset``), ``attributes``, ``netcdf``, ``units`` (CF
  units of scaled quantities), ``provenance`` (version, revision, fingerprint, the command),
  ``show`` (``hpcontact show``);
* ``maps``: adaptive maps — ``refinement``, ``checks``, ``fill``, ``rounds``,
  ``interpolation``.

``driver`` is the face of a run (``run_sweep``, ``main``: ``python -m hpcontact.sweep``) and
``accuracy_study`` the accuracy-versus-cost sweep, every scene with cold kernels. The scene
kinds and their solvers live below: ``hpcontact.problems.kinds`` and
``hpcontact.accuracy.task_function``.
"""
