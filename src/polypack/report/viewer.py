"""The 3D pack viewer: packs and per-particle fields as compact data for the WebGL page.

The page itself (``assets/viewer.js``, ``assets/viewer.css``) is a small WebGL2
renderer of ray-cast impostor spheres written for polypack: every sphere is drawn at its
true radius, with exact depth, a clipping slab that shows true cross-sections, orbit,
zoom, pan and PNG export.  The data are embedded in the page as base64 little-endian
typed arrays (float32 positions and radii, uint8/uint16 integer fields), about 22 bytes
per sphere, so nothing is fetched when the page is viewed.
"""

from __future__ import annotations

import base64
import html
import json
import os
import tempfile
import webbrowser
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import InvalidInputError
from ..packing import Packing

__all__ = ["View", "view", "particle_fields", "pack_payload", "viewer_block", "page", "BUILTIN_FIELDS"]

#: Colour fields every pack has (``coordination`` when contacts are counted; x, y, z: centre coordinates).
BUILTIN_FIELDS = ("species", "radius", "coordination", "x", "y", "z")


def _b64(a, dtype) -> dict:
    arr = np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<"))
    code = {"<f4": "f32", "|u1": "u8", "<u2": "u16", "<i4": "i32"}[arr.dtype.str]
    return {"dtype": code, "data": base64.b64encode(arr.tobytes()).decode("ascii")}


def _int_dtype(v):
    lo, hi = int(v.min()) if v.size else 0, int(v.max()) if v.size else 0
    if lo >= 0 and hi < 256:
        return "u1"
    if lo >= 0 and hi < 65536:
        return "u2"
    return "i4"


@lru_cache(maxsize=None)
def _asset(name: str) -> str:
    return resources.files("polypack.report").joinpath("assets", name).read_text(encoding="utf-8")


@lru_cache(maxsize=None)
def colormaps() -> dict:
    """RGB tables (uint8, flattened) of the colour maps the viewer uses, taken from matplotlib."""
    import matplotlib

    out = {}
    for name in ("viridis", "plasma", "coolwarm"):
        cm = matplotlib.colormaps[name]
        out[name] = [int(round(255 * c)) for rgb in cm(np.linspace(0, 1, 256))[:, :3] for c in rgb]
    out["category"] = [int(round(255 * c)) for rgb in matplotlib.colormaps["tab10"].colors for c in rgb]
    return out


def _mean_radii(packing):
    sp = packing.species
    return [float(packing.radii[sp == k].mean()) if np.any(sp == k) else float("nan")
            for k in range(packing.n_species)]


def species_names(packing) -> list:
    """``"species k (a = ..., N = ...)"`` for each species; for two sizes also "large"/"small"."""
    a = _mean_radii(packing)
    counts = np.bincount(packing.species, minlength=packing.n_species)
    words = {}
    if len(a) == 2 and a[0] != a[1]:
        big = int(np.argmax(a))
        words = {big: "large", 1 - big: "small"}
    out = []
    for k, ak in enumerate(a):
        w = f"{words[k]}, " if k in words else ""
        out.append(f"species {k} ({w}a = {ak:.4g}, N = {int(counts[k])})")
    return out


def coordination_numbers(packing, tolerance=0.01):
    """Contacts per sphere: neighbours with ``d_ij <= (1 + tolerance)(r_i + r_j)``.

    The criterion of :class:`polypack.analysis.Contacts` (same pair search), without its
    overlap check of the whole pack (the pack was checked when it was made or read).
    """
    from ..neighbors import pairs_within

    if packing.n < 2:
        return np.zeros(packing.n, np.int64)
    i, j, d = pairs_within(packing.positions, packing.radii, packing.box, a=1.0 + tolerance, b=0.0,
                           periodic=packing.periodic)
    keep = d <= (1.0 + tolerance) * (packing.radii[i] + packing.radii[j])
    return np.bincount(i[keep], minlength=packing.n) + np.bincount(j[keep], minlength=packing.n)


