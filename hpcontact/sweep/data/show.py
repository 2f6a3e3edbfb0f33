"""``hpcontact show RESULTS.nc``: a short summary of a sweep's data set, for the user who just ran
the job (docs/reference/cli.md).

It states the title; the axes with their sizes, ranges and units; the quantities stored; the
points, tasks, solves and failures (the first few with their points and messages); the worst
estimated relative error of every stored stiffness (``<name>_error``) and where, beside the
requested accuracy; for an adaptive map the worst map error of every refined quantity, the
tolerance and whether it was met, the solves against the points and the check points; and the
provenance (version, git revision, creation time, MPI size). Every number is read from the data
set (docs/reference/dataset.md): nothing is solved or recomputed.

``summarize(ds)`` gives it as a plain dictionary (what ``--json`` prints), ``summary(ds)`` as
text. A file that is missing, unreadable, damaged or not a sweep's data set is one line naming
the file and what is wrong, exit status 2 (``main``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # xarray comes with the data set opened (dataset.open_dataset): `hpcontact solve` need not import it
    import xarray as xr

from hpcontact.sweep.data.attributes import ERROR_STATUS_MEANINGS, STATUS_MEANINGS

#: Failures listed with their points and messages (the rest are counted).
FIRST_FAILURES = 5
#: Labels of a text axis shown (the rest are counted).
FIRST_LABELS = 6
#: An error this close above the requested accuracy is at it (interpolated errors of an adaptive map
#: carry the last bits of the interpolation).
ROUNDING = 1e-9
#: Variables that describe a point rather than store a quantity.
BOOKKEEPING = frozenset({"status", "message", "error_status", "solved", "plan"})


class NotASweep(ValueError):
    """The file is netCDF but not a sweep's data set (no ``status`` variable with its flags)."""


def _plain(value: Any) -> Any:
    """``value`` as JSON takes it: numpy scalars as Python numbers, NaN as None."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    return value


def _unit(attrs: Mapping[str, Any]) -> str:
    """What a value is in: its scale (``G a``) where it is stored as a ratio to one, else its
    ``units`` ("1": dimensionless; "" when none is stated)."""
    return str(attrs.get("scale", attrs.get("units", "")))


def _meanings(var: xr.DataArray, default: Mapping[int, str]) -> dict[int, str]:
    """Flag value -> meaning from the variable's CF flag attributes (``default`` without them)."""
    values, meanings = var.attrs.get("flag_values"), var.attrs.get("flag_meanings")
    if values is None or meanings is None:
        return dict(default)
    return {int(v): m for v, m in zip(np.atleast_1d(values), str(meanings).split())}


def _point(var: xr.DataArray, index: tuple[int, ...]) -> dict[str, Any]:
    """The coordinates of ``var`` at the array index ``index`` (dimension name -> label)."""
    point = {}
    for dim, i in zip(var.dims, index):
        coord = var[dim] if dim in var.coords else None
        if var.sizes[dim] > 1:  # an axis of one value says nothing about where
            point[str(dim)] = _plain(coord.values[i]) if coord is not None else int(i)
    return point


def _axis(ds: xr.Dataset, name: str) -> dict[str, Any]:
    values = ds[name].values
    axis: dict[str, Any] = {"name": name, "size": int(values.size), "long_name": ds[name].attrs.get("long_name", "")}
    if values.dtype.kind in "fiu":
        axis.update(min=_plain(np.nanmin(values)), max=_plain(np.nanmax(values)), units=_unit(ds[name].attrs))
    else:
        axis["labels"] = [_plain(v) for v in values]
    return axis


def _default_target(ds: xr.Dataset) -> float | None:
    """The one target every estimated point was solved to where the spec requested no accuracy
    (the default's, ``accuracy.DEFAULT_ACCURACY``: the records' ``accuracy``), else None."""
    if _attr(ds, "requested_accuracy") is not None or "accuracy" not in ds.data_vars:
        return None
    targets = np.unique(np.asarray(ds["accuracy"].values, dtype=float))
    targets = targets[np.isfinite(targets)]
    return float(targets[0]) if len(targets) == 1 else None


def _worst(var: xr.DataArray) -> dict[str, Any] | None:
    """The largest finite value of ``var`` and its point; None when it has none."""
    values = np.asarray(var.values, dtype=float)
    if not np.isfinite(values).any():
        return None
    flat = int(np.nanargmax(np.where(np.isfinite(values), values, np.nan)))
    index = np.unravel_index(flat, values.shape)
    return {"error": _plain(values[index]), "at": _point(var, tuple(int(i) for i in index))}


def _attr(ds: xr.Dataset, name: str) -> Any:
    return _plain(ds.attrs[name]) if name in ds.attrs else None


