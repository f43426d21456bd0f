"""Report and viewer performance: build time and size of reports, time to the first frame.

    python benchmarks/bench_report.py [--run out/bimodal] [--n 100000] [--browser /usr/bin/chromium]

Measures (targets of issue 20 in brackets):

* the report of the bundled bimodal study (16 realizations of N = 2000) [< 10 s, < 10 MB]; the run
  folder is made with ``polypack run examples/bimodal_propellant.toml`` if it does not exist;
* the report of one pack of ``--n`` spheres [10^5: < 5 s, < 15 MB]; the pack is one sphere per
  cubic cell with a random radius in [0.18, 0.46] and a random offset inside its cell (exactly
  non-overlapping by construction; the viewer's cost does not depend on how the pack was made);
* the time to the first frame of that page in headless Chromium (software WebGL: SwiftShader),
  measured by the page (``performance.now()`` at the end of the first finished frame, from the
  start of navigation) [< 2 s], and the time of one more frame.

There is no peer to compare with (no packing tool ships an offline viewer): the numbers are
absolute. The machine may be shared: its load average is printed with the results, and the CPU
seconds of the report process beside its wall time (on a loaded machine the wall time is mostly
waiting for a core).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def lattice_pack(n, seed=1):
    import polypack as pp

    side = int(np.ceil(n ** (1 / 3) - 1e-9))  # at least n spheres
    rng = np.random.default_rng(seed)
    g = np.stack(np.meshgrid(*[np.arange(side)] * 3, indexing="ij"), -1).reshape(-1, 3) + 0.5
    r = rng.uniform(0.18, 0.46, len(g))
    g = g + rng.uniform(-1, 1, g.shape) * (0.5 - r)[:, None] * 0.99
    return pp.Packing(g, r, np.full(3, float(side)), species=(r < 0.3).astype(int))


def first_frame(html, browser, width=1000, height=800, repeats=3):
    from playwright.sync_api import sync_playwright

    args = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"]
    out = []
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=browser, headless=True, args=args)
        for _ in range(repeats):
            pg = b.new_page(viewport={"width": width, "height": height})
            t0 = time.perf_counter()
            pg.goto(Path(html).resolve().as_uri())
            pg.wait_for_function("() => window.polypackViewer && window.polypackViewer.frames > 0", timeout=120000)
            wall = time.perf_counter() - t0
            ff = pg.evaluate("window.polypackViewer.firstFrameMs")
            frame = pg.evaluate("""() => { const v = window.polypackViewer; const t = performance.now(); v.draw();
                const px = new Uint8Array(4); v.gl.readPixels(0, 0, 1, 1, v.gl.RGBA, v.gl.UNSIGNED_BYTE, px);
                return performance.now() - t; }""")
            n = pg.evaluate("window.polypackViewer.drawnSpheres")
            out.append({"first_frame_ms": ff, "wall_to_first_frame_s": wall, "next_frame_ms": frame, "drawn": n})
            pg.close()
        b.close()
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=ROOT / "out" / "bimodal", help="run folder of the bundled study")
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--browser", default=os.environ.get("POLYPACK_CHROMIUM") or shutil.which("chromium"))
    ap.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results" / "report.json")
    a = ap.parse_args(argv)
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    if not (a.run / "study.resolved.json").is_file():
        print(f"making the run folder {a.run} (polypack run examples/bimodal_propellant.toml) ...", flush=True)
        subprocess.run([sys.executable, "-m", "polypack.cli", "run", str(ROOT / "examples" / "bimodal_propellant.toml"),
                        "--out", str(a.run), "--workers", "2", "--no-report", "--no-progress"], check=True, env=env)
    tmp = Path(tempfile.mkdtemp(prefix="bench-report-"))
    res = {"load_average": os.getloadavg(), "cpus": os.cpu_count()}

    def timed_report(src, out):
        """Wall and CPU seconds of `polypack report` in a fresh process (imports included)."""
        import resource

        c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "polypack.cli", "report", str(src), "-o", str(out)], check=True, env=env,
                       stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        return wall, (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)

    import polypack as pp

    wall, cpu = timed_report(a.run, tmp / "study.html")
    res["study"] = {"seconds": wall, "cpu_seconds": cpu, "mb": (tmp / "study.html").stat().st_size / 1e6}
    pk = lattice_pack(a.n)
    pp.io.write(tmp / "big.gsd", pk)
    timed_report(tmp / "big.gsd", tmp / "warm.html")  # numba cache of the contact counter
    wall, cpu = timed_report(tmp / "big.gsd", tmp / "big.html")
    res["pack"] = {"n": pk.n, "seconds": wall, "cpu_seconds": cpu, "mb": (tmp / "big.html").stat().st_size / 1e6}
    if a.browser:
        res["pack"]["browser"] = first_frame(tmp / "big.html", a.browser)
        res["study"]["browser"] = first_frame(tmp / "study.html", a.browser, repeats=1)
    print(f"machine: {res['cpus']} cores, load average {', '.join(f'{x:.1f}' for x in res['load_average'])}")
    print(f"{'report':<28s} {'wall s':>7s} {'CPU s':>6s} {'MB':>6s} {'first frame ms':>15s} {'next frame ms':>14s}")
    for key, label in (("study", "bundled study (16 x 2000)"), ("pack", f"one pack of N = {pk.n}")):
        r = res[key]
        br = r.get("browser") or []
        ff = min(x["first_frame_ms"] for x in br) if br else float("nan")
        nf = min(x["next_frame_ms"] for x in br) if br else float("nan")
        print(f"{label:<28s} {r['seconds']:7.2f} {r['cpu_seconds']:6.2f} {r['mb']:6.2f} {ff:15.0f} {nf:14.0f}")
    a.json.parent.mkdir(parents=True, exist_ok=True)
    a.json.write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {a.json}")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
