"""The sweep's cost model: what each task costs, its seconds and memory, and the wall time on R ranks."""
