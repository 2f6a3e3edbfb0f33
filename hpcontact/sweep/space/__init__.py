"""The parameter space of a sweep: its spec parsed and checked, its axes, the enumeration of its scenes."""
