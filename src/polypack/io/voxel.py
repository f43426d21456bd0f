"""Voxel images of packs: :func:`voxelize` and :func:`write_image` (``.npy``, ``.tif``, ``.vti``).

A pack becomes the microstructure of a composite (§4 of 000_2cedc098acbd866b.txt: spheres of
each species are inclusions in a matrix) sampled on a regular grid that tiles the box
exactly: ``n_a`` voxels of size ``h_a = L_a / n_a`` along axis ``a``. Voxel ``(i, j, k)``
(array index order ``x, y, z``) takes the label ``1 + species`` of the sphere holding its
centre, 0 for the matrix. Periodic axes wrap; a 2D pack of disks gives a 2D image.

The label image carries a volume-fraction error of a few per cent at a few voxels per
radius. :class:`VoxelImage` reports the exact phase volume fractions (sphere volumes
over the box volume) beside the voxel fractions, and with ``subsamples = s`` the
per-voxel inclusion fraction of every boundary voxel from an ``s^dim`` sub-voxel grid
(a composite-voxel field; Kabel, Merkert & Schneider, CMAME 294, 168 (2015)).

Writers (all atomic: a temporary file in the target folder, renamed when complete):

=========  ==============================================================================
``.npy``   ``numpy.save`` of the label array (``numpy.load`` gives it back exactly)
``.tif``   a multi-page uncompressed TIFF stack (one page per z layer, page rows along y,
           columns along x; 8-bit, or 16-bit above 255 labels) written through Pillow,
           which matplotlib already requires; ImageJ/Fiji, tifffile and Pillow read it
``.vti``   VTK XML ImageData, cell data ``phase`` (the labels) and, when sampled,
           ``inclusion_fraction``; base64 binary, Origin 0, Spacing ``h``; ParaView reads it
=========  ==============================================================================
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._util import atomic_open, atomic_path
from ..errors import InvalidInputError
from ..packing import Packing

__all__ = ["VoxelImage", "voxelize", "write_image", "IMAGE_FORMATS", "voxel_shape"]

#: extension -> writer name
IMAGE_FORMATS = {".npy": "npy", ".tif": "tiff", ".tiff": "tiff", ".vti": "vti"}


@dataclass(frozen=True)
class VoxelImage:
    """A periodic phase-label image of a pack.

    Attributes
    ----------
    labels : ndarray of uint8 or uint16, shape ``(n_x, n_y[, n_z])``
        0 for the matrix, ``1 + s`` for species ``s``.
    spacing : ndarray, shape ``(dim,)``
        Voxel size ``h_a = L_a / n_a`` per axis (the pack's length unit).
    box : ndarray, shape ``(dim,)``
        Box lengths.
    exact_fractions : ndarray, shape ``(n_species + 1,)``
        Volume fraction of each phase from the sphere volumes (matrix first).
    voxel_fractions : ndarray, shape ``(n_species + 1,)``
        Fraction of the voxels carrying each label.
    fraction : ndarray of float32 or None
        Inclusion volume fraction of every voxel from sub-voxel sampling (``subsamples > 0``).
    meta : dict
        ``resolution`` (voxels per axis), ``subsamples``, ``periodic``.
    """

    labels: np.ndarray
    spacing: np.ndarray
    box: np.ndarray
    exact_fractions: np.ndarray
    voxel_fractions: np.ndarray
    fraction: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    @property
    def shape(self):
        return self.labels.shape

    @property
    def dim(self):
        return self.labels.ndim

    @property
    def n_phases(self):
        return len(self.exact_fractions)

    @property
    def inclusion_fraction(self) -> float:
        """Exact inclusion volume fraction (all species)."""
        return float(np.sum(self.exact_fractions[1:]))

    @property
    def voxel_inclusion_fraction(self) -> float:
        return float(np.sum(self.voxel_fractions[1:]))

    @property
    def subvoxel_inclusion_fraction(self) -> float | None:
        """Inclusion fraction of the composite-voxel field (``None`` without sub-sampling)."""
        return None if self.fraction is None else float(np.mean(self.fraction, dtype=np.float64))

    def to_dict(self):
        return {"shape": list(self.shape), "spacing": self.spacing.tolist(), "box": self.box.tolist(),
                "exact_fractions": self.exact_fractions.tolist(), "voxel_fractions": self.voxel_fractions.tolist(),
                "subvoxel_inclusion_fraction": self.subvoxel_inclusion_fraction}


def voxel_shape(box, resolution):
    """Voxels per axis: ``resolution`` along the longest box axis, the others in proportion.

    ``resolution`` may also be a sequence (one count per axis). Every axis gets at least 1.
    """
    box = np.asarray(box, dtype=np.float64)
    if np.ndim(resolution) == 0:
        try:
            r = int(resolution)
        except (TypeError, ValueError):
            raise InvalidInputError(f"resolution={resolution!r} must be an integer >= 2 (voxels along the longest axis)") from None
        if isinstance(resolution, bool) or r != resolution or r < 2:
            raise InvalidInputError(f"resolution={resolution!r} must be an integer >= 2 (voxels along the longest axis)")
        return tuple(max(1, int(round(r * L / box.max()))) for L in box)
    res = list(resolution)
    if len(res) != box.size or any(isinstance(x, bool) or int(x) != x or int(x) < 1 for x in res):
        raise InvalidInputError(f"resolution={resolution!r} must be one integer or {box.size} integers >= 1")
    return tuple(int(x) for x in res)


def voxelize(packing: Packing, resolution=64, *, subsamples: int = 0) -> VoxelImage:
    """Phase-label image of a pack on a grid that tiles its box.

    Parameters
    ----------
    packing : Packing
        Spheres (3D) or disks (2D); periodic axes wrap, wall axes clip.
    resolution : int or sequence of int, default 64
        Voxels along the longest box axis (the other axes get ``round(resolution L_a / L_max)``
        so voxels are nearly cubic), or one count per axis.
    subsamples : int, default 0
        ``s > 0``: sample every boundary voxel on ``s^dim`` sub-voxel points and return the
        per-voxel inclusion fraction (:attr:`VoxelImage.fraction`).

    Returns
    -------
    VoxelImage
        Labels (0 matrix, ``1 + species``), spacing, exact and voxel phase fractions.

    Raises
    ------
    InvalidInputError
        Not a Packing, a bad resolution, ``subsamples`` not an integer in ``[0, 64]``.
    """
    from .._kernels.voxel import voxelize_spheres

    if not isinstance(packing, Packing):
        raise InvalidInputError(f"packing must be a polypack.Packing, got {type(packing).__name__}")
    if isinstance(subsamples, bool) or int(subsamples) != subsamples or not 0 <= int(subsamples) <= 64:
        raise InvalidInputError(f"subsamples={subsamples!r} must be an integer in [0, 64] (0: no sub-voxel sampling)")
    dim = packing.dim
    shape = voxel_shape(packing.box, resolution)
    box = np.asarray(packing.box, dtype=np.float64)
    h = box / np.asarray(shape)
    n3 = np.array(list(shape) + [1] * (3 - dim), dtype=np.int64)
    h3 = np.array(list(h) + [1.0] * (3 - dim))
    per = np.array([int(p) for p in packing.periodic] + [0] * (3 - dim), dtype=np.int64)
    ns = int(packing.n_species) if packing.n > 0 else 1
    labels = np.zeros(int(np.prod(n3)), np.int32)
    frac = np.zeros(int(np.prod(n3)) if subsamples else 1)
    pos = np.ascontiguousarray(packing.positions, dtype=np.float64)
    if packing.n:
        voxelize_spheres(pos, np.ascontiguousarray(packing.radii, dtype=np.float64),
                         np.ascontiguousarray(packing.species, dtype=np.int64), dim, n3, h3, per,
                         int(subsamples), labels, frac)
    dtype = np.uint8 if ns + 1 <= 255 else np.uint16
    labels = labels.reshape(shape).astype(dtype)
    counts = np.bincount(labels.ravel(), minlength=ns + 1)[: ns + 1]
    from ..geometry import ball_volume

    vol = float(np.prod(box))
    exact = np.array([float(np.sum(ball_volume(packing.radii[packing.species == s], dim))) / vol for s in range(ns)])
    exact = np.concatenate([[1.0 - exact.sum()], exact])
    fraction = np.minimum(frac.reshape(shape), 1.0).astype(np.float32) if subsamples else None
    return VoxelImage(labels=labels, spacing=h, box=box.copy(), exact_fractions=exact,
                      voxel_fractions=counts / labels.size, fraction=fraction,
                      meta={"resolution": list(shape), "subsamples": int(subsamples),
                            "periodic": [bool(p) for p in packing.periodic]})


def _format(path, format):
    if format is not None:
        f = str(format).lower().lstrip(".")
        f = {"tif": "tiff"}.get(f, f)
        if f not in set(IMAGE_FORMATS.values()):
            raise InvalidInputError(f"format={format!r} is unknown; allowed: npy, tiff, vti")
        return f
    ext = Path(path).suffix.lower()
    if ext not in IMAGE_FORMATS:
        raise InvalidInputError(f"cannot tell the image format of {str(path)!r} from its extension {ext or '(none)'!r}; "
                                "allowed: .npy, .tif/.tiff, .vti")
    return IMAGE_FORMATS[ext]


def write_image(path, image: VoxelImage, format: str | None = None) -> None:
    """Write a :class:`VoxelImage` atomically as ``.npy``, ``.tif`` (stack) or ``.vti``.

    Raises
    ------
    InvalidInputError
        Unknown extension or format, or ``image`` not a VoxelImage.
    """
    if not isinstance(image, VoxelImage):
        raise InvalidInputError(f"image must be a polypack.io.VoxelImage, got {type(image).__name__}")
    f = _format(path, format)
    if f == "npy":
        with atomic_open(path, "wb") as fh:
            np.save(fh, image.labels, allow_pickle=False)
    elif f == "tiff":
        _write_tiff(path, image)
    else:
        _write_vti(path, image)


def _write_tiff(path, image):
    from PIL import Image

    lab = image.labels
    if lab.ndim == 2:
        lab = lab[:, :, None]
    mode_dtype = np.uint8 if lab.dtype == np.uint8 else np.uint16
    pages = [Image.fromarray(np.ascontiguousarray(lab[:, :, k].T.astype(mode_dtype))) for k in range(lab.shape[2])]
    desc = json.dumps({"writer": "polypack", "spacing": image.spacing.tolist(), "axes": "ZYX",
                       "exact_fractions": image.exact_fractions.tolist()})
    with atomic_path(path) as tmp:
        pages[0].save(tmp, format="TIFF", save_all=True, append_images=pages[1:], compression=None,
                      description=desc)


def _b64(arr):
    raw = np.ascontiguousarray(arr).tobytes()
    return base64.b64encode(np.uint64(len(raw)).tobytes() + raw).decode("ascii")


def _write_vti(path, image):
    lab = image.labels
    dim = lab.ndim
    n = list(lab.shape) + [1] * (3 - dim)
    h = list(image.spacing) + [1.0] * (3 - dim)
    ext = f"0 {n[0]} 0 {n[1]} 0 {n[2]}"
    vt = {np.dtype(np.uint8): "UInt8", np.dtype(np.uint16): "UInt16"}[lab.dtype]
    arrays = [f'        <DataArray type="{vt}" Name="phase" format="binary">{_b64(lab.reshape(n).ravel(order="F"))}'
              '</DataArray>\n']
    if image.fraction is not None:
        arrays.append('        <DataArray type="Float32" Name="inclusion_fraction" format="binary">'
                      f'{_b64(image.fraction.reshape(n).ravel(order="F").astype("<f4"))}</DataArray>\n')
    spacing = " ".join(repr(float(x)) for x in h)
    text = ('<?xml version="1.0"?>\n'
            '<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n'
            f'  <ImageData WholeExtent="{ext}" Origin="0 0 0" Spacing="{spacing}">\n'
            f'    <Piece Extent="{ext}">\n'
            '      <CellData Scalars="phase">\n' + "".join(arrays) +
            '      </CellData>\n    </Piece>\n  </ImageData>\n</VTKFile>\n')
    with atomic_open(path, "w", encoding="ascii") as fh:
        fh.write(text)