def check_sweep(ds: xr.Dataset) -> None:
    """Raise ``NotASweep`` unless ``ds`` has the ``status`` variable every sweep writes."""
    if "status" not in ds.data_vars:
        raise NotASweep("not a sweep data set: no status variable (hpcontact run writes one per task)")
    if "flag_meanings" not in ds["status"].attrs or "ok" not in str(ds["status"].attrs["flag_meanings"]).split():
        raise NotASweep("not a sweep data set: its status variable has no task status flags")


def summarize(ds: xr.Dataset, path: str | Path | None = None) -> dict[str, Any]:
    """The summary of the sweep data set ``ds`` as a dictionary of plain values (JSON as it is;
    NaN as None); ``path`` is named in it when given. Raises ``NotASweep`` on a data set without
    a sweep's ``status`` variable."""
    check_sweep(ds)
    status = ds["status"]
    order = str(ds.attrs.get("sweep_axes", " ".join(map(str, ds.dims)))).split()
    dims = [d for d in order if d in ds.dims] + [str(d) for d in ds.dims if str(d) not in order]
    stiffnesses = [str(n) for n in ds.data_vars if f"{n}_error" in ds.data_vars and not str(n).endswith("_error")]
    errors = {f"{n}_error" for n in stiffnesses} | {f"{n}_map_error" for n in stiffnesses}
    others = [str(n) for n in ds.data_vars if str(n) not in {*stiffnesses, *errors, *BOOKKEEPING}]
    units: dict[str, list[str]] = {}
    for name in stiffnesses:
        units.setdefault(_unit(ds[name].attrs), []).append(name)

    codes = np.asarray(status.values)
    meanings = _meanings(status, STATUS_MEANINGS)
    ok = next((v for v, m in meanings.items() if m == "ok"), 0)
    failed = np.argwhere(codes != ok)
    messages = ds["message"] if "message" in ds.data_vars else None
    first = []
    for index in failed[:FIRST_FAILURES]:
        index = tuple(int(i) for i in index)
        message = _plain(messages.values[index]) if messages is not None else ""
        first.append(
            {
                "at": _point(status, index),
                "status": meanings.get(int(codes[index]), str(codes[index])),
                "message": message,
            }
        )
    by_status: dict[str, int] = {}
    for code in codes[codes != ok]:
        key = meanings.get(int(code), str(code))
        by_status[key] = by_status.get(key, 0) + 1

    error_counts = None
    if "error_status" in ds.data_vars:
        flags = _meanings(ds["error_status"], ERROR_STATUS_MEANINGS)
        values = np.asarray(ds["error_status"].values)
        error_counts = {flags[v]: int((values == v).sum()) for v in sorted(flags)}

    solves = _attr(ds, "sweep_solves")
    summary: dict[str, Any] = {
        "file": str(path) if path is not None else None,
        "title": _attr(ds, "title"),
        "scene_kind": _attr(ds, "scene_kind"),
        "axes": [_axis(ds, d) for d in dims],
        "fixed": {str(n): _plain(ds[n].values[()]) for n in ds.coords if ds[n].ndim == 0},
        "quantities": {"stiffnesses": units, "other": others},
        "points": int(codes.size),
        "point_axes": [str(d) for d in status.dims],
        "tasks": _attr(ds, "sweep_tasks"),
        "tasks_run": _attr(ds, "sweep_tasks_run"),
        "tasks_reused": _attr(ds, "sweep_tasks_reused"),
        "solves": solves if solves is not None else _attr(ds, "sweep_tasks"),
        "solves_counted": "sweep_solves" if solves is not None else "one per task (sweep_tasks)",
        "wall_time_s": _attr(ds, "sweep_wall_time_s"),
        "failures": {"count": int(len(failed)), "by_status": by_status, "first": first},
        "errors": {
            "requested_accuracy": _attr(ds, "requested_accuracy"),
            "default_target": _default_target(ds),
            "worst": {name: _worst(ds[f"{name}_error"]) for name in stiffnesses},
            "error_status": error_counts,
        },
        "adaptive": None,
        "provenance": {
            "hpcontact_version": _attr(ds, "hpcontact_version"),
            "git_revision": _attr(ds, "git_revision"),
            "created": _attr(ds, "created"),
            "mpi_size": _attr(ds, "mpi_size"),
            "contributors": len(json.loads(ds.attrs["sweep_contributors"]))
            if "sweep_contributors" in ds.attrs
            else None,
            "runs": len(str(ds.attrs["history"]).splitlines()) if "history" in ds.attrs else None,
            "spec_path": _attr(ds, "spec_path"),
        },
    }
    if "solved" in ds.data_vars:
        refined = str(ds.attrs.get("adaptive_quantities", "")).split() or [
            n for n in stiffnesses if f"{n}_map_error" in ds.data_vars
        ]
        summary["adaptive"] = {
            "tolerance": _attr(ds, "adaptive_tolerance"),
            "met": None if "adaptive_met" not in ds.attrs else bool(ds.attrs["adaptive_met"]),
            "max_map_error": _attr(ds, "adaptive_max_map_error"),
            "worst": {n: _worst(ds[f"{n}_map_error"]) for n in refined if f"{n}_map_error" in ds.data_vars},
            "solves": solves,
            "points_solved": int(np.asarray(ds["solved"].values == 1).sum()),
            "points": int(codes.size),
            "check_points": _attr(ds, "adaptive_check_points"),
            "rounds": _attr(ds, "adaptive_rounds"),
            "estimate_factor": _attr(ds, "adaptive_estimate_factor"),
            "points_not_interpolated": _attr(ds, "adaptive_points_not_interpolated"),
        }
    return summary


