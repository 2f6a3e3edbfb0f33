"""A sweep's data: the data set's attributes (and, moved by the coordinator, journal, columns, assembly, netcdf, units, provenance, show)."""
