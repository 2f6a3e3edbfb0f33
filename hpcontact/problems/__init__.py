"""The problems a scene poses, solved once on one discretization.

``contact`` (a bonded or frictionless punch, or a rigid sphere, on one grid: scene → plan →
kernels → solves → record), ``line_contact`` (the 2-D line contact), ``slip`` (two bodies with
Coulomb friction under a load path), ``kinds`` (the scene kinds and their validators) and
``footprint`` (the grid, CG iterations and array bytes of a one-grid solve, for cost and memory
plans). docs/design.md §2.3.
"""
