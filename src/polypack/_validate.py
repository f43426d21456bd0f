"""One set of value checks for the Python API, the study schema and the CLI.

A check takes a value and returns it normalised (``int`` -> ``float`` for numbers, a
comma-separated string -> a list ...) or raises :class:`Bad` with the reason; the caller
adds where the value came from (``protocol.volume_fraction = 1.2: must be in (0, 1)`` in a
study file, ``volume_fraction=1.2: must be in (0, 1)`` in Python, ``--volume-fraction`` on
the command line). :func:`check` does that for keyword arguments and raises
:class:`~polypack.InvalidInputError`.

Every check has a ``describe`` attribute (``"number > 0"``, ``"integer >= 1"``, one of
the choices ...) used in generated docs and CLI help. This module has no heavy imports.
"""

from __future__ import annotations

import math

from .errors import InvalidInputError

__all__ = [
    "Bad",
    "check",
    "fmt",
    "type_name",
    "number",
    "integer",
    "positive",
    "non_negative",
    "fraction_open",
    "fraction_closed",
    "size_ratio",
    "int_min",
    "string",
    "boolean",
    "choice",
    "volume_fraction",
    "positive_or_list",
    "number_or_list",
    "number_list",
    "schedule",
    "formats",
    "dimension",
    "optional",
    "FORMATS",
]


class Bad(ValueError):
    """Raised by a check with the reason; the caller adds the key path or argument name."""


def type_name(value) -> str:
    return {bool: "boolean", int: "integer", float: "float", str: "string", list: "array", dict: "table"}.get(
        type(value), type(value).__name__
    )


def fmt(value) -> str:
    """TOML-ish text of a value for messages (strings in double quotes)."""
    if isinstance(value, str):
        return repr(value).replace("'", '"')
    return repr(value)


def _describe(text):
    def deco(f):
        f.describe = text
        return f

    return deco


def check(name: str, value, validator, *, sep: str = "="):
    """``validator(value)``, or an :class:`InvalidInputError` ``"{name}={value!r}: {reason}"``."""
    try:
        return validator(value)
    except Bad as exc:
        shown = fmt(value) if sep != "=" else repr(value)
        raise InvalidInputError(f"{name}{sep}{shown}: {exc}") from None


@_describe("number")
def number(v):
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        try:  # numpy scalars
            import numbers

            if isinstance(v, numbers.Real) and not isinstance(v, bool):
                v = float(v)
            else:
                raise TypeError
        except TypeError:
            raise Bad(f"expected a number, got {type_name(v)}") from None
    v = float(v)
    if not math.isfinite(v):
        raise Bad("must be finite")
    return v


@_describe("integer")
def integer(v):
    if isinstance(v, bool) or not isinstance(v, int):
        if isinstance(v, float) and v.is_integer():
            return int(v)
        import numbers

        if isinstance(v, numbers.Integral) and not isinstance(v, bool):
            return int(v)
        raise Bad(f"expected an integer, got {type_name(v)}")
    return v


@_describe("number > 0")
def positive(v):
    v = number(v)
    if not v > 0:
        raise Bad("must be > 0")
    return v


@_describe("number >= 0")
def non_negative(v):
    v = number(v)
    if v < 0:
        raise Bad("must be >= 0")
    return v


@_describe("number > 0 or inf")
def positive_or_inf(v):
    if isinstance(v, (int, float)) and not isinstance(v, bool) and v == math.inf:
        return float(v)
    return positive(v)


@_describe("number in (0, 1)")
def fraction_open(v):
    v = number(v)
    if not 0 < v < 1:
        raise Bad("must be in (0, 1)")
    return v


@_describe("number in [0, 1]")
def fraction_closed(v):
    v = number(v)
    if not 0 <= v <= 1:
        raise Bad("must be in [0, 1]")
    return v


@_describe("number in (0, 1] (λ = a2/a1)")
def size_ratio(v):
    v = number(v)
    if not 0 < v <= 1:
        raise Bad("must be in (0, 1] (λ = a2/a1)")
    return v


def between(lo, hi, *, lo_open=True, hi_open=False, why=""):
    """Check for a number in the interval from ``lo`` to ``hi`` (open or closed ends); ``why`` is
    appended to the reason (``"VEM reaches (0, 0.6]"``)."""
    text = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"

    def check_between(v):
        v = number(v)
        if (v <= lo if lo_open else v < lo) or (v >= hi if hi_open else v > hi):
            raise Bad(f"must be in {text}" + (f" ({why})" if why else ""))
        return v

    check_between.describe = f"number in {text}"
    return check_between


