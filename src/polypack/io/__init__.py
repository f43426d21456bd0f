"""File formats: ``write(path, packing)`` and ``read(path)`` choose the format by extension.

=========  ==========================  ==============  =====================================
format     extensions                  read back       opened by
=========  ==========================  ==============  =====================================
``gsd``    ``.gsd``                    yes (exact)     HOOMD-blue, OVITO, freud (primary)
``xyz``    ``.xyz``, ``.extxyz``       yes (exact)     OVITO, ASE
``lammps`` ``.data``, ``.lmp``         yes (exact)     LAMMPS ``read_data`` (atom_style sphere)
``vtp``    ``.vtp``                    yes (exact)     ParaView, OVITO, VTK
``csv``    ``.csv``                    yes (exact)     numpy, pandas, spreadsheets
=========  ==========================  ==============  =====================================

Bonded networks (particles plus bonds and per-bond/per-particle fields) go to ``.gsd``,
``.vtm`` (VTK multiblock) and LAMMPS ``.data`` through :mod:`polypack.io.bonds`
(``pp.mechanics.write_network`` builds the arrays from a ``BondNetwork``).

Every write is atomic (a temporary file in the same folder renamed onto the target), so
an interrupted write leaves the old file or none. Every file carries the provenance
record ``{"writer": "polypack", "version", "meta"}``; reading returns ``meta`` as written.
A truncated, empty or foreign file raises :class:`~polypack.FormatError` naming the file.

Examples
--------
>>> import polypack as pp
>>> pp.io.write("pack.gsd", pk)          # doctest: +SKIP
>>> pk2 = pp.io.read("pack.gsd")         # doctest: +SKIP
>>> pk2 == pk                             # doctest: +SKIP
True
"""

from __future__ import annotations

from importlib import import_module
from pathlib import Path

from ..errors import InvalidInputError
from ..packing import Packing
from .voxel import VoxelImage, voxelize, write_image  # voxel images of packs (issue 34)

__all__ = ["write", "read", "read_with_info", "FORMATS", "format_for", "voxelize", "write_image", "VoxelImage"]

# format name -> (module, extensions, readable)
FORMATS: dict[str, tuple[str, tuple[str, ...], bool]] = {
    "gsd": ("_gsd", (".gsd",), True),
    "xyz": ("_xyz", (".xyz", ".extxyz"), True),
    "lammps": ("_lammps", (".data", ".lmp"), True),
    "vtp": ("_vtp", (".vtp",), True),
    "csv": ("_csv", (".csv",), True),
}


def _allowed(readable_only: bool) -> str:
    return ", ".join(
        f"{name} ({'/'.join(exts)})" for name, (_, exts, readable) in FORMATS.items() if readable or not readable_only
    )


def format_for(path, format: str | None = None, reading: bool = False) -> str:
    """Name of the format used for ``path``: ``format`` if given, else from the extension.

    Raises
    ------
    InvalidInputError
        Unknown format name or extension (the message lists the allowed ones), or a
        write-only format when ``reading``.
    """
    if format is not None:
        name = str(format).lower().lstrip(".")
        if name not in FORMATS:
            raise InvalidInputError(f"format={format!r} is unknown; allowed: {_allowed(reading)}")
    else:
        ext = Path(path).suffix.lower()
        matches = [k for k, (_, exts, _) in FORMATS.items() if ext in exts]
        if not matches:
            raise InvalidInputError(
                f"cannot tell the file format of {str(path)!r} from its extension {ext or '(none)'!r}; "
                f"allowed: {_allowed(reading)} (or pass format=...)"
            )
        name = matches[0]
    if reading and not FORMATS[name][2]:
        raise InvalidInputError(f"format {name!r} is write-only; readable: {_allowed(True)}")
    return name


def _module(name: str):
    return import_module(f"{__name__}.{FORMATS[name][0]}")


def write(path, packing: Packing, format: str | None = None) -> None:
    """Write ``packing`` to ``path``, atomically, in the format given by the extension.

    Parameters
    ----------
    path : str or os.PathLike
        Target file; its folder is created if needed. An existing file is replaced only
        once the new one is completely written.
    packing : Packing
        The pack to write.
    format : {"gsd", "xyz", "lammps", "vtp", "csv"}, optional
        Overrides the extension.

    Raises
    ------
    InvalidInputError
        ``packing`` is not a Packing, or the format is unknown.
    """
    if not isinstance(packing, Packing):
        raise InvalidInputError(f"packing must be a polypack.Packing, got {type(packing).__name__}")
    _module(format_for(path, format)).write(path, packing)


def read_with_info(path, format: str | None = None, **options) -> tuple[Packing, dict]:
    """Read a packing and a dict describing the file.

    The dict holds ``format``, ``frames`` (number of frames in the file) and ``frame``
    (the index read, from 0), and for files written by polypack ``writer`` and
    ``version`` (the polypack version that wrote it).  ``options`` go to the format
    reader (GSD and XYZ: ``frame=-1``, the frame to read).
    """
    return _module(format_for(path, format, reading=True)).read_with_info(path, **options)


def read(path, format: str | None = None, **options) -> Packing:
    """Read a packing written by :func:`write` (or a compatible foreign file).

    Parameters
    ----------
    path : str or os.PathLike
        A ``.gsd``, ``.xyz``/``.extxyz``, ``.data``/``.lmp``, ``.vtp`` or ``.csv`` file.
    format : {"gsd", "xyz", "lammps", "vtp", "csv"}, optional
        Overrides the extension.
    **options
        Passed to the format reader; GSD and XYZ accept ``frame`` (default -1, the
        last; :func:`read_with_info` says which one was read).

    Returns
    -------
    Packing
        Bitwise equal to the packing written (positions, radii, box, species, meta),
        for meta made of JSON types.

    Raises
    ------
    FormatError
        The file is missing, empty, truncated, of another format or holds invalid values.
    InvalidInputError
        The extension or ``format`` is unknown.
    """
    return read_with_info(path, format, **options)[0]