def _number(value: Any) -> str:
    return "-" if value is None else f"{value:.4g}" if isinstance(value, float) else str(value)


def _error(value: float) -> str:
    """An error as printed: three significant digits (``summarize`` keeps every digit)."""
    return f"{value:.2e}"


def _at(point: Mapping[str, Any]) -> str:
    return ", ".join(f"{k}={_number(v)}" for k, v in point.items())


def _unit_text(unit: str) -> str:
    return "" if unit in ("", "1") else f" {unit}"


def text(summary: Mapping[str, Any]) -> str:
    """The summary ``summarize`` made, as the lines ``hpcontact show`` prints."""
    lines = [str(summary["title"] or summary["file"] or "sweep data set")]
    if summary["file"]:
        lines.append(f"  file {summary['file']}")
    lines.append("axes")
    for axis in summary["axes"]:
        if "labels" in axis:
            labels = [str(v) for v in axis["labels"]]
            shown = " ".join(labels[:FIRST_LABELS]) + (
                f" … ({len(labels) - FIRST_LABELS} more)" if len(labels) > FIRST_LABELS else ""
            )
            lines.append(f"  {axis['name']:<12s} {axis['size']:>5d}  {shown}")
        else:
            span = _number(axis["min"]) if axis["size"] == 1 else f"{_number(axis['min'])} … {_number(axis['max'])}"
            lines.append(
                f"  {axis['name']:<12s} {axis['size']:>5d}  {span}{_unit_text(axis['units'])}  ({axis['long_name']})"
            )
    if summary["fixed"]:
        lines.append("  fixed: " + ", ".join(f"{k} = {_number(v)}" for k, v in summary["fixed"].items()))
    lines.append("quantities")
    for unit, names in summary["quantities"]["stiffnesses"].items():
        lines.append(f"  {' '.join(names)}  [{unit or 'no unit stated'}]")
    if summary["quantities"]["other"]:
        also = " ".join(summary["quantities"]["other"])
        lines.append(textwrap.fill(also, width=100, initial_indent="  also: ", subsequent_indent="        "))

    failures = summary["failures"]
    per = " × ".join(summary["point_axes"])
    lines.append("run")
    lines.append(
        f"  {summary['points']} points ({per}), {_number(summary['tasks'])} tasks "
        f"({_number(summary['tasks_run'])} run, {_number(summary['tasks_reused'])} reused), "
        f"{_number(summary['solves'])} solves"
        + ("" if summary["solves_counted"] == "sweep_solves" else " (one per task)")
    )
    detail = ", ".join(f"{n} {m}" for m, n in failures["by_status"].items())
    lines.append(f"  failures: {failures['count']}" + (f" ({detail})" if detail else ""))
    for failure in failures["first"]:
        lines.append(f"    {_at(failure['at'])}: {failure['status']}: {failure['message']}")
    if failures["count"] > len(failures["first"]):
        lines.append(f"    … {failures['count'] - len(failures['first'])} more")

    errors = summary["errors"]
    if errors["worst"]:
        requested, target = errors["requested_accuracy"], errors["default_target"]
        if requested is not None:
            said, limit, what = f"requested accuracy {_number(requested)}", requested, "the requested accuracy"
        elif target is not None:
            said, limit, what = f"no accuracy requested: the default's target {_number(target)}", target, "that target"
        else:
            said, limit, what = "no accuracy requested", None, ""
        lines.append(f"estimated relative errors (worst; {said})")
        width = max(len(n) for n in errors["worst"])
        for name, worst in errors["worst"].items():
            if worst is None:
                lines.append(f"  {name:<{width}s}  no estimate")
                continue
            above = limit is not None and worst["error"] > limit * (1.0 + ROUNDING)
            over = f"  (above {what})" if above else ""
            lines.append(f"  {name:<{width}s}  {_error(worst['error'])}  at {_at(worst['at'])}{over}")
        if errors["error_status"] is not None:
            lines.append("  points: " + ", ".join(f"{n} {m}" for m, n in errors["error_status"].items()))

    adaptive = summary["adaptive"]
    if adaptive is not None:
        met = {True: "met", False: "NOT met", None: "not stated"}[adaptive["met"]]
        lines.append(f"adaptive map (tolerance {_number(adaptive['tolerance'])}: {met})")
        solved = adaptive["points_solved"]
        checks = adaptive["check_points"]
        factor = adaptive["estimate_factor"]
        lines.append(
            f"  {_number(adaptive['solves'])} solves for {adaptive['points']} points"
            + (f" ({solved} points solved)" if solved != adaptive["solves"] else "")
            + (f"; {checks} random check points" if checks else "; no check points")
            + (f", estimate factor {_number(factor)}" if checks and factor is not None else "")
            + f"; {_number(adaptive['rounds'])} rounds"
        )
        if adaptive["points_not_interpolated"]:
            lines.append(f"  {adaptive['points_not_interpolated']} points neither solved nor interpolated (NaN)")
        if adaptive["worst"]:
            width = max(len(n) for n in adaptive["worst"])
            for name, worst in adaptive["worst"].items():
                shown = "no estimate" if worst is None else f"{_error(worst['error'])}  at {_at(worst['at'])}"
                lines.append(f"  {name:<{width}s}  map error {shown}")

    prov = summary["provenance"]
    lines.append("provenance")
    lines.append(
        f"  hpcontact {prov['hpcontact_version'] or '?'}, git {prov['git_revision'] or '?'}, "
        f"created {prov['created'] or '?'}, MPI size {_number(prov['mpi_size'])}"
    )
    if prov["runs"] or prov["contributors"]:
        lines.append(
            f"  {_number(prov['runs'])} run(s) in its history, {_number(prov['contributors'])} version(s) in its journals"
        )
    if prov["spec_path"]:
        lines.append(f"  spec {prov['spec_path']}")
    return "\n".join(lines)


