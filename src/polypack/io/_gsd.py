"""GSD (HOOMD schema), the primary polypack format; read by HOOMD-blue, OVITO, freud.

Layout of a file written by polypack (one frame, double precision)::

    configuration/box        [Lx, Ly, Lz, 0, 0, 0]  (float32 values, rounded up; see below)
    particles/N, position    (N, 3) float64 centred in [-L/2, L/2)
    particles/diameter       (N,) float64 = 2 * radii
    particles/types          "S0", "S1", ... ; particles/typeid = species
    log/polypack/provenance  one-line JSON {"writer", "version", "meta"} (an OVITO attribute)
    log/polypack/box         (3,) float64 exact box lengths
    log/polypack/volume_fraction, log/polypack/n_species   scalars for a quick look in OVITO
    log/polypack/periodic    (dim,) uint8 per-axis periodic flags (only when some axis has walls)

2D packs (disks) are written as HOOMD 2D frames: ``configuration/dimensions = 2``, box
``[Lx, Ly, 0, 0, 0, 0]``, positions with ``z = 0``, ``log/polypack/box`` of shape (2,).
HOOMD boxes are periodic on every axis; wall axes are recorded in ``log/polypack/periodic``.

Exactness. gsd stores ``configuration/box`` through float32, so the exact float64 box
lives in ``log/polypack/box``; the float32 box is rounded *up* so every centred
position still lies inside it. Centring uses ``y = x - L`` for ``x >= L/2`` and
``y = x`` otherwise: by Sterbenz's lemma ``x - L`` is exact for ``L/2 <= x < L``, so
the inverse ``x = y + L`` (``y < 0``) recovers ``x`` bit for bit, unlike the naive
``x - L/2`` which rounds for ``x < L/4``. Diameters ``2 r`` and radii ``d / 2`` are
exact too, so ``read(write(p)) == p`` holds bitwise.
"""

from __future__ import annotations

import numpy as np

from .._util import atomic_path
from ..packing import Packing
from ._common import build_packing, fail, parse_provenance, provenance_json, type_names



