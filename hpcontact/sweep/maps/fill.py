"""The data set of an adaptive map: every unsolved point interpolated from the nodes, the map
errors, ``solved`` and the ``adaptive_*`` attributes (:func:`fill`; docs/reference/dataset.md)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from hpcontact.errors import InputError
from hpcontact.problems.kinds import KINDS
from hpcontact.sweep.data.columns import NOT_COMPUTED
from hpcontact.sweep.data.dataset import DIRECTIONAL, TENSOR, derive_directional, directional_errors
from hpcontact.sweep.data.journal import OK
from hpcontact.sweep.maps.estimates import OFF_DIAGONAL, Checks, Layout
from hpcontact.sweep.maps.state import State, estimate, node_mask, state_tasks

MAP_ERROR_SUFFIX = "_map_error"
INTERPOLATED_MESSAGE = "interpolated (adaptive map)"
#: An unsolved point whose interpolant needs a node whose solve failed (status not computed).
UNINTERPOLATED_MESSAGE = "not interpolated: a solve it depends on failed (adaptive map)"


def stiffness_names(ds: Any, kind: str) -> list[str]:
    """The stored stiffnesses of ``ds`` (those that carry ``<name>_error``): a data set's data
    variables, or the names of ``dataset.stored_stiffnesses``' arrays."""

    pattern = KINDS[kind].estimated
    return [str(v) for v in ds if pattern.match(str(v)) and not str(v).endswith("_error")]


def refined_names(ds: Any, spec: Any) -> list[str]:
    """The quantities refined on: ``[adaptive] quantities`` that ``ds`` holds (as
    ``stiffness_names``), else every stored stiffness."""
    stored = stiffness_names(ds, spec.kind)
    chosen = spec.adaptive.quantities
    if chosen is None:
        return stored
    for name in chosen:
        if name not in stored:
            raise InputError("adaptive.quantities", f"stiffnesses the scenes store ({', '.join(stored)})", name)
    return list(chosen)


def quantity_fields(ds: Any, names: Sequence[str]) -> dict[str, np.ndarray]:
    """The values of the quantities ``names`` in ``ds`` and their ``<name>_error`` where stored,
    as float arrays over the task axes."""
    out = {}
    for name in names:
        for full in (name, f"{name}_error"):
            if full in ds:
                out[full] = np.asarray(ds[full].values, dtype=np.float64)
    return out


