"""hpcontact: anisotropy of contact stiffness with FFT-accelerated half-space boundary elements."""

__version__ = "0.1.0"
