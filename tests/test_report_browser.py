"""The report and the 3D viewer in a real browser (headless Chromium of the system, Playwright).

Checked: no console or page errors, no request leaves the page, the canvas is not blank,
every sphere is drawn (the viewer's counter equals N), the clipping slab, colours,
orbiting and realization switches change the image, PNG export, the Jupyter iframe, and
that a sphere is drawn at its true radius (silhouette size against the perspective
projection). A missing browser fails these tests unless POLYPACK_SKIP_BROWSER_TESTS=1.
"""

from __future__ import annotations

import base64
import math
from io import BytesIO

import numpy as np
import pytest

import polypack as pp
from polypack.report import report, view

from _browser import Page, foreground_fraction, launch, sync_playwright


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as p:
        b = launch(p)
        yield b
        b.close()


def lattice_pack(n_side=14, seed=3):
    """Exactly non-overlapping spheres: one per cubic cell, radius < 1/2, jittered inside its cell."""
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(*[np.arange(n_side)] * 3, indexing="ij"), -1).reshape(-1, 3) + 0.5
    r = rng.uniform(0.18, 0.46, len(g))
    g = g + rng.uniform(-1, 1, g.shape) * (0.5 - r)[:, None] * 0.99
    pk = pp.Packing(g, r, np.full(3, float(n_side)), species=(r < 0.3).astype(int))
    assert pk.min_gap() > 0
    return pk


def _set_range(page, cls, value):
    page.page.evaluate(f"""() => {{ const e = document.querySelector('.{cls}'); e.value = '{value}';
        e.dispatchEvent(new Event('input', {{bubbles: true}})); }}""")


def _diff(a, b):
    return float(np.mean(np.abs(a - b)))


def _only_self(pg):
    return [u for u in pg.requests if u != pg.url]


def test_pack_report_in_browser(tmp_path, browser):
    pk = lattice_pack()
    f = tmp_path / "pack.gsd"
    pp.io.write(f, pk)
    html = report(f, tmp_path / "pack.html")
    pg = Page(browser).open(html)
    try:
        assert pg.viewer("v.n") == pk.n
        assert pg.viewer("v.drawnSpheres") == pk.n
        base = pg.canvas_pixels()
        # not blank: many foreground pixels with real contrast
        assert foreground_fraction(base) > 0.2 and base.std() > 25
        # both species colours (tab10 blue and orange, shaded) are on screen
        hue = base[..., 2] - base[..., 0]
        assert np.mean(hue > 60) > 0.02 and np.mean(hue < -60) > 0.02

        # a thin slab normal to z: fewer spheres on screen, a different image
        pg.page.check(".pp-clip-on")
        _set_range(pg, "pp-clip-thick", 80)
        pg.redraw()
        thin = pg.canvas_pixels()
        assert pg.viewer("v.clip.on") is True
        assert _diff(base, thin) > 8
        assert foreground_fraction(thin) < 0.8 * foreground_fraction(base)
        # moving the slab changes the image again; the count of submitted spheres stays N
        _set_range(pg, "pp-clip-pos", 250)
        pg.redraw()
        moved = pg.canvas_pixels()
        assert _diff(thin, moved) > 3
        assert pg.viewer("v.drawnSpheres") == pk.n
        pg.page.uncheck(".pp-clip-on")
        pg.redraw()
        assert _diff(pg.canvas_pixels(), base) < 1.0  # slab off: the first image again

        # colour by radius: another image, same geometry
        pg.page.select_option(".pp-field", "radius")
        pg.redraw()
        by_radius = pg.canvas_pixels()
        assert _diff(base, by_radius) > 5
        assert abs(foreground_fraction(by_radius) - foreground_fraction(base)) < 0.01
        # colour by height: a coordinate computed in the page, its range that of the centres
        pg.page.select_option(".pp-field", "z")
        pg.redraw()
        assert _diff(by_radius, pg.canvas_pixels()) > 5
        lo, hi = pg.viewer("[v.cur.fields.z.min, v.cur.fields.z.max]")
        assert abs(lo - pk.positions[:, 2].min()) < 1e-5 and abs(hi - pk.positions[:, 2].max()) < 1e-5
        pg.page.select_option(".pp-field", "radius")
        pg.redraw()

        # orbit: a drag rotates the view
        box = pg.page.locator("canvas.pp-canvas").bounding_box()
        cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        pg.page.mouse.move(cx, cy)
        pg.page.mouse.down()
        pg.page.mouse.move(cx + 120, cy + 30, steps=4)
        pg.page.mouse.up()
        pg.redraw()
        assert _diff(by_radius, pg.canvas_pixels()) > 5
        # zoom: the wheel brings the camera closer
        d0 = pg.viewer("v.dist")
        pg.page.mouse.wheel(0, -400)
        pg.page.wait_for_timeout(100)
        assert pg.viewer("v.dist") < d0

        # PNG export: the data URL decodes to an image of the canvas size; the button downloads it
        from PIL import Image

        url = pg.viewer("v.toPNG()")
        assert url.startswith("data:image/png;base64,")
        im = Image.open(BytesIO(base64.b64decode(url.split(",", 1)[1])))
        assert im.size == tuple(pg.viewer("[v.canvas.width, v.canvas.height]"))
        with pg.page.expect_download() as dl:
            pg.page.click(".pp-png")
        assert dl.value.suggested_filename.endswith(".png")

        assert pg.errors == []
        assert _only_self(pg) == []  # nothing but the page itself was requested
        # the page's figure is inline SVG, the page carries a CSP forbidding any fetch
        assert pg.page.locator("figure svg").count() >= 1
    finally:
        pg.close()


