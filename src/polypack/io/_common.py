"""Helpers shared by the file-format modules of :mod:`polypack.io`.

Every format stores the same three things: the spheres (positions, radii, species),
the periodic box, and a provenance record ``{"writer": "polypack", "version": ...,
"meta": packing.meta}`` serialised as one line of JSON. Floats are written with 17
the shortest decimal that reads back as the same float64 (Python's ``repr``), so text
formats round-trip exactly.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import FormatError, InvalidInputError
from ..packing import Packing

FLOAT = "%r"  # shortest text that reads back as the same float64 (use on Python floats)


def num(value) -> str:
    """Shortest decimal text of a float that reads back bit for bit."""
    return repr(float(value))


# ------------------------------------------------------------------ errors
def fail(path, what: str) -> FormatError:
    """A :class:`~polypack.FormatError` naming the file and what is wrong with it."""
    return FormatError(f"{path}: {what}")


# -------------------------------------------------------------- provenance
def _json_default(obj):
    """JSON fallback for numpy scalars/arrays, paths and sets found in ``meta``."""
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (set, frozenset)):
        return sorted(obj, key=repr)
    if isinstance(obj, Path):
        return str(obj)
    return repr(obj)


def provenance_json(packing: Packing) -> str:
    """One-line JSON ``{"writer", "version", "meta"}`` stored in every file polypack writes.

    ``meta`` made of JSON types (dict with str keys, list, str, int, float, bool, None)
    round-trips exactly (floats via ``repr``, including nan and inf). numpy values become
    plain numbers or lists, tuples become lists, anything else its ``repr`` string.
    """
    from .._version import __version__

    record = {"writer": "polypack", "version": __version__, "meta": packing.meta}
    return json.dumps(record, default=_json_default, allow_nan=True, ensure_ascii=True)


def parse_provenance(text: str, path) -> tuple[dict, dict]:
    """Inverse of :func:`provenance_json`: ``(meta, info)`` where info has ``writer``, ``version``."""
    try:
        record = json.loads(text)
    except (json.JSONDecodeError, TypeError) as exc:
        raise fail(path, f"provenance record is not valid JSON ({exc})") from None
    if not isinstance(record, dict) or not isinstance(record.get("meta", {}), dict):
        raise fail(path, "provenance record must be a JSON object with a 'meta' object")
    info = {k: v for k, v in record.items() if k != "meta"}
    return dict(record.get("meta", {})), info


# ------------------------------------------------------------------ species
def type_names(n_species: int) -> list[str]:
    """Particle type names ``S0, S1, ...`` for species ``0..K-1`` (at least one name)."""
    return [f"S{k}" for k in range(max(int(n_species), 1))]


# ----------------------------------------------------------------- reading
def read_text(path) -> str:
    """Whole text file; FormatError if it is missing, empty, binary or lacks its final newline.

    Every text file polypack writes ends with a newline, so a missing one means the
    file was cut short (a half-written last number could otherwise parse silently).
    """
    try:
        raw = Path(path).read_bytes()
    except FileNotFoundError:
        raise fail(path, "no such file") from None
    except OSError as exc:
        raise fail(path, f"cannot be read ({exc.strerror or exc})") from None
    if not raw.strip():
        raise fail(path, "file is empty")
    if b"\0" in raw:
        raise fail(path, "binary data where a text file was expected")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise fail(path, f"not a UTF-8 text file (bad byte at offset {exc.start})") from None
    if not text.endswith("\n"):
        raise fail(path, "truncated: the last line is incomplete (no final newline)")
    return text


def parse_table(lines, ncols, path, first_line: int, sep=None) -> np.ndarray:
    """Parse rows of ``ncols`` numbers into a float64 array (exact decimal parsing).

    ``first_line`` is the 1-based file line number of ``lines[0]``, used in errors.
    """
    out = np.empty((len(lines), ncols), dtype=np.float64)
    for k, line in enumerate(lines):
        tok = line.split(sep)
        if len(tok) != ncols:
            raise fail(path, f"line {first_line + k} has {len(tok)} fields, expected {ncols}")
        try:
            out[k] = [float(t) for t in tok]
        except ValueError:
            raise fail(path, f"line {first_line + k} has a non-numeric field: {line.strip()[:60]!r}") from None
    return out


def as_int_column(values: np.ndarray, what: str, path) -> np.ndarray:
    """Integer column from parsed floats; FormatError if any entry is not an integer."""
    bad = ~np.isfinite(values) | (values != np.round(values))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise fail(path, f"{what} of row {k + 1} is {values[k]!r}; must be an integer")
    return values.astype(np.int64)


def parse_int(token: str, what: str, path) -> int:
    """One integer field of a header; FormatError naming ``what`` otherwise."""
    try:
        return int(token)
    except (TypeError, ValueError):
        raise fail(path, f"{what} is {token[:40]!r}; expected an integer") from None


def build_packing(path, positions, radii, box, species=None, meta=None, periodic=None) -> Packing:
    """A Packing from file contents; invalid contents become a FormatError naming the file."""
    try:
        return Packing(positions, radii, box, species=species, meta=meta, periodic=periodic)
    except InvalidInputError as exc:
        raise fail(path, f"invalid contents: {exc}") from None


def pbc_text(packing: Packing) -> str:
    """Extended-XYZ style flags ``"T T F"``: one per axis of 3D space (2D packs: third ``F``)."""
    flags = list(packing.periodic) + [False] * (3 - packing.dim)
    return " ".join("T" if f else "F" for f in flags)


def parse_pbc(text: str, path) -> list[bool]:
    """Inverse of :func:`pbc_text` (also accepts ``True``/``False``/``1``/``0``)."""
    out = []
    for tok in str(text).split():
        t = tok.upper()
        if t in ("T", "TRUE", "1"):
            out.append(True)
        elif t in ("F", "FALSE", "0"):
            out.append(False)
        else:
            raise fail(path, f"periodic flags {text!r}: each must be T or F")
    return out


def format_rows(columns, formats, sep=" ") -> str:
    """Text rows from equal-length columns; ``formats`` is one %-format per column.

    Returns ``""`` for no rows, else lines each ending in a newline.
    """
    n = len(columns[0]) if columns else 0
    if n == 0:
        return ""
    fmt = sep.join(formats) + "\n"
    cols = [c.tolist() for c in columns]
    return "".join(fmt % row for row in zip(*cols))
