"""Adaptive maps: solve the grid points a map needs, interpolate the rest (``[adaptive]``)."""
