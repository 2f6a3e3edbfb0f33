"""Numerical building blocks that know no contact mechanics.

``convolution`` (the non-periodic FFT convolution on a padded grid: pyFFTW plans, spectra
cache, FFTW wisdom), ``conjugate_gradient`` (CG on a mask and the Polonsky–Keer constrained CG),
``preconditioner`` (the Fourier preconditioner |k| H(m)⁻¹), ``friction_qp`` (the friction
sub-problem of a load step) and ``memory`` (the memory budget of a rank, resident bytes, sizes
such as ``4G``). docs/design.md §2.2.
"""
