"""``hpcontact run SPEC --dry-run``: the tasks of a spec with the cost model's estimates (seconds,
memory, wall time on 1, 64 and 1024 ranks), nothing computed."""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from hpcontact.numerics.memory import default_memory_per_rank
from hpcontact.sweep.cost.calibration_file import described, load_calibration
from hpcontact.sweep.run.arguments import EXIT_OK
from hpcontact.sweep.run.guard import apart
from hpcontact.sweep.run.options import MEM_PER_RANK
from hpcontact.sweep.run.summary import SHOWN_FAILURES
from hpcontact.sweep.space.parse import load_spec
from hpcontact.sweep.work.estimate import Estimate, estimate, gpu_batches
from hpcontact.sweep.work.tasks import enumerate_part, join_parts, points, progress_lines

#: A dry run lists a sample of the tasks, after its summary: the first ``LISTED_HEAD`` and the last
#: ``LISTED_TAIL``, and a line saying how many it left out between them (``--list-all``: every task;
#: ``--json`` always lists every task). Mindlin's adaptive map has 861 tasks, a large sweep 10^6:
#: lines nobody reads, and printing them takes longer than the estimate.
LISTED_HEAD = 10
LISTED_TAIL = 5


def listed_tasks(count: int, list_all: bool = False) -> Sequence[int | None]:
    """The indices of the tasks a text dry run of ``count`` tasks lists, in order, with None where
    it says how many it left out: every task when ``list_all`` or when there are no more than
    ``LISTED_HEAD + LISTED_TAIL``, else the first ``LISTED_HEAD`` and the last ``LISTED_TAIL``."""
    if list_all or count <= LISTED_HEAD + LISTED_TAIL:
        return range(count)
    return [*range(LISTED_HEAD), None, *range(count - LISTED_TAIL, count)]