def particle_fields(packing, *, coordination=None, tolerance=0.01, fields=None) -> dict:
    """The colour fields of one pack, encoded for the viewer.

    Parameters
    ----------
    packing : Packing
    coordination : array_like of int, optional
        Contacts per sphere; counted with :class:`polypack.analysis.Contacts`
        (``tolerance``: relative gap below which two spheres touch) when not given, or
        left out when ``False``.
    fields : dict, optional
        Extra per-particle fields ``{name: (N,) numbers}``; integer arrays with at most
        12 distinct values are shown as categories, others with a colour scale.
    """
    n = packing.n
    out = {
        "species": {"kind": "category", "label": "species", "values": _b64(packing.species, _int_dtype(packing.species)),
                    "categories": species_names(packing), "colormap": "category"},
        "radius": {"kind": "scale", "label": "radius a", "values": _b64(packing.radii, "f4"),
                   "min": float(packing.radii.min()), "max": float(packing.radii.max()), "unit": "length units",
                   "colormap": "viridis"},
    }
    if coordination is None:
        coordination = coordination_numbers(packing, tolerance)
    if coordination is not False:
        z = np.asarray(coordination)
        if z.shape != (n,):
            raise InvalidInputError(f"coordination has shape {z.shape}: one integer per sphere ({n},) is needed")
        z = z.astype(np.int64)
        out["coordination"] = {"kind": "scale", "label": "coordination z",
                               "doc": f"contacts per sphere (relative gap < {tolerance:g})",
                               "values": _b64(z, _int_dtype(z)), "min": float(z.min()), "max": float(z.max()),
                               "unit": "contacts", "colormap": "plasma"}
    for ax in range(packing.dim):  # centre coordinates, computed in the page from the positions
        out["xyz"[ax]] = {"kind": "scale", "label": f"position {'xyz'[ax]}", "derived": ax, "unit": "length units",
                          "colormap": "viridis"}
    for name, vals in (fields or {}).items():
        name = str(name)
        try:
            v = np.asarray(vals, dtype=np.float64)
        except (TypeError, ValueError):
            raise InvalidInputError(f"field {name!r}: must be numbers, one per sphere") from None
        if v.shape != (n,):
            raise InvalidInputError(f"field {name!r} has shape {v.shape}: one number per sphere ({n},) is needed")
        if not np.all(np.isfinite(v)):
            raise InvalidInputError(f"field {name!r}: holds NaN or infinite values")
        ints = np.all(v == np.round(v))
        if ints and np.unique(v).size <= 12 and v.min() >= 0:
            cats = [f"{name} = {int(u)}" for u in range(int(v.max()) + 1)]
            out[name] = {"kind": "category", "label": name, "values": _b64(v.astype(np.int64), _int_dtype(v.astype(np.int64))),
                         "categories": cats, "colormap": "category"}
        else:
            out[name] = {"kind": "scale", "label": name, "values": _b64(v, "f4"), "min": float(v.min()),
                         "max": float(v.max()), "unit": "", "colormap": "viridis"}
    return out


def pack_payload(packing, label="pack", **field_options) -> dict:
    """One realization for the viewer: positions, radii, box and colour fields."""
    if not isinstance(packing, Packing):
        raise InvalidInputError(f"packing: expected a polypack.Packing, got {type(packing).__name__}")
    pos = np.asarray(packing.positions, dtype=np.float64)
    box = [float(x) for x in packing.box]
    if packing.dim == 2:  # disks: drawn as spheres in the plane z = 0
        pos = np.column_stack([pos, np.zeros(packing.n)])
        box = box + [0.0]
    return {
        "label": str(label),
        "n": int(packing.n),
        "box": box,
        "dim": int(packing.dim),
        "periodic": [bool(p) for p in packing.periodic],
        "positions": _b64(pos.ravel(), "f4"),
        "radii": _b64(packing.radii, "f4"),
        "fields": particle_fields(packing, **field_options),
    }


def _field_order(k):
    return (BUILTIN_FIELDS.index(k), "") if k in BUILTIN_FIELDS else (len(BUILTIN_FIELDS), k)


def check_field(payloads, field):
    """InvalidInputError unless ``field`` is a colour field of every realization."""
    if field is None:
        return
    have = set.intersection(*(set(p["fields"]) for p in payloads)) if payloads else set()
    if field not in have:
        raise InvalidInputError(f"color={field!r}: not a per-particle field of this pack; allowed: "
                                f"{', '.join(sorted(have, key=_field_order))}")


