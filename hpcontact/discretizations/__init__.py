"""Boundary discretizations beyond the plain grid: cells that follow the contact's edge.

``boundary_cells`` (coverage-weighted cells, and ``covered_solve``: the one-grid solve on the
treatment a study asks for), ``singular_cells`` (cells that carry the edge singularity of a
bonded punch), ``singular_pairs`` (their Galerkin pair integrals by edge-following
quadrature) and ``strip_cells`` (slender contacts as strips with the plane punch's profile
across). docs/design.md §2.2.
"""