def centre(positions: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Exactly reversible map of ``[0, L)`` onto ``[-L/2, L/2)`` (see the module notes)."""
    return np.where(positions >= 0.5 * box, positions - box, positions)


def uncentre(positions: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Inverse of :func:`centre`: ``y + L`` for ``y < 0``, else ``y``."""
    return np.where(positions < 0.0, positions + box, positions)


def _box32_up(box: np.ndarray) -> np.ndarray:
    """Box lengths as float32 values no smaller than the float64 ones."""
    b32 = box.astype(np.float32)
    low = b32.astype(np.float64) < box
    b32[low] = np.nextafter(b32[low], np.float32(np.inf))
    return b32.astype(np.float64)


def make_frame(packing: Packing):
    """The one-frame ``gsd.hoomd.Frame`` polypack writes for ``packing`` (see the module notes)."""
    import gsd.hoomd

    box = packing.box
    dim = packing.dim
    frame = gsd.hoomd.Frame()
    flags = np.array(packing.periodic)
    pos = centre(packing.positions, box)  # also exact on wall axes, where 0 < x < L
    if dim == 2:
        frame.configuration.dimensions = 2
        frame.configuration.box = np.concatenate([_box32_up(box), np.zeros(4)])
        pos = np.column_stack([pos, np.zeros(packing.n)])
    else:
        frame.configuration.box = np.concatenate([_box32_up(box), np.zeros(3)])
    frame.particles.N = packing.n
    frame.particles.types = type_names(packing.n_species)
    frame.particles.position = pos.reshape(packing.n, 3)
    frame.particles.diameter = 2.0 * packing.radii
    frame.particles.typeid = packing.species.astype(np.uint32)
    frame.log["polypack/provenance"] = provenance_json(packing)
    frame.log["polypack/box"] = np.array(box, dtype=np.float64)
    frame.log["polypack/volume_fraction"] = np.array([packing.volume_fraction])
    frame.log["polypack/n_species"] = np.array([packing.n_species], dtype=np.int64)
    if not packing.fully_periodic:
        frame.log["polypack/periodic"] = flags.astype(np.uint8)
    return frame


def write_frame(path, frame) -> None:
    """Write one frame as a double-precision GSD file (atomically)."""
    import gsd.hoomd

    with atomic_path(path) as tmp:
        with gsd.hoomd.open(str(tmp), "w", precision="double") as traj:
            traj.append(frame)


def write(path, packing: Packing) -> None:
    """Write ``packing`` as a one-frame double-precision HOOMD GSD file (atomically)."""
    write_frame(path, make_frame(packing))


def read_with_info(path, frame: int = -1) -> tuple[Packing, dict]:
    """Read one frame (default: the last) of a GSD file; ``(packing, info)``.

    ``info`` holds ``writer``/``version`` from the provenance record (empty for files
    not written by polypack), ``format``, ``frames`` and ``frame`` (the index read,
    counted from 0).  Every per-particle array must have ``particles/N`` rows.
    """
    import gsd.hoomd

    try:
        with gsd.hoomd.open(str(path), "r") as traj:
            nframes = len(traj)
            if nframes == 0:
                raise fail(path, "GSD file contains no frames")
            if isinstance(frame, bool) or not isinstance(frame, (int, np.integer)) or not -nframes <= frame < nframes:
                raise fail(path, f"frame {frame} requested but the file has {nframes} frame(s)")
            snap = traj[frame]
            n = int(snap.particles.N)
            pos = np.asarray(snap.particles.position, dtype=np.float64)
            diam = np.asarray(snap.particles.diameter, dtype=np.float64)
            typeid = np.asarray(snap.particles.typeid)
            for name, arr, width in (("position", pos, 3), ("diameter", diam, 1), ("typeid", typeid, 1)):
                rows = arr.shape[0] if arr.ndim else 0
                if rows != n or arr.size != n * width:
                    raise fail(path, f"frame {frame % nframes}: particles/N is {n} but particles/{name} has "
                                     f"{rows} rows")
            pos = pos.reshape(n, 3)
            diam = diam.reshape(n)
            typeid = typeid.reshape(n).astype(np.int64)
            gbox = np.asarray(snap.configuration.box, dtype=np.float64).reshape(6)
            dim = int(snap.configuration.dimensions)
            log = dict(snap.log)
    except FileNotFoundError:
        raise fail(path, "no such file") from None
    except Exception as exc:  # gsd raises RuntimeError/ValueError/OSError on damaged files
        from ..errors import PolypackError

        if isinstance(exc, PolypackError):
            raise
        detail = str(exc).replace(f": {path}", "").strip() or type(exc).__name__
        raise fail(path, f"not a readable GSD file ({detail}; empty, truncated or another format?)") from None
    if np.any(gbox[3:] != 0):
        raise fail(path, f"triclinic box tilts {gbox[3:].tolist()}; only orthorhombic boxes are allowed")
    if dim not in (2, 3):
        raise fail(path, f"configuration/dimensions is {dim}; allowed are 2 and 3")
    if "polypack/box" in log:
        box = np.asarray(log["polypack/box"], dtype=np.float64).reshape(-1)
        if box.shape != (dim,):
            raise fail(path, f"log/polypack/box has shape {box.shape}, expected ({dim},)")
    else:
        box = gbox[:dim]
    if np.any(box <= 0):
        raise fail(path, f"box {box.tolist()} is not a {dim}-D box (lengths must be > 0)")
    if dim == 2:
        if np.any(pos[:, 2] != 0):
            raise fail(path, "a 2-D frame has particles with z != 0")
        pos = pos[:, :2]
    periodic = None
    if "polypack/periodic" in log:
        flags = np.asarray(log["polypack/periodic"]).reshape(-1)
        if flags.shape != (dim,):
            raise fail(path, f"log/polypack/periodic has shape {flags.shape}, expected ({dim},)")
        periodic = tuple(bool(f) for f in flags)
    meta, info = {}, {}
    if "polypack/provenance" in log:
        text = log["polypack/provenance"]
        if isinstance(text, np.ndarray):
            text = text.reshape(-1)[0] if text.dtype.kind in "UST" else text.tobytes().decode("utf-8", "replace")
        meta, info = parse_provenance(str(text), path)
    info.update(format="gsd", frames=nframes, frame=int(frame) % nframes)
    pk = build_packing(path, uncentre(pos, box), 0.5 * diam, box, species=typeid, meta=meta, periodic=periodic)
    return pk, info