def dry_run(
    spec_path: str | Path,
    output: str | Path | None = None,
    stream: TextIO | None = None,
    *,
    as_json: bool = False,
    mem_per_rank: int | None = None,
    calibration: Any = None,
    list_all: bool = False,
    accuracy: float | None = None,
) -> int:
    """``hpcontact run SPEC --dry-run``: a line with the title, the number of tasks and the output;
    the summary: the distinct grids and kernel sets, the totals (core-seconds, core-hours, peak
    memory), the wall time on 1, 64 and 1024 ranks (``cost``) and an adaptive spec's first
    round and bound; then the tasks with their 0-based indices (the order ``HPCONTACT_FAULTS``
    counts in), relative cost, estimated seconds and peak memory and parameters: a sample
    (``listed_tasks``) unless ``list_all``. A warning on stderr for tasks over ``mem_per_rank`` bytes (default:
    ``numerics.memory.default_memory_per_rank``). With ``as_json``, one JSON object instead,
    every task in its ``tasks_list`` (written as it goes, not built in memory). Nothing is
    computed but the cost model's calibration (once per host and version,
    ``cost.calibration_file.load_calibration``)."""
    stream = stream if stream is not None else sys.stdout
    spec = load_spec(
        spec_path, output=output, check_scenes=False, accuracy=accuracy
    )  # checked once, while enumerating:
    apart(spec)  # refused as the run refuses it (guard.apart), before the enumeration
    progress = progress_lines(sys.stderr, points(spec))
    tasks, task_of = join_parts(spec, [enumerate_part(spec, check=True, progress=progress, lean=True)])
    # a dry run is the command line's alone (``hpcontact run --dry-run``): its words
    limit, source = (mem_per_rank, MEM_PER_RANK.flag) if mem_per_rank is not None else default_memory_per_rank()
    if calibration is None:
        calibration = load_calibration(stream=sys.stderr)
    est = estimate(tasks, calibration)
    over = est.over(limit)
    peak_task = int(np.argmax(est.bytes)) if tasks else None  # the first of the largest
    if over:
        shown = ", ".join(map(str, over[:SHOWN_FAILURES])) + (", ..." if len(over) > SHOWN_FAILURES else "")
        print(
            f"hpcontact: warning: {len(over)} task(s) need more memory than {limit / 2**20:.0f} MiB per rank "
            f"({source}): {shown}; hpcontact run refuses this spec",
            file=sys.stderr,
        )
    if as_json:
        head = json.dumps(
            {
                "title": spec.title,
                "output": str(spec.output),
                "tasks": len(tasks),
                "estimated_task_seconds": est.total_seconds,
                "estimated_core_hours": est.total_seconds / 3600.0,
                "estimated_peak_memory_bytes": est.peak_bytes,
                "peak_memory_task": peak_task,
                "wall_time_s": {str(r): w for r, w in est.wall_s.items()},
                "efficiency": {str(r): e for r, e in est.efficiency.items()},
                "grids": est.grids(),
                "kernel_sets": est.kernel_sets(),
                "mem_per_rank_bytes": limit,
                "mem_per_rank_source": source,
                "tasks_over_memory": over,
                "calibration": {
                    "host": calibration.host,
                    "version": calibration.version,
                    "cpu": calibration.cpu,
                    "cores": calibration.cores,
                    "date": calibration.date,
                },
                "tasks_not_estimated": est.not_estimated,
                **_gpu_json(est),
            }
        )
        # the object json.dumps writes with "tasks_list" last, one entry per task, written in blocks
        stream.write(head[:-1] + ', "tasks_list": [')
        for begin in range(0, len(tasks), 10_000):
            stream.write(
                ", ".join(
                    f'{{"index": {i}, "key": {_json_text(t.key)}, "cost": {_json_number(t.cost)}, '
                    f'"estimated_seconds": {_json_seconds(s)}, "estimated_peak_memory_bytes": {_json_number(b)}}}'
                    for i, t, s, b in zip(
                        range(begin, begin + 10_000),
                        tasks[begin : begin + 10_000],
                        est.seconds[begin : begin + 10_000].tolist(),
                        est.bytes[begin : begin + 10_000].tolist(),
                    )
                )
                + (", " if begin + 10_000 < len(tasks) else "")
            )
        stream.write("]}\n")
        stream.flush()
        return EXIT_OK
    print(
        f"# {spec.title}: {len(tasks)} tasks -> {spec.output} (index, key, relative cost, estimated seconds, "
        f"estimated peak MiB, scene)",
        file=stream,
    )
    counts = est.grids()  # once: a label per task
    grids = "; ".join(f"{label}: {count} tasks" for label, count in counts.items())
    print(f"# {len(counts)} grid(s) ({grids}); {est.kernel_sets()} kernel set(s)", file=stream)
    left_out = f" ({est.not_estimated} GPU task(s) not estimated)" if est.not_estimated else ""
    # an adaptive map's totals are its bound, every task solved: its rounds solve fewer (its line below)
    every = " if every task is solved (an adaptive map's bound)" if spec.adaptive is not None else ""
    print(
        f"# estimated{every}: {est.total_seconds:.4g} core-seconds = {est.total_seconds / 3600.0:.3g} core-hours{left_out}; "
        f"peak memory {est.peak_bytes / 2**20:.0f} MiB (task {peak_task}); limit {limit / 2**20:.0f} MiB per rank "
        f"({source})",
        file=stream,
    )
    walls = ", ".join(
        f"{r} rank(s) {_wall_text(w)} (efficiency {est.efficiency[r]:.2f})" for r, w in est.wall_s.items()
    )
    cpu_tasks = "" if est.on_gpu is None else " (CPU tasks)"
    print(
        f"# wall time{every}: {walls or 'not estimated while a task has no seconds'}; {described(calibration)}{cpu_tasks}",
        file=stream,
    )
    for line in _gpu_lines(est):
        print(line, file=stream)
    if calibration.contended():
        print(f"# warning: cost model {calibration.contended()}", file=stream)
    if spec.adaptive is not None:  # all the tasks are the bound; the first round solves fewer
        from hpcontact.sweep.maps.rounds import dry_run_text

        print(dry_run_text(spec, task_of, est.seconds), file=stream)
    shown = json.JSONEncoder(sort_keys=True).encode  # json.dumps(..., sort_keys=True) without an encoder per line
    listed = listed_tasks(len(tasks), list_all)
    left_out = len(tasks) - LISTED_HEAD - LISTED_TAIL
    for begin in range(0, len(listed), 10_000):
        stream.write(
            "".join(
                f"# ... {left_out} more tasks ({LISTED_HEAD} ... {len(tasks) - LISTED_TAIL - 1}; "
                f"--list-all lists every task)\n"
                if i is None
                else f"{i:6d}  {tasks[i].key[:12]}  {tasks[i].cost:10.3g}  {_seconds_text(float(est.seconds[i]))}  "
                f"{float(est.bytes[i]) / 2**20:7.0f}  {shown(dict(tasks[i].params))}\n"
                for i in listed[begin : begin + 10_000]
            )
        )
    return EXIT_OK


