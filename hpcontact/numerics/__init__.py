"""Numerical building blocks that know no contact mechanics.

``convolution`` (the non-periodic FFT convolution on a padded grid: pyFFTW plans, spectra
cache, FFTW wisdom), ``conjugate_gradient`` (CG on a mask and the Polonsky–Keer constrained CG),
``preconditioner`` (the Fourier preconditioner |k| H(m)⁻¹), ``friction_qp`` (the friction
sub-problem of a load step), ``memory`` (the memory budget of a rank, resident bytes, sizes
such as ``4G``) and ``blas`` (the BLAS thread limit, applied only while a solve runs). docs/design.md §2.2.
"""
