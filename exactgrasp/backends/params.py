"""Declared parameter constraints of backends and the one helper that checks them.

A backend declares, once, what each constructor parameter may be (``parameter_constraints``,
a dict of `Param`) and calls `validate_parameters` in its constructor; every refusal then reads
the same way: the backend, the parameter, the value given and what is allowed.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from exactgrasp.errors import BackendError

__all__ = ["Interval", "Options", "Param", "describe", "satisfies", "validate_parameters"]

CLOSED = ("both", "left", "right", "neither")


def _number(x: float) -> str:
    """A bound as written in messages: ``2``, ``0.05``, ``10,000,000``."""
    if isinstance(x, numbers.Integral):
        return f"{x:,}" if abs(x) >= 10_000 else str(x)
    return f"{x:g}"


class Interval:
    """Numbers of one kind between two bounds.

    Parameters
    ----------
    kind : {int, float, numbers.Integral, numbers.Real}
        Integers only, or any real number (integers included). Booleans are never numbers
        here, and a real number must be finite.
    lo, hi : float or None
        Bounds; None leaves that side unbounded.
    closed : {"both", "left", "right", "neither"}
        Which bounds belong to the interval.
    """

    def __init__(self, kind: type, lo: float | None, hi: float | None, closed: str = "both"):
        if kind in (int, numbers.Integral):
            self.kind: type = numbers.Integral
        elif kind in (float, numbers.Real):
            self.kind = numbers.Real
        else:
            raise TypeError(f"Interval kind must be int or float, got {kind!r}.")
        if closed not in CLOSED:
            raise ValueError(f"closed must be one of {CLOSED}, got {closed!r}.")
        if lo is not None and hi is not None and hi < lo:
            raise ValueError(f"Interval bounds out of order: {lo} > {hi}.")
        self.lo, self.hi, self.closed = lo, hi, closed

    def __call__(self, value: Any) -> bool:
        if isinstance(value, bool) or not isinstance(value, self.kind):
            return False
        if not math.isfinite(value):
            return False
        if self.lo is not None:
            if value < self.lo or (value == self.lo and self.closed in ("right", "neither")):
                return False
        if self.hi is not None:
            if value > self.hi or (value == self.hi and self.closed in ("left", "neither")):
                return False
        return True

    def cast(self, value: Any) -> int | float:
        """The value as a plain Python int or float (numpy scalars are not JSON)."""
        return int(value) if self.kind is numbers.Integral else float(value)

    def __str__(self) -> str:
        integer = self.kind is numbers.Integral
        noun = "integer" if integer else "number"
        lo_in = self.closed in ("both", "left")
        hi_in = self.closed in ("both", "right")
        if self.lo is not None and self.hi is not None:
            lo, hi = _number(self.lo), _number(self.hi)
            if lo_in and hi_in:
                return f"{'an' if integer else 'a'} {noun} from {lo} to {hi}"
            brackets = ("[" if lo_in else "(", "]" if hi_in else ")")
            return f"{'an' if integer else 'a'} {noun} in {brackets[0]}{lo}, {hi}{brackets[1]}"
        finite = "" if integer else ", finite"
        if self.lo == 0 and self.hi is None:
            sign = "non-negative" if lo_in else "positive"
            return f"a {sign}{finite} {noun}"
        if integer and self.lo == 1 and lo_in and self.hi is None:
            return "a positive integer"
        article = "an" if integer else "a finite"
        if self.lo is not None:
            return f"{article} {noun} {'>=' if lo_in else '>'} {_number(self.lo)}"
        if self.hi is not None:
            return f"{article} {noun} {'<=' if hi_in else '<'} {_number(self.hi)}"
        return f"{article} {noun}"


#: What `Options.listed` gives for a value that is not listed.
_UNLISTED = object()


class Options:
    """One of a few listed values (compared by equality; a bool never stands for 0 or 1).

    Parameters
    ----------
    values : iterable
        The allowed values, in the order messages list them (a set is listed sorted).
    """

    def __init__(self, values: Iterable[Any]):
        if isinstance(values, set | frozenset):
            values = sorted(values, key=repr)
        self.values = tuple(values)

    def __call__(self, value: Any) -> bool:
        return self.listed(value) is not _UNLISTED

    def listed(self, value: Any) -> Any:
        """The listed option equal to ``value`` (so a numpy scalar comes back as the plain value
        listed), or ``_UNLISTED``."""
        flag = isinstance(value, bool | np.bool_)  # numpy's bools are no ints either
        for option in self.values:
            if flag != isinstance(option, bool | np.bool_):
                continue
            if isinstance(value, str) != isinstance(option, str):
                continue
            try:
                if value == option:
                    return option
            except (TypeError, ValueError):  # an array compares element-wise
                continue
        return _UNLISTED

    def alternatives(self) -> list[str]:
        """Each option as messages write it."""
        return [repr(v) for v in self.values]


class Param:
    """What one parameter may be: any of several constraints.

    Parameters
    ----------
    *allowed
        Constraints, any of which admits a value: an `Interval`, an `Options`, ``None`` (the
        value None), ``"boolean"`` (True or False, numpy's too), the builtin ``callable`` (any
        callable), or a type (an instance of it).
    hint : str
        What the parameter means, added to refusals (``"voxels along the hand's longest side"``).
    """

    def __init__(self, *allowed: Any, hint: str = ""):
        if not allowed:
            raise ValueError("a Param needs at least one constraint.")
        for constraint in allowed:
            if not (
                constraint is None
                or constraint is callable
                or constraint == "boolean"
                or isinstance(constraint, Interval | Options | type)
            ):
                raise TypeError(f"unknown parameter constraint {constraint!r}.")
        self.allowed = allowed
        self.hint = hint

    def admits(self, value: Any) -> Any:
        """The first constraint that admits ``value``, or `NotImplemented` when none does."""
        for constraint in self.allowed:
            if satisfies(constraint, value):
                return constraint
        return NotImplemented


def satisfies(constraint: Any, value: Any) -> bool:
    """Whether ``value`` meets one constraint (see `Param` for the kinds)."""
    if constraint is None:
        return value is None
    if constraint is callable:
        return callable(value)
    if isinstance(constraint, str):
        return isinstance(value, bool | np.bool_)
    if isinstance(constraint, type):
        return isinstance(value, constraint)
    return constraint(value)


def _alternatives(constraint: Any) -> list[str]:
    if constraint is None:
        return ["None"]
    if constraint is callable:
        return ["a callable"]
    if isinstance(constraint, str):
        return ["True or False"]
    if isinstance(constraint, type):
        return [f"a {constraint.__name__}"]
    if isinstance(constraint, Options):
        return constraint.alternatives()
    return [str(constraint)]


def describe(param: Param) -> str:
    """What a parameter may be, in words: ``"None, a positive integer or 'none'"``."""
    words = [w for constraint in param.allowed for w in _alternatives(constraint)]
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} or {words[-1]}"


def validate_parameters(
    constraints: Mapping[str, Param], params: Mapping[str, Any], owner: str
) -> dict[str, Any]:
    """Check parameters against their declared constraints.

    Parameters
    ----------
    constraints : mapping of str to Param
        The owner's declared table (``parameter_constraints``).
    params : mapping of str to object
        Values given; names missing here are not checked, names missing from `constraints`
        are refused.
    owner : str
        Who takes the parameters, for messages (``"VoxelBackend"``).

    Returns
    -------
    dict
        The same parameters, numbers as plain Python ints and floats.

    Raises
    ------
    BackendError
        For an unknown name, or a value no constraint of its `Param` admits; the message names
        the owner, the parameter, the value and what is allowed.
    """
    unknown = sorted(set(params) - set(constraints))
    if unknown:
        raise BackendError(
            f"{owner}: unknown parameters {unknown}; it takes {', '.join(constraints)}."
        )
    out: dict[str, Any] = {}
    for name, value in params.items():
        param = constraints[name]
        match = param.admits(value)
        if match is NotImplemented:
            hint = f" ({param.hint})" if param.hint else ""
            raise BackendError(f"{owner}: {name} must be {describe(param)}, got {value!r}{hint}.")
        if isinstance(match, Interval):
            value = match.cast(value)
        elif isinstance(match, Options):
            value = match.listed(value)
        elif match == "boolean":
            value = bool(value)
        out[name] = value
    return out