def fill(
    ds: Any, spec: Any, layout: Layout, state: State, task_of: np.ndarray, rounds: int, checks: Checks | None = None
) -> Any:
    """The final data set of an adaptive sweep from ``ds`` (``dataset.dataset_of`` of every
    journaled task, derive off): every unsolved point of a sub-problem filled by interpolation
    from its nodes (stiffnesses and their ``<name>_error``; other record variables NaN or "",
    ``status`` ok where the stiffnesses are finite (those finite at every successful solve:
    normalized_* of an anisotropic body is NaN by definition), ``message`` ``INTERPOLATED_MESSAGE``,
    ``error_status`` the worst of the sub-problem's nodes), plus ``solved``,
    ``<name>_map_error`` for every stored stiffness (linked by ``ancillary_variables``) and the
    global attributes ``sweep_solves``, ``adaptive_*``. The check points of ``checks`` are
    solved points; each sub-problem's estimate carries the factor its checks set."""
    import xarray as xr  # here, not at the module's import: a round's decision needs none (maps.rounds)

    checks = checks if checks is not None else Checks()
    task_of = np.asarray(task_of)
    solved_tasks = state_tasks(layout, state, task_of, checks)
    solved = np.isin(task_of, solved_tasks)
    names = stiffness_names(ds, spec.kind)
    dims = ds["status"].dims
    fields = quantity_fields(ds, names)
    values = {n: a.copy() for n, a in fields.items()}
    maps = {n: np.full(layout.shape, np.nan) for n in names}
    worst_status = ds["error_status"].values.copy() if "error_status" in ds else None
    for s, (cat, leaves) in enumerate(state):
        est = estimate(layout, cat, leaves, names, fields, checks.factor(s), checks.cautious(s))
        mask = layout.take(solved, cat)
        for q, name in enumerate(names):
            current = layout.take(values[name], cat)
            layout.put(values[name], cat, np.where(mask, current, est.values[..., q]))
            solve = (
                np.abs(np.nan_to_num(layout.take(fields[f"{name}_error"], cat), nan=0.0))
                if f"{name}_error" in fields
                else 0.0
            )
            interp = sum(e[..., q] for e in est.axes) + est.solve[..., q]
            layout.put(maps[name], cat, np.where(mask, solve, interp))
            if f"{name}_error" in values:
                current = layout.take(values[f"{name}_error"], cat)
                layout.put(values[f"{name}_error"], cat, np.where(mask, current, est.solve[..., q]))
        if worst_status is not None:
            node_status = layout.take(ds["error_status"].values, cat)[node_mask(layout, leaves)]
            current = layout.take(worst_status, cat)
            layout.put(worst_status, cat, np.where(mask, current, node_status.max()))
    out = ds.copy()
    unsolved = ~solved
    # every variable replaced or added at once (``assign``: one merge; a Dataset's __setitem__
    # merges each time, ~9 ms a variable on the 4-D map's 146 475 points)
    new: dict[str, Any] = {}
    for name in out.data_vars:
        if name in values:
            new[name] = (out[name].dims, values[name], out[name].attrs)
        elif out[name].dims == dims and name not in ("status", "message", "error_status"):
            array = out[name].values.copy()
            if array.dtype.kind == "f":
                array[unsolved] = np.nan
            elif array.dtype.kind in "OUS":
                array = array.astype(object)
                array[unsolved] = ""
            else:
                continue
            new[name] = (dims, array, out[name].attrs)
    # a stiffness undefined at some solves that succeeded (normalized_* of an anisotropic body:
    # NaN by definition) is no sign of a failed node where it is NaN between them
    ok = solved & (ds["status"].values == OK)
    defined = [n for n in names if np.all(np.isfinite(fields[n][ok]))]
    finite = np.all([np.isfinite(values[n]) for n in defined], axis=0) if defined else np.ones(layout.shape, bool)
    status = out["status"].values.copy()
    status[unsolved] = np.where(finite[unsolved], OK, NOT_COMPUTED)
    new["status"] = (dims, status, out["status"].attrs)
    message = out["message"].values.astype(object).copy()
    message[unsolved] = np.where(finite[unsolved], INTERPOLATED_MESSAGE, UNINTERPOLATED_MESSAGE)
    new["message"] = (dims, message, out["message"].attrs)
    if worst_status is not None:
        new["error_status"] = (dims, worst_status, out["error_status"].attrs)
    new["solved"] = (
        dims,
        solved.astype(np.int32),  # the file's integer type (netcdf: every integer is int32)
        {
            "long_name": "whether the point was solved (1) or interpolated from solved points (0) by the adaptive map",
            "flag_values": np.array([0, 1], dtype=np.int32),
            "flag_meanings": "interpolated solved",
        },
    )
    for name in names:
        relative_to = "the largest diagonal entry" if OFF_DIAGONAL.match(name) else f"|{name}|"
        new[f"{name}{MAP_ERROR_SUFFIX}"] = (
            dims,
            maps[name],
            {
                "long_name": f"estimated relative error of {name} in the adaptive map, relative to {relative_to}: "
                f"the interpolation estimate (0 at solved points) plus the solve's own {name}_error where it has one",
                "units": "1",
            },
        )
    out = out.assign(new)
    for name in names:
        linked = str(out[name].attrs.get("ancillary_variables", "")).split()
        out[name].attrs["ancillary_variables"] = " ".join([*linked, f"{name}{MAP_ERROR_SUFFIX}", "solved"])
    out = _directional_map_error(derive_directional(out))
    refined = refined_names(ds, spec)
    worst = max((float(np.nanmax(maps[n])) for n in refined if np.any(np.isfinite(maps[n]))), default=float("nan"))
    out.attrs.update(
        sweep_solves=int(len(solved_tasks)),
        sweep_points_solved=int(solved.sum()),
        adaptive_points_not_interpolated=int(np.count_nonzero(unsolved & ~finite)),
        adaptive_rounds=int(rounds),
        adaptive_tolerance=float(spec.adaptive.default),
        adaptive_quantities=" ".join(refined),
        adaptive_max_map_error=worst,
        adaptive_met=int(
            all(not np.any(maps[n] > spec.adaptive.tolerance(n)) for n in refined)
            and not np.count_nonzero(unsolved & ~finite)
        ),
        adaptive_check_points=len(checks.points),
        adaptive_check_rounds=int(checks.rounds),
        adaptive_estimate_factor=float(checks.largest_factor),
        adaptive_conservative_subproblems=int(sum(checks.conservative)),
    )
    if spec.adaptive.max_solves is not None:
        out.attrs["adaptive_max_solves"] = int(spec.adaptive.max_solves)
    return xr.Dataset(out.data_vars, coords=out.coords, attrs=out.attrs)


def _directional_map_error(ds: Any) -> Any:
    """``ds`` with ``K_nn_map_error`` (and ``normalized_nn_map_error``) where it has K_nn: the
    bound ``dataset`` derives ``K_nn_error`` by, on the tensor's map errors."""

    if "K_nn" not in ds or not all(f"{n}{MAP_ERROR_SUFFIX}" in ds for n in TENSOR):
        return ds
    names = [*TENSOR, "K_zz", "K_nn", "normalized_nn"]
    tmp = ds[[n for n in names if n in ds]]
    tmp = tmp.assign({f"{n}_error": ds[f"{n}{MAP_ERROR_SUFFIX}"] for n in [*TENSOR, "K_zz"] if n in ds})
    order = ds.attrs.get("sweep_axes", " ".join(map(str, ds.dims))).split()
    derived = directional_errors(tmp, order)
    out = ds
    for name in DIRECTIONAL:
        if f"{name}_error" in derived and name in ds:
            error = f"{name}{MAP_ERROR_SUFFIX}"
            array = derived[f"{name}_error"]
            out = out.assign({error: array})
            out[error].attrs = {
                "long_name": f"estimated relative error of {name} in the adaptive map (from the tensor's map errors)",
                "units": "1",
            }
            linked = str(out[name].attrs.get("ancillary_variables", "")).split()
            out[name].attrs["ancillary_variables"] = " ".join([*linked, error, "solved"])
    return out
