"""Exceptions shared by every layer: bad input and failed numerics are never silent."""

from __future__ import annotations

import difflib
import enum
import math
from collections.abc import Iterable
from typing import Any


class Front(enum.Enum):
    """The front end that shows a message: each spells an option its own way (``Option``)."""

    COMMAND_LINE = "command line"
    PYTHON = "python"


class Option(str):
    """An option of a front end that a message names (``hpcontact.sweep.run.options`` declares
    the run's): as text (``str``), its command-line flag (``--resume``), so that it reads and
    compares as the command line's word wherever a field name is read; its ``keyword`` is how
    Python names it (``resume``; None: the command line's alone, spelled by its flag
    everywhere). As advice in a message (``advised``), Python passes a ``switch`` (on or off) as
    ``resume=True`` and a value as ``output=``; as the field of an ``InputError`` (``named``), it
    is the keyword."""

    keyword: str | None
    switch: bool

    def __new__(cls, flag: str, keyword: str | None, switch: bool) -> Option:
        option = super().__new__(cls, flag)
        option.keyword, option.switch = keyword, switch
        return option

    def __getnewargs__(self) -> tuple[Any, ...]:  # type: ignore[override]  # pickled across ranks
        return (str(self), self.keyword, self.switch)

    @property
    def flag(self) -> str:
        """The command line's word: ``--resume``."""
        return str.__str__(self)

    def advised(self, front: Front) -> str:
        """The option as advice in ``front``'s words: ``--resume``; ``resume=True``, ``output=``."""
        if front is Front.COMMAND_LINE or self.keyword is None:
            return self.flag
        return f"{self.keyword}=True" if self.switch else f"{self.keyword}="

    def named(self, front: Front) -> str:
        """The option as the field of an error in ``front``'s words: ``--mem-per-rank``; ``mem_per_rank``."""
        return self.flag if front is Front.COMMAND_LINE or self.keyword is None else self.keyword


class Message(str):
    """Text that names options, each kept as its ``Option`` and spelled by the front end that
    shows it (``render``): ``Message("pass ", RESUME, " to continue")`` is "pass --resume to
    continue" on the command line and "pass resume=True to continue" to a Python caller. As
    text (``str``) it is the command line's wording, so that code reading a message as text
    reads what it read before; joined with ``+`` to text or another message it stays a message
    (other ``str`` operations give the command line's plain text)."""

    parts: tuple[str, ...]

    def __new__(cls, *parts: str) -> Message:
        flat = tuple(q for p in parts for q in (p.parts if isinstance(p, Message) else (p,)) if q != "")
        message = super().__new__(
            cls, "".join(p.advised(Front.COMMAND_LINE) if isinstance(p, Option) else p for p in flat)
        )
        message.parts = flat
        return message

    def __getnewargs__(self) -> tuple[str, ...]:  # type: ignore[override]  # pickled across ranks
        return self.parts

    def render(self, front: Front) -> str:
        """The text as ``front`` shows it: each option ``Option.advised`` there."""
        return "".join(p.advised(front) if isinstance(p, Option) else p for p in self.parts)

    def options(self) -> tuple[Option, ...]:
        """The options the message names, in order."""
        return tuple(p for p in self.parts if isinstance(p, Option))

    def __repr__(self) -> str:
        return f"Message{self.parts!r}"

    def __add__(self, other: str) -> Message:  # type: ignore[override]
        return Message(self, other)

    def __radd__(self, other: str) -> Message:
        return Message(other, self)


def rendered(text: str | Option | Message, front: Front) -> str:
    """``text`` as ``front`` shows it: a message rendered, an option as advice, plain text as is."""
    if isinstance(text, Message):
        return text.render(front)
    return text.advised(front) if isinstance(text, Option) else text


class InputError(ValueError):
    """A field of a scene, a spec or a command line is outside its allowed range.

    The message names the field, the value and what is allowed, in one line; the command line
    prints it and exits with status 2. A field that is a front end's option (``Option``) and an
    ``allowed`` that names options (``Message``) are kept as such: ``str()`` words them as the
    command line does, ``worded`` as another front end does.
    """

    def __init__(self, field: str | Option, allowed: str | Message, value: Any = None) -> None:
        self.field = field
        self.allowed = allowed
        self.value = value
        super().__init__(self.worded(Front.COMMAND_LINE))

    def _words(self, front: Front) -> tuple[str, str]:
        """The field and what is allowed as ``front`` words them."""
        field = self.field.named(front) if isinstance(self.field, Option) else self.field
        return field, rendered(self.allowed, front)

    def worded(self, front: Front) -> str:
        """The one line of this error as ``front`` shows it: ``--mem-per-rank = ...`` on the
        command line (``str()``), ``mem_per_rank = ...`` to a Python caller."""
        field, allowed = self._words(front)
        shown = "" if self.value is None else f" = {self.value!r}"
        return f"{field}{shown}: {allowed}"

    def for_front(self, front: Front) -> InputError:
        """The same error (type, field, value) in ``front``'s words, as plain text."""
        return InputError(*self._words(front), self.value)

    def names_option(self) -> bool:
        """Whether the error names a front end's option (its field, or in what is allowed)."""
        return isinstance(self.field, Option) or isinstance(self.allowed, Message) and bool(self.allowed.options())


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
