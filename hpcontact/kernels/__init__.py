"""Influence coefficients: the half-space's surface Green's functions integrated over cells.

``isotropic`` (Boussinesq–Cerruti, closed form), ``anisotropic`` (the surface Green's function
H(m) of any crystal by the Barnett–Lothe integrals), ``cell_integrals`` (exact integrals of the
1/r-type kernels over rectangular cells, any cell aspect) and ``engine`` (the kernel spectra and
convolution operators of one material on one grid, built only as a plan asks).
docs/design.md §2.1, §2.2, §2.5.
"""