def tiny_study(n=150, realizations=2):
    return {
        "study": {"name": "tiny_report", "seed": 5, "realizations": realizations},
        "psd": {"model": "bimodal", "size_ratio": 0.5, "volume_ratio": 0.5, "n": n},
        "protocol": {"kind": "crm", "volume_fraction": 0.45},
        "analysis": {"rdf": {"r_max": 0.9, "dr": 0.05}, "windows": {"window_radius": 2.0},
                     "contacts": {"tolerance": 0.02}, "pores": {"n_points": 2000}},
        "output": {"plots": False},
    }


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "tiny"
    pp.ensemble.run_study(tiny_study(), out, progress=False)
    return out


def test_run_report_switches_realizations(tiny_run, tmp_path, browser):
    html = report(tiny_run, tmp_path / "r.html")
    pg = Page(browser).open(html)
    try:
        n = pp.io.read(tiny_run / "realizations" / "r0001.gsd").n
        assert pg.page.locator(".pp-real option").count() == 2
        first = pg.canvas_pixels()
        pg.page.select_option(".pp-real", "1")
        pg.redraw()
        assert "realization 1" in pg.page.inner_text(".pp-info")
        assert pg.viewer("v.drawnSpheres") == n and pg.viewer("v.realization") == 1
        assert _diff(first, pg.canvas_pixels()) > 3
        assert pg.page.locator("figure svg").count() >= 4  # partial RDFs, windows, pores, grading
        assert pg.errors == [] and _only_self(pg) == []
    finally:
        pg.close()


def test_jupyter_iframe_renders(browser):
    pk = lattice_pack(6)
    v = view(pk, color="radius")
    pg = Page(browser)
    try:
        pg.page.set_content(f"<html><body>{v._repr_html_()}</body></html>")
        frame = pg.page.frame_locator("iframe")
        frame.locator("canvas.pp-canvas").wait_for()
        inner = pg.page.frames[1]
        inner.wait_for_function("() => window.polypackViewer && window.polypackViewer.frames > 0", timeout=60000)
        assert inner.evaluate("window.polypackViewer.drawnSpheres") == pk.n
        assert inner.evaluate("window.polypackViewer.field") == "radius"
        assert pg.errors == []
    finally:
        pg.close()


@pytest.mark.parametrize("radius", [0.6, 1.3])
def test_sphere_drawn_at_its_true_radius(tmp_path, browser, radius):
    """One sphere at the orbit centre: its silhouette's pixel area is that of the perspective
    projection of a sphere of that radius (tangent cone half-angle asin(r/d))."""
    L = 6.0
    pk = pp.Packing(np.array([[L / 2, L / 2, L / 2]]), np.array([radius]), np.full(3, L))
    path = view(pk).save(tmp_path / "one.html")
    pg = Page(browser, 600, 600).open(path)
    try:
        # hide the box outline: draw only the sphere
        pg.page.evaluate("() => { const v = window.polypackViewer; v.drawBox = false; }")
        pg.redraw()
        w, h = pg.viewer("[v.canvas.width, v.canvas.height]")
        dist = pg.viewer("v.dist")
        px = pg.canvas_pixels()
        assert px.shape[:2] == (h, w)
        area = float(np.sum(np.abs(px - 255).max(axis=2) > 12))
        alpha = math.asin(radius / dist)
        rpx = math.tan(alpha) / math.tan(math.radians(15.0)) * h / 2  # fov 30 degrees
        # measured within 3 pixels of the exact area; tolerance: a rim of half a pixel
        # (a radius wrong by 2 % changes the area by 4 %, 2.5 times the tolerance)
        assert abs(area - math.pi * rpx**2) < math.pi * rpx + 4, (area, math.pi * rpx**2)
    finally:
        pg.close()


def test_point_sprites_and_quads_draw_the_same_spheres(tmp_path, browser):
    """Two rasterisations of the same ray-cast spheres (point sprites, instanced quads) give the
    same image; close up, where a sprite would exceed the GPU's largest point, quads are used."""
    pk = lattice_pack(8)
    path = view(pk).save(tmp_path / "q.html")
    pg = Page(browser, 700, 600).open(path)
    try:
        pg.page.check(".pp-clip-on")  # with sections, so the slab caps are compared too
        _set_range(pg, "pp-clip-thick", 400)
        pg.redraw()
        assert pg.viewer("v.path") == "points"
        pts = pg.canvas_pixels()
        pg.page.evaluate("() => { window.polypackViewer.forceQuads = true; }")
        pg.redraw()
        assert pg.viewer("v.path") == "quads"
        quads = pg.canvas_pixels()
        # identical up to the rasterisation of silhouette pixels (a fraction of a per cent)
        differ = np.abs(pts - quads).max(axis=2) > 40
        assert differ.mean() < 0.005, differ.mean()
        assert foreground_fraction(quads) > 0.2
        pg.page.evaluate("() => { const v = window.polypackViewer; v.forceQuads = false; v.dist = 2.0; }")
        pg.redraw()
        assert pg.viewer("v.path") == "quads" and foreground_fraction(pg.canvas_pixels()) > 0.5
        assert pg.errors == []
    finally:
        pg.close()