def summary(ds: xr.Dataset, path: str | Path | None = None) -> str:
    """The summary of the sweep data set ``ds`` as text (``hpcontact show`` prints it)."""
    return text(summarize(ds, path))


def _problem(path: str, exc: BaseException) -> str:
    """What is wrong with ``path``, in words, from the exception that opening it raised."""
    if isinstance(exc, FileNotFoundError):
        return "no such file"
    if isinstance(exc, IsADirectoryError) or os.path.isdir(path):
        return "is a directory, not a data set"
    if isinstance(exc, PermissionError):
        return "permission denied"
    if isinstance(exc, NotASweep):
        return str(exc)
    if isinstance(exc, OSError):
        reason = str(exc.strerror or exc)
        if "Unknown file format" in reason:
            return f"not a netCDF file ({reason})"
        return reason
    if isinstance(exc, RuntimeError) and "HDF error" in str(exc):
        return f"damaged: a variable cannot be read ({exc})"
    return f"cannot be read as a sweep data set ({type(exc).__name__}: {exc})"


def add_show_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The arguments of ``hpcontact show`` on ``parser``."""
    parser.description = (
        "Summarize a sweep's data set: axes, quantities, points, tasks, solves, failures, the worst\n"
        "estimated errors and where, an adaptive map's map errors and tolerance, provenance."
    )
    parser.epilog = (
        "examples:\n"
        "  hpcontact show results/demo.nc                the summary as text\n"
        "  hpcontact show results/demo_map.nc --json     the same as one JSON object\n\n"
        "A missing, unreadable or damaged file, or one that is not a sweep's data set, is one line\n"
        "on stderr naming it and what is wrong, exit status 2."
    )
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("file", help="the data set (netCDF) that hpcontact run wrote")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    return parser


def show_command(args: argparse.Namespace) -> int:
    """``hpcontact show``: print the summary of ``args.file``; 2 with one line on stderr when the
    file cannot be summarized."""
    from hpcontact.sweep.data.dataset import open_dataset  # as hpcontact.open_dataset, without an upward import

    path = args.file
    try:
        with open_dataset(path) as ds:
            result = summarize(ds, path)
    except (OSError, ValueError, KeyError, TypeError, RuntimeError) as exc:
        print(f"hpcontact show: {path}: {_problem(path, exc)}", file=sys.stderr)
        return 2
    print(json.dumps(result) if args.json else text(result))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m hpcontact.sweep.data.show FILE [--json]``: ``hpcontact show`` alone."""
    parser = add_show_arguments(argparse.ArgumentParser(prog="hpcontact show"))
    return show_command(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
