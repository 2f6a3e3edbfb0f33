"""Materials of the half-space: what stiffness relates stress to strain, nothing about grids.

``isotropic`` (``Isotropic``: G, nu and the plane-strain modulus), ``crystal`` (``Crystal``:
a 6 × 6 stiffness in GPa or units of G, rotations, the library of cubic crystals, cubic
constants from (nu, A)) and ``elastic_constants`` (crystals from the fields a scene or a slip
body names: ``cubic``, ``orthotropic``, ``voigt``, ``material``). docs/design.md §2.5.
"""