def _gpu_lines(est: Estimate) -> list[str]:
    """The text dry run's lines on GPU tasks: on which GPU, whose cost model (or that there is none
    for this GPU), and per grid a scene's device memory and the scenes of one batch."""
    if est.gpu is None or est.on_gpu is None:
        return []
    gpu = est.gpu.gpu
    lines = [
        f"# GPU tasks: {int(est.on_gpu.sum())} on {gpu.label}, {gpu.free / 2**30:.1f} GiB free here; {est.gpu.note}"
        + ("" if est.gpu.calibration is not None else ": their seconds are not estimated")
    ]
    lines += [
        f"# GPU batch: {label}: {nbytes / 2**20:.0f} MiB a scene on the device, up to {scenes} scene(s) a batch"
        for label, nbytes, scenes in gpu_batches(est)
    ]
    return lines


def _gpu_json(est: Estimate) -> dict[str, Any]:
    """The JSON dry run's keys on GPU tasks (``_gpu_lines``), none without GPU tasks."""
    if est.gpu is None or est.on_gpu is None:
        return {}
    gpu = est.gpu.gpu
    return {
        "gpu": {
            "tasks": int(est.on_gpu.sum()),
            "device": gpu.label,
            "free_bytes": gpu.free,
            "total_bytes": gpu.total,
            "cost_model": est.gpu.note,
            "calibrated": est.gpu.calibration is not None,
            "batches": [{"grid": g, "scene_bytes": b, "scenes_per_batch": n} for g, b, n in gpu_batches(est)],
        }
    }


def _seconds_text(seconds: float) -> str:
    """A task's estimated seconds in the listing; a task without an estimate (a GPU task without
    its GPU's calibration) says so."""
    return f"{seconds:9.3g}" if not math.isnan(seconds) else "     none"


def _json_seconds(seconds: float) -> str:
    """A task's estimated seconds in the JSON listing: null for a task without an estimate."""
    return "null" if math.isnan(seconds) else _json_number(seconds)


def _json_text(text: str) -> str:
    """``text`` as ``json.dumps`` writes it (a task key, hex, as it is)."""
    return f'"{text}"' if text.isalnum() and text.isascii() else json.dumps(text)


def _json_number(value: float) -> str:
    """``value`` as ``json.dumps`` writes it: ``repr`` of a finite number, else NaN / Infinity."""
    return repr(value) if math.isfinite(value) else json.dumps(value)


def _wall_text(seconds: float) -> str:
    """``seconds`` as the dry-run prints a wall time: s below 2 minutes, else min, else h."""
    if seconds < 120.0:
        return f"{seconds:.3g} s"
    return f"{seconds / 60.0:.3g} min" if seconds < 7200.0 else f"{seconds / 3600.0:.3g} h"
