"""The work of a sweep: its tasks (keys, groups, chunks), their estimated seconds and memory, the schedule replayed."""
