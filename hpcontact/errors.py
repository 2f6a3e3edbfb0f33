"""Exceptions shared by every layer: bad input and failed numerics are never silent."""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from typing import Any


class InputError(ValueError):
    """A field of a scene, a spec or a command line is outside its allowed range.

    The message names the field, the value and what is allowed, in one line; the command line
    prints it and exits with status 2.
    """

    def __init__(self, field: str, allowed: str, value: Any = None) -> None:
        self.field = field
        self.allowed = allowed
        self.value = value
        shown = "" if value is None else f" = {value!r}"
        super().__init__(f"{field}{shown}: {allowed}")


def unused_field(field: str, value: Any, setting: str, setting_value: Any, why: str) -> InputError:
    """The one message of a field given for a scene that does not read it (never silently
    ignored): ``nu = 0.1: not used with material = 'Cu' (its elastic constants fix the Poisson
    ratio); leave nu out``. ``setting`` is the field whose value ``setting_value`` makes ``field``
    unused, ``why`` says why."""
    return InputError(field, f"not used with {setting} = {setting_value!r} ({why}); leave {field} out", value)


def did_you_mean(word: Any, choices: Iterable[str], quote: bool = False) -> str:
    """``"; did you mean X?"`` with the name of ``choices`` closest to an unknown ``word``
    (difflib, ratio >= 0.6; else one that differs only in case), ``""`` when none is close or
    the closest is ``word`` itself; ``quote``: X as Python shows a string (``'aspect'``)."""
    names = list(choices)
    close = difflib.get_close_matches(str(word), names, n=1, cutoff=0.6) or [
        c for c in names if c.lower() == str(word).lower()
    ]
    if not close or close[0] == word:
        return ""
    return f"; did you mean {close[0]!r}?" if quote else f"; did you mean {close[0]}?"


class ConvergenceError(RuntimeError):
    """An iterative solver stopped before reaching its tolerance (iterations and residual kept)."""

    def __init__(self, message: str, iterations: int, residual: float) -> None:
        self.iterations = iterations
        self.residual = residual
        super().__init__(f"{message} (iterations={iterations}, relative residual={residual:.3e})")


class AccuracyWarning(UserWarning):
    """A solve without ``n`` or ``accuracy`` (``hpcontact.solve``, ``hpcontact solve``) missed its
    default accuracy (``hpcontact.accuracy.DEFAULT_ACCURACY``): the record is returned with
    ``accuracy_met`` False, and this warning names the requested and the estimated error and
    what stopped the refinement. The command line prints it as one line on stderr and exits 1.
    An ``accuracy`` the caller asked for raises ``hpcontact.accuracy.AccuracyNotMet`` instead."""


def finite_number(field: str, value: Any, allowed: str) -> float:
    """``value`` as a finite float, else ``InputError(field, allowed, value)`` (bools refused)."""
    if isinstance(value, bool):
        raise InputError(field, allowed, value)
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(field, allowed, value) from None
    if not math.isfinite(number):
        raise InputError(field, allowed, value)
    return number


def integer(field: str, value: Any, low: int, allowed: str, high: float = math.inf) -> int:
    """``value`` as an integer in [low, high], else ``InputError(field, allowed, value)``."""
    number = finite_number(field, value, allowed)
    if number != int(number) or not low <= number <= high:
        raise InputError(field, allowed, value)
    return int(number)