def int_min(lo):
    """Check for an integer ``>= lo``."""

    def check_int(v):
        v = integer(v)
        if v < lo:
            raise Bad(f"must be an integer >= {lo}")
        return v

    check_int.describe = f"integer >= {lo}"
    check_int.lower = lo
    return check_int


@_describe("string")
def string(v):
    if not isinstance(v, str):
        raise Bad(f"expected a string, got {type_name(v)}")
    return v


@_describe("boolean")
def boolean(v):
    if not isinstance(v, bool):
        raise Bad(f"expected true or false, got {type_name(v)}")
    return v


def choice(*allowed):
    """Check for one of the strings ``allowed``."""

    def check_choice(v):
        if not isinstance(v, str) or v not in allowed:
            raise Bad(f"allowed: {', '.join(fmt(a) for a in allowed)}")
        return v

    check_choice.describe = "one of " + ", ".join(fmt(a) for a in allowed)
    check_choice.choices = tuple(allowed)
    return check_choice


@_describe('number in (0, 1) or "jammed"')
def volume_fraction(v):
    if isinstance(v, str):
        if v != "jammed":
            raise Bad('allowed: a number in (0, 1) or "jammed"')
        return v
    return fraction_open(v)


def _split(v):
    if isinstance(v, str):
        return [x for x in v.replace(";", ",").split(",") if x.strip()]
    return v


@_describe("number > 0 or array of numbers > 0")
def positive_or_list(v):
    if isinstance(v, list):
        if not v:
            raise Bad("must not be empty")
        return [positive(x) for x in v]
    return positive(v)


def number_or_list(item):
    """A number, or an array (or comma-separated text) of numbers, each passing ``item``."""

    def check_nl(v):
        v = _split(v)
        if isinstance(v, (list, tuple)):
            if not v:
                raise Bad("must not be empty")
            try:
                vals = [item(float(x) if isinstance(x, str) else x) for x in v]
            except ValueError as exc:
                if isinstance(exc, Bad):
                    raise
                raise Bad("expected a number or a comma-separated list of numbers") from None
            return vals[0] if len(vals) == 1 else vals
        return item(v)

    check_nl.describe = f"{item.describe} (or an array of them)"
    return check_nl


def number_list(item):
    """An array (or comma-separated text) of numbers, each passing ``item``."""

    def check_list(v):
        v = _split(v)
        if not isinstance(v, (list, tuple)):
            v = [v]
        if not v:
            raise Bad("must not be empty")
        try:
            return [item(float(x) if isinstance(x, str) else x) for x in v]
        except ValueError as exc:
            if isinstance(exc, Bad):
                raise
            raise Bad("expected a comma-separated list of numbers") from None

    check_list.describe = f"array of {item.describe}"
    return check_list


@_describe("increasing array of volume fractions in (0, 1)")
def schedule(v):
    if not isinstance(v, (list, tuple)):
        raise Bad(f"expected an array of volume fractions, got {type_name(v)}")
    out = [fraction_open(x) for x in v]
    if any(b <= a for a, b in zip(out, out[1:])):
        raise Bad("volume fractions must increase")
    return out


FORMATS = ("gsd", "xyz", "data", "vtp", "csv")


@_describe("array of " + ", ".join(fmt(a) for a in FORMATS))
def formats(v):
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise Bad("expected an array of strings")
    bad = [x for x in v if x not in FORMATS]
    if bad:
        raise Bad(f"unknown format {fmt(bad[0])}; allowed: {', '.join(fmt(a) for a in FORMATS)}")
    return ["gsd"] + [x for x in dict.fromkeys(v) if x != "gsd"]


@_describe("2 (disks) or 3 (spheres)")
def dimension(v):
    v = integer(v)
    if v not in (2, 3):
        raise Bad("allowed: 2 (disks) or 3 (spheres)")
    return v


def optional(inner):
    """``None`` passes through; anything else goes to ``inner``."""

    def check_opt(v):
        return None if v is None else inner(v)

    check_opt.describe = f"{getattr(inner, 'describe', 'value')} or None"
    return check_opt