def viewer_block(payloads, *, name="pack", field="species", height="70vh") -> str:
    """The viewer's HTML (controls, canvas, data); the page must include :func:`viewer_head`."""
    check_field(payloads, field)
    data = {"name": name, "initial_field": field or "species", "realizations": list(payloads),
            "colormaps": colormaps(), "background": [1.0, 1.0, 1.0]}
    blob = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    axes = "".join(f'<option value="{i}"{" selected" if i == 2 else ""}>{a}</option>' for i, a in enumerate("xyz"))
    return f"""<div class="pp-viewer" style="--pp-height:{html.escape(height)}">
<div class="pp-controls">
<label class="pp-real-wrap">realization <select class="pp-real"></select></label>
<label>colour by <select class="pp-field"></select></label>
<label title="show only the spheres inside a slab of the box"><input type="checkbox" class="pp-clip-on"> slab</label>
<label>normal <select class="pp-clip-axis">{axes}</select></label>
<label>centre <input type="range" class="pp-clip-pos" min="0" max="1000" value="500"></label>
<label>thickness <input type="range" class="pp-clip-thick" min="0" max="1000" value="200"></label>
<button type="button" class="pp-reset">reset view</button>
<button type="button" class="pp-png">save PNG</button>
</div>
<canvas class="pp-canvas"></canvas>
<div class="pp-foot"><span class="pp-legend"></span><span class="pp-info"></span>
<span class="pp-help">drag: rotate · shift/right-drag: pan · wheel: zoom</span></div>
<script type="application/json" class="pp-data">{blob}</script>
</div>
<script>window.polypackStart && window.polypackStart();</script>"""


def viewer_head() -> str:
    """``<style>`` and ``<script>`` of the viewer (inline, no network)."""
    return f"<style>{_asset('viewer.css')}</style>\n<script>{_asset('viewer.js')}</script>"


def page(title, body, *, extra_css="") -> str:
    """A self-contained HTML page."""
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta http-equiv="Content-Security-Policy" content="default-src 'none'; img-src data: blob:; style-src 'unsafe-inline'; script-src 'unsafe-inline'">
<title>{html.escape(title)}</title>
{viewer_head()}
<style>{extra_css}</style>
</head><body>
{body}
</body></html>
"""


class View:
    """A pack viewer: ``_repr_html_`` shows it in Jupyter, :meth:`save` writes the page.

    Returned by :func:`view`.
    """

    def __init__(self, html_text: str, title: str = "pack"):
        self.html = html_text
        self.title = title

    def _repr_html_(self) -> str:
        # an iframe isolates the page's script and style from the notebook's
        return (f'<iframe srcdoc="{html.escape(self.html, quote=True)}" style="width:100%;height:640px;border:0" '
                f'title="{html.escape(self.title)}"></iframe>')

    def save(self, path) -> Path:
        """Write the self-contained page to ``path`` (atomically); returns the path."""
        from .._util import atomic_open, output_path

        path = output_path(path)
        with atomic_open(path, "w", encoding="utf-8") as fh:
            fh.write(self.html)
        return path

    def show(self, path=None, browser=True) -> Path:
        """Write the page (to a temporary file unless ``path``) and open it in the web browser."""
        if path is None:
            fd, name = tempfile.mkstemp(prefix="polypack-view-", suffix=".html")
            os.close(fd)
            path = Path(name)
            path.write_text(self.html, encoding="utf-8")
        else:
            path = self.save(path)
        if browser:
            webbrowser.open(Path(path).resolve().as_uri())
        return Path(path)

    def __repr__(self) -> str:
        return f"<polypack View {self.title!r}: {len(self.html) / 1e6:.2f} MB page>"


def view(packing, color="species", *, fields=None, tolerance=0.01, title=None) -> View:
    """A 3D viewer of one pack (every sphere at its true radius), for Jupyter or a browser.

    Parameters
    ----------
    packing : Packing
    color : str
        Initial colour field: ``"species"``, ``"radius"``, ``"coordination"`` or a
        name of ``fields`` (all can be switched in the page).
    fields : dict, optional
        Extra per-particle fields ``{name: (N,) numbers}``.
    tolerance : float
        Relative gap below which two spheres touch, for the coordination field.

    Returns
    -------
    View
        Shows itself inline in Jupyter (``_repr_html_``); ``.save(path)`` writes the
        self-contained page, ``.show()`` opens it in the browser.
    """
    payload = pack_payload(packing, "pack", fields=fields, tolerance=tolerance)
    title = title or f"polypack pack: N = {packing.n}"
    block = viewer_block([payload], name="pack", field=color, height="85vh")
    return View(page(title, f'<main class="pp-page">{block}</main>'), title=title)
