"""``polypack report``: one self-contained HTML page for a pack file or a ``polypack run`` folder.

The page holds the 3D viewer (every realization of a run), the run's tables (summary,
protocol statistics, realizations, provenance) and its figures as inline SVG.  Everything
shown comes from what the run wrote (``study.resolved.json``, the realizations' records
and packs, ``ensemble/curves.json``, ``ensemble/scalars.json``); only the per-sphere
coordination numbers for the viewer's colours are counted from the packs (a run stores
the mean, not the per-sphere values).  A run folder that is not finished is reported as
such, with what it holds.
"""

from __future__ import annotations

import html
import json
import math
import time
from pathlib import Path

import numpy as np

from ..errors import FormatError, InvalidInputError, PolypackError
from .viewer import check_field, pack_payload, page, viewer_block

__all__ = ["report", "pack_report_html", "run_report_html", "sweep_report", "RunFolder", "read_run"]

_CSS = """
body { margin: 0; font: 14px/1.5 system-ui, -apple-system, "Segoe UI", sans-serif; color: #222; background: #fff; }
.pp-page { max-width: 1180px; margin: 0 auto; padding: 10px 18px 40px; }
header h1 { font-size: 22px; margin: 8px 0 2px; }
header p { margin: 2px 0; color: #444; }
nav { position: sticky; top: 0; background: #fff; border-bottom: 1px solid #ddd; padding: 6px 0; z-index: 2; }
nav a { margin-right: 14px; color: #225; text-decoration: none; }
h2 { font-size: 17px; margin: 26px 0 8px; border-bottom: 1px solid #e2e2e2; }
h3 { font-size: 14px; margin: 16px 0 6px; }
table { border-collapse: collapse; font-size: 13px; margin: 4px 0 10px; }
th, td { border-bottom: 1px solid #e6e6e6; padding: 2px 10px 2px 4px; text-align: left; vertical-align: top; }
td.num { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
code, .key { font-family: ui-monospace, SFMono-Regular, Menlo, monospace; font-size: 12px; color: #555; }
.status { padding: 6px 10px; border-radius: 4px; margin: 8px 0; }
.status.ok { background: #eef7ee; border: 1px solid #bcd9bc; }
.status.partial { background: #fff4e0; border: 1px solid #e8c27a; }
figure { margin: 12px 0 18px; }
figure svg { max-width: 100%; height: auto; }
figcaption { font-size: 13px; color: #444; max-width: 900px; }
details pre { background: #f6f6f6; padding: 8px; overflow: auto; font-size: 12px; }
.scroll { overflow-x: auto; }
"""

# summary keys in words (others are shown by their summary.csv column name)
_WORDS = {
    "n": "number of spheres N",
    "volume_fraction": "volume fraction c",
    "contacts.coordination": "mean coordination number z (contacts per sphere)",
    "contacts.coordination_without_rattlers": "coordination without rattlers",
    "contacts.rattler_fraction": "fraction of rattlers",
    "pores.void_fraction": "void fraction (porosity)",
    "pores.fit.seed.a": "DOH a, Eq. (6) of 003_873b69fc71c74cf6.txt as printed",
    "pores.fit.seed.b": "b, Eq. (6) of 003_873b69fc71c74cf6.txt as printed",
    "pores.fit.normalized.a": "DOH a, Gaussian survival form",
    "pores.fit.normalized.b": "b, Gaussian survival form",
    "pores.fit.r0": "r0 of the DOH fit (length units)",
    "kfunction.K": "K function",
}


def _esc(x) -> str:
    return html.escape(str(x))


def _num(v, digits=5) -> str:
    if v is None:
        return "–"
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        if v != 0 and (abs(v) >= 1e6 or abs(v) < 1e-3):
            return f"{v:.{digits - 1}e}"
        return f"{v:.{digits}g}"
    return _esc(v)


def _table(header, rows, cls="") -> str:
    th = "".join(f"<th>{_esc(h)}</th>" for h in header)
    body = []
    for row in rows:
        cells = []
        for c in row:
            if isinstance(c, tuple) and c and c[0] == "html":
                cells.append(f"<td>{c[1]}</td>")
            elif isinstance(c, (int, float)) and not isinstance(c, bool):
                cells.append(f'<td class="num">{_num(c)}</td>')
            else:
                cells.append(f"<td>{_esc(c)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f'<div class="scroll"><table class="{cls}"><thead><tr>{th}</tr></thead><tbody>{"".join(body)}</tbody></table></div>'


def _figure(svg, caption) -> str:
    return f"<figure>{svg}<figcaption>{caption}</figcaption></figure>"


def _read_pack(path):
    import polypack as pp

    try:
        return pp.io.read(path)
    except PolypackError as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise FormatError(f"{path}: cannot be read as a pack ({msg})") from None


# ================================================================== a pack file
def _pack_tables(pk, coordination):
    dim = pk.dim
    counts = np.bincount(pk.species, minlength=pk.n_species)
    rows = [
        ("number of spheres N", pk.n),
        ("dimension", dim),
        ("box (length units)", " × ".join(f"{x:.6g}" for x in pk.box)),
        ("periodic axes", ", ".join("xyz"[i] for i, p in enumerate(pk.periodic) if p) or "none (walls)"),
        ("volume fraction c", float(pk.volume_fraction)),
        ("smallest relative gap min d_ij/(a_i+a_j) − 1", float(pk.min_gap()) if pk.n > 1 else float("nan")),
        ("radius range (length units)", f"{pk.radii.min():.6g} – {pk.radii.max():.6g}"),
    ]
    if coordination is not None:
        rows.append(("mean coordination number z (contacts per sphere)", float(np.mean(coordination))))
    vol = pk.radii ** dim
    sp_rows = []
    from .viewer import species_names

    names = species_names(pk)
    for k in range(pk.n_species):
        sel = pk.species == k
        frac = float(vol[sel].sum() / vol.sum()) if vol.sum() > 0 else float("nan")
        sp_rows.append((names[k], int(counts[k]), float(pk.radii[sel].mean()) if sel.any() else float("nan"),
                        float(pk.volume_fraction) * frac))
    return rows, sp_rows


def _meta_html(meta) -> str:
    if not meta:
        return "<p>The file holds no provenance record.</p>"
    scal = [(k, v) for k, v in meta.items() if isinstance(v, (int, float, str, bool)) or v is None]
    txt = json.dumps(meta, indent=1, default=str)
    if len(txt) > 200_000:
        txt = txt[:200_000] + "\n... (cut)"
    return (_table(("key", "value"), [(k, v if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v))
                                      for k, v in scal])
            + f"<details><summary>full provenance record (JSON)</summary><pre>{_esc(txt)}</pre></details>")


def pack_report_html(path, *, color=None, fields=None, tolerance=0.01, plots_dir=None, formats=()) -> str:
    """The report page of one pack file (viewer, pack table, species, grading curve, provenance)."""
    from .figures import grading_figure, save_figure, svg_text
    from .viewer import coordination_numbers

    path = Path(path)
    pk = _read_pack(path)
    z = coordination_numbers(pk, tolerance)
    payload = pack_payload(pk, path.name, coordination=z, tolerance=tolerance, fields=fields)
    check_field([payload], color)
    rows, sp_rows = _pack_tables(pk, z)
    import matplotlib.pyplot as plt

    fig, hz = grading_figure(pk.radii, species=pk.species, dim=pk.dim, title="")
    svg = svg_text(fig)
    if plots_dir is not None and formats:
        save_figure(fig, Path(plots_dir) / f"{path.stem}_grading", formats)
    plt.close(fig)
    body = f"""<main class="pp-page">
<header><h1>polypack pack: {_esc(path.name)}</h1>
<p>{pk.n} {"spheres" if pk.dim == 3 else "disks"} at volume fraction {pk.volume_fraction:.5f}; report written
{time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())} by polypack {_version()}.</p></header>
<nav><a href="#viewer">viewer</a><a href="#pack">pack</a><a href="#plots">sizes</a><a href="#provenance">provenance</a></nav>
<h2 id="viewer">Viewer</h2>
{viewer_block([payload], name=path.stem, field=color or "species")}
<h2 id="pack">Pack</h2>
{_table(("quantity", "value"), rows)}
<h3>Species</h3>
{_table(("species", "N", "mean radius a (length units)", "volume fraction c_k"), sp_rows)}
<h2 id="plots">Sizes</h2>
{_figure(svg, "Grading curve of the pack's sizes: cumulative volume fraction h(d) of spheres of diameter below d, "
         f"with Hazen's d10 = {hz['d10']:.4g}, d30 = {hz['d30']:.4g}, d60 = {hz['d60']:.4g} (Eq. (18) of 001_ad5bae0acea940c4.txt).")}
<h2 id="provenance">Provenance</h2>
{_meta_html(pk.meta)}
</main>"""
    return page(f"polypack report: {path.name}", body, extra_css=_CSS)


def _version():
    from .._version import __version__

    return __version__


# ================================================================== a run folder
class RunFolder:
    """What a ``polypack run`` folder holds (read only; nothing is recomputed)."""

    def __init__(self, out):
        from ..ensemble.runner import verify_realization

        self.out = Path(out)
        try:
            with open(self.out / "study.resolved.json", encoding="utf-8") as fh:
                self.doc = json.load(fh)
        except FileNotFoundError:
            raise InvalidInputError(f"{self.out} holds no study.resolved.json: not a polypack run folder") from None
        except (OSError, ValueError) as exc:
            raise FormatError(f"{self.out / 'study.resolved.json'}: unreadable ({exc})") from None
        try:
            self.study = self.doc["study"]
            self.fingerprint = self.doc["fingerprint"]
            self.p = int(self.study["study"]["realizations"])
            self.name = str(self.study["study"].get("name", self.out.name))
        except (KeyError, TypeError, ValueError):
            raise FormatError(f"{self.out / 'study.resolved.json'}: not a resolved polypack study") from None
        self.records, self.missing, self.unverified = [], [], []
        for i in range(self.p):
            rec = verify_realization(self.out, i, self.fingerprint)
            if rec is not None:
                self.records.append(rec)
            elif (self.out / "realizations" / f"r{i:04d}.json").exists():
                self.unverified.append(i)
            else:
                self.missing.append(i)
        self.curves = self._json("ensemble/curves.json")
        self.scalars = self._json("ensemble/scalars.json")
        if self.curves is not None and self.curves.get("n_realizations", 0) == 0 and not self.records:
            self.curves = None

    def _json(self, rel):
        p = self.out / rel
        if not p.is_file():
            return None
        try:
            with open(p, encoding="utf-8") as fh:
                return json.load(fh)
        except (OSError, ValueError):
            return None

    @property
    def complete(self) -> bool:
        return not self.missing and not self.unverified and self.curves is not None and self.scalars is not None

    def status_text(self) -> str:
        done = len(self.records)
        if self.complete:
            return f"complete: {done} of {self.p} realizations, ensemble results written"
        parts = [f"incomplete run: {done} of {self.p} realizations finished"]
        if self.unverified:
            parts.append(f"{len(self.unverified)} saved record(s) do not verify (checksum or study): "
                         + ", ".join(map(str, self.unverified[:10])))
        if self.curves is None or self.scalars is None:
            parts.append("the ensemble curves and means are not written yet (rerun the same polypack run command)")
        return "; ".join(parts)


def read_run(out) -> RunFolder:
    """Read a run folder (:class:`RunFolder`); InvalidInputError if it is not one."""
    return RunFolder(out)


def _t_half(entry):
    """95 % half-width ``t(0.975, n - 1) SE`` of a mean in ensemble/scalars.json (as the run's bands)."""
    from scipy.special import stdtrit  # the Student quantile of polypack.ensemble.runner.t_quantile

    se, n = entry.get("se"), entry.get("n", 0)
    if se is None or n < 2:
        return float("nan")
    return float(stdtrit(n - 1, 0.975)) * float(se)


def _declared_words(key, study=None) -> str:
    """Words of a summary column as its capability declares them (``Outputs.labels``)."""
    from .. import registry

    try:
        if key.startswith("protocol."):
            kind = (study or {}).get("protocol", {}).get("kind")
            if not kind:
                return ""
            return registry.get("protocol", kind).words(key[len("protocol."):])
        head, _, rest = key.partition(".")
        base = head.rstrip("0123456789")  # windows0, windows1 ...
        return registry.get("analysis", base).words(rest) if rest else ""
    except PolypackError:
        return ""


def _scalar_rows(scalars, prefix_filter, study=None):
    rows = []
    for k, e in scalars.items():
        if k == "excluded" or not isinstance(e, dict) or not prefix_filter(k):
            continue
        half = _t_half(e)
        words = _WORDS.get(k) or _declared_words(k, study)
        rows.append((("html", f"{_esc(words)}{'<br>' if words else ''}<span class='key'>{_esc(k)}</span>"),
                     e.get("mean"), half, e.get("n")))
    return rows


def _protocol_label(study):
    """The protocol's registered display name (``label`` of its registration)."""
    from .. import registry

    kind = str(study.get("protocol", {}).get("kind", "pack"))
    try:
        return registry.get("protocol", kind).title
    except PolypackError:
        return kind


def _species_volume_fractions(pk):
    v = pk.box_volume
    from ..geometry import ball_volume

    vol = ball_volume(pk.radii, pk.dim)
    return [float(vol[pk.species == k].sum() / v) for k in range(pk.n_species)]


def _species_mean_radii(pk):
    return [float(pk.radii[pk.species == k].mean()) for k in range(pk.n_species)]


def run_figures(run: RunFolder, packs, *, theory=False, compare=(), plots_dir=None, formats=()):
    """``[(name, svg, caption)]`` of the run's figures (and files in ``plots_dir``)."""
    import matplotlib.pyplot as plt

    from . import figures as P

    out = []
    if run.curves is None or not run.records:
        return out
    an = run.curves.get("analyses", {})
    nreal = run.curves.get("n_realizations", 0)
    pk0 = packs[0] if packs else None

    def emit(name, fig, caption):
        out.append((name, P.svg_text(fig), caption))
        if plots_dir is not None and formats:
            P.save_figure(fig, Path(plots_dir) / name, formats)
        plt.close(fig)

    band = (f"shaded: 95 % band of the mean, ± t(0.975, P − 1) standard errors over P = {nreal} realizations"
            if nreal > 1 else "one realization: no band")
    if "rdf" in an and pk0 is not None:
        runs = [{"label": _protocol_label(run.study), "entry": an["rdf"], "species_radii": _species_mean_radii(pk0),
                 "volume_fractions": _species_volume_fractions(pk0), "n_realizations": an["rdf"]["n_realizations"]}]
        for other in compare:
            oan = (other["run"].curves or {}).get("analyses", {})
            if "rdf" in oan and other["pack"] is not None:
                runs.append({"label": _protocol_label(other["run"].study), "entry": oan["rdf"],
                             "species_radii": _species_mean_radii(other["pack"]),
                             "volume_fractions": _species_volume_fractions(other["pack"]),
                             "n_realizations": oan["rdf"]["n_realizations"]})
        fig = P.partial_rdf_figure(runs, theory=theory)
        cap = ("Partial radial distribution functions g_km against the reduced distance "
               "R_km = (r − a_k)/a_m + 1 of seed 000 §5.3 (contact at R_km = 2; Figs. 9–11 of seed 000), "
               f"{band}.")
        if theory:
            cap += (" Dotted: well-stirred approximation, Eq. (19) of 000_2cedc098acbd866b.txt; dashed: Willis form, "
                    "Eq. (20) of 000_2cedc098acbd866b.txt, with the Percus–Yevick mixture contact values of "
                    "Eq. (21) of 000_2cedc098acbd866b.txt and Eq. (22) of 000_2cedc098acbd866b.txt.")
        if len(runs) > 1:
            cap += " Runs compared: " + ", ".join(r["label"] for r in runs) + "."
        emit("rdf_partials_R", fig, cap)
    wins = sorted((k for k in an if k.rstrip("0123456789") == "windows"), key=lambda k: (len(k), k))
    if wins and pk0 is not None:
        wrec = run.records[0]["analysis"].get("windows")
        wlist = wrec if isinstance(wrec, list) else [wrec]
        entries, radii = [], []
        for j, k in enumerate(wins):
            w = wlist[j] if j < len(wlist) else {}
            rh = w.get("window_radius")
            ref = w.get("reference", "species")
            entries.append((f"R_h = {rh:g}" if rh is not None else k, an[k]))
            if rh is None:
                radii.append(None)
            elif ref == "species":
                a = np.asarray(_species_mean_radii(pk0))
                radii.append(rh * a[pk0.species])
            else:
                radii.append(rh * pk0.radii)
        fig = P.windows_figure(entries, species=pk0.species, box_volume=pk0.box_volume, window_radii=radii,
                               names=P.species_words(_species_mean_radii(pk0)))
        emit("windows", fig, "Window histograms p(n_h) (Fig. 4 of seed 000): fraction of the windows (balls of "
             "radius R_h a_k around each sphere of species k) that hold n_h centres of the other spheres; points: "
             "mean with its 95 % band; red: Poisson law of the same mean; dashed: ideal gas of the same numbers of "
             "spheres (binomial). A pack more uniform than random points has a narrower histogram.")
    if "pores" in an:
        r0s = [r["analysis"]["pores"]["fit"]["r0"] for r in run.records if "pores" in r.get("analysis", {})]
        sc = run.scalars or {}
        fits = {}
        for name in ("seed", "normalized"):
            ea, eb = sc.get(f"pores.fit.{name}.a"), sc.get(f"pores.fit.{name}.b")
            if ea and eb:
                fits[name] = (ea["mean"], _t_half(ea), eb["mean"], _t_half(eb))
        if r0s:
            fig = P.pores_figure(an["pores"], r0=float(np.mean(r0s)), fits=fits)
            emit("pores", fig, "Pore-size survival P(r_P > r): probability that a random point of the void is "
                 "farther than r from every sphere surface, against r/r0 (seed 003 §2.3), with the fit of "
                 f"Eq. (6) of 003_873b69fc71c74cf6.txt (a: degree of heterogeneity); {band}; a and b: ensemble mean ± 95 % half-width.")
    for col, ylab in P.MODULUS_COLUMNS:
        groups = []
        for label, recs in [(_protocol_label(run.study) + f" ({run.name})", run.records)] + \
                [(_protocol_label(o["run"].study) + f" ({o['run'].name})", o["run"].records) for o in compare]:
            pts = [(r["scalars"].get(P.DOH_COLUMN), r["scalars"].get(col)) for r in recs]
            pts = [(a, g) for a, g in pts if isinstance(a, (int, float)) and isinstance(g, (int, float))]
            if pts:
                groups.append((label, [a for a, _ in pts], [g for _, g in pts]))
        if groups:
            fig = P.modulus_vs_doh_figure(groups, y_label=ylab)
            emit(f"modulus_vs_doh_{col.split('.')[0]}", fig,
                 f"{ylab[0].upper() + ylab.split(' (')[0][1:]} of each realization against its degree of heterogeneity a "
                 "(the Eq. (6) of 003_873b69fc71c74cf6.txt fit of its pore-size survival), as Fig. 6 of seed 003; "
                 "one colour per run.")
            break
    ffg = [P.fullfield_moduli_groups(label, recs) for label, recs in
           [(_protocol_label(run.study) + f" ({run.name})", run.records)]
           + [(_protocol_label(o["run"].study) + f" ({o['run'].name})", o["run"].records) for o in compare]]
    ffg = [g for g in ffg if g is not None]
    if ffg:
        fig = P.moduli_vs_c_figure(ffg)
        emit("moduli_fullfield", fig, "Effective moduli E*/E0 and μ*/μ0 against the inclusion volume fraction c "
             "(Figs. 8–9 of seed 000): the full-field FFT solution of each pack's voxel image "
             "([analysis.homogenize], docs/fullfield.md; filled circles, mean ± 1.96 SE over realizations; diamonds: "
             "Richardson continuum estimate with its discretization error) beside Mori–Tanaka, the Hashin–Shtrikman "
             "upper bound, the three-point bounds from the packs' ζ2, η2 (bars) and MEFM (squares); one colour per protocol (compare runs with --compare).")
    if pk0 is not None:
        try:
            from ..ensemble.stages import make_model

            model = make_model(run.study["psd"])
        except (PolypackError, KeyError, TypeError):
            model = None
        fig, hz = P.grading_figure(pk0.radii, model=model, species=pk0.species, dim=pk0.dim)
        emit("grading", fig, "Grading curve: cumulative volume fraction h(d) of spheres with diameter below d, of the "
             f"study's size-distribution model and of realization {run.records[0]['index']}'s sizes, with Hazen's "
             f"d10 = {hz['d10']:.4g}, d30 = {hz['d30']:.4g}, d60 = {hz['d60']:.4g}, Cu = {hz['Cu']:.3g}, "
             f"Cc = {hz['Cc']:.3g} (Eq. (18) of 001_ad5bae0acea940c4.txt).")
    done = {"rdf", "pores"} | set(wins)
    for k, entry in an.items():
        if k in done:
            continue
        fig = P.generic_figure(k, entry)
        if fig is not None:
            emit(k, fig, f"{k}: ensemble mean; {band}.")
    return out


def run_report_html(out, *, color=None, theory=False, compare=(), plots_dir=None, formats=(), tolerance=None,
                    fields=None) -> str:
    """The report page of a run folder (see the module docstring)."""
    run = read_run(out)
    if not run.records and run.curves is None:
        raise InvalidInputError(f"{run.out}: the run has no finished realization yet (0 of {run.p}); nothing to report")
    tol = tolerance if tolerance is not None else \
        float(run.study.get("analysis", {}).get("contacts", {}).get("tolerance", 0.01))
    packs, payloads = [], []
    from .viewer import coordination_numbers

    for rec in run.records:
        pk = _read_pack(run.out / "realizations" / rec["files"]["gsd"]["path"])
        packs.append(pk)
        z = coordination_numbers(pk, tol)
        payloads.append(pack_payload(pk, f"realization {rec['index']}", coordination=z, tolerance=tol, fields=None))
    check_field(payloads, color)
    comp = []
    for c in compare:
        o = read_run(c)
        opk = _read_pack(o.out / "realizations" / o.records[0]["files"]["gsd"]["path"]) if o.records else None
        comp.append({"run": o, "pack": opk})
    figs = run_figures(run, packs, theory=theory, compare=comp, plots_dir=plots_dir, formats=formats)

    st = run.study
    desc = st["study"].get("description", "")
    status_cls = "ok" if run.complete else "partial"
    status = f'<p class="status {status_cls}">{_esc(run.status_text())}</p>'
    sc = run.scalars or {}
    excluded = sc.get("excluded") or (run.curves or {}).get("excluded") or []
    summary = _scalar_rows(sc, lambda k: not k.startswith("protocol."), run.study)
    proto = _scalar_rows(sc, lambda k: k.startswith("protocol."), run.study)
    hdr = ("quantity (summary.csv column)", "mean", "95 % half-width", "realizations")
    statuses = {}
    for r in run.records:
        s = str((r.get("protocol") or {}).get("status", "target"))
        statuses[s] = statuses.get(s, 0) + 1
    real_rows = []
    for r in run.records:
        pr = r.get("protocol") or {}
        real_rows.append((r["index"], " ".join(map(str, r["seed"].get("spawn_key", []))), r["n"],
                          float(r["volume_fraction"]), str(pr.get("status", "")), pr.get("min_gap"),
                          r.get("seconds"), r["files"]["gsd"]["path"], r["files"]["gsd"]["sha256"][:12]))
    versions = run.doc.get("versions", {})
    codes = sorted({json.dumps(r.get("code"), sort_keys=True) for r in run.records})
    prov_rows = [("study fingerprint", run.fingerprint), ("study file", run.doc.get("source", "")),
                 ("root seed", st["study"].get("seed")),
                 ("realization seeds", "child i of numpy SeedSequence(root seed).spawn(P); spawn keys in the table above"),
                 ("code of the realizations", "; ".join(codes))]
    prov_rows += [(f"version of {k}", v if v is not None else "–") for k, v in versions.items()]
    prov_rows.append(("report written", f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} by polypack {_version()}"))
    toml = ""
    tpath = run.out / "study.resolved.toml"
    if tpath.is_file():
        toml = tpath.read_text(encoding="utf-8", errors="replace")
    fig_html = "".join(_figure(svg, _esc(cap)) for _, svg, cap in figs) or \
        "<p>No ensemble curves in this folder yet: the figures appear when the run has aggregated its results.</p>"
    viewer = viewer_block(payloads, name=run.name, field=color or "species") if payloads else \
        "<p>No finished realization to show.</p>"
    excl = ""
    if excluded:
        excl = ("<p>Left out of the ensemble averages (stopped by a budget): "
                + ", ".join(f"realization {e['index']} ({_esc(e['status'])})" for e in excluded) + "</p>")
    body = f"""<main class="pp-page">
<header><h1>{_esc(run.name)}</h1><p>{_esc(desc)}</p>
<p>{_esc(_protocol_label(st))} packs of the size distribution <code>{_esc(st['psd'].get('model'))}</code>,
{run.p} realization(s); folder <code>{_esc(run.out)}</code>.</p>{status}</header>
<nav><a href="#viewer">viewer</a><a href="#summary">summary</a><a href="#plots">plots</a>
<a href="#protocol">protocol</a><a href="#realizations">realizations</a><a href="#provenance">provenance</a></nav>
<h2 id="viewer">Viewer</h2>
{viewer}
<h2 id="summary">Summary</h2>
{_table(hdr, summary) if summary else "<p>The ensemble means are not written yet.</p>"}
{excl}
<h2 id="plots">Plots</h2>
{fig_html}
<h2 id="protocol">Protocol statistics</h2>
<p>Packing status of the finished realizations: {_esc(", ".join(f"{v} × {k}" for k, v in statuses.items()) or "none")}.</p>
{_table(hdr, proto) if proto else ""}
<h2 id="realizations">Realizations</h2>
{_table(("index", "seed spawn key", "N", "volume fraction", "status", "min gap", "seconds", "pack", "sha256"),
        real_rows)}
{"<p>Not finished: " + ", ".join(map(str, run.missing)) + "</p>" if run.missing else ""}
<h2 id="provenance">Provenance</h2>
{_table(("item", "value"), prov_rows)}
<details><summary>resolved study (study.resolved.toml)</summary><pre>{_esc(toml)}</pre></details>
</main>"""
    return page(f"polypack report: {run.name}", body, extra_css=_CSS)


# ================================================================== entry point
def report(source, out=None, *, color=None, theory=False, compare=(), plots_dir=None, formats=(), fields=None,
           tolerance=None):
    """Write the self-contained HTML report of a pack file or a run folder.

    Parameters
    ----------
    source : path
        A pack file (GSD, extended XYZ, LAMMPS data, CSV) or a ``polypack run`` folder.
    out : path, optional
        The HTML file (default: ``report.html`` in the run folder, or ``<pack>.html``
        beside the pack).
    color : str, optional
        Initial colour field of the viewer (``species``, ``radius``, ``coordination`` or
        a name of ``fields``); an unknown name is an error.
    theory : bool
        Draw the analytic partial RDFs of §5 of 000_2cedc098acbd866b.txt beside the measured ones.
    compare : sequence of paths
        Other run folders whose curves are overlaid (e.g. a CRM run beside an SCRM run).
    plots_dir : path, optional
        Also write the figures there as files, in ``formats`` (``png``, ``svg``, ``pdf``).
    fields : dict, optional
        Extra per-particle fields of a single pack ``{name: (N,) numbers}``.
    tolerance : float, optional
        Relative gap below which two spheres touch (coordination colours); default the
        run's ``[analysis.contacts] tolerance`` or 0.01.

    Returns
    -------
    pathlib.Path
        The HTML file written (atomically).
    """
    from .._util import atomic_open, make_folder, output_path
    from .figures import PLOT_FORMATS

    src = Path(source)
    formats = tuple(formats or ())
    for f in formats:
        if f not in PLOT_FORMATS:
            raise InvalidInputError(f"plot format {f!r}: allowed are {', '.join(PLOT_FORMATS)}")
    if tolerance is not None and not (isinstance(tolerance, (int, float)) and tolerance >= 0):
        raise InvalidInputError(f"tolerance={tolerance!r}: must be a number >= 0")
    if src.is_dir():
        if not any(src.iterdir()):
            raise InvalidInputError(f"{src}: the folder is empty (not a polypack run folder)")
        if fields:
            raise InvalidInputError("fields: extra per-particle fields are given for a single pack, not a run folder")
        target = Path(out) if out is not None else src / "report.html"
        target = output_path(target)
        if plots_dir is not None:
            make_folder(plots_dir)
        text = run_report_html(src, color=color, theory=theory, compare=compare, plots_dir=plots_dir,
                               formats=formats, tolerance=tolerance)
    elif src.exists():
        if compare:
            raise InvalidInputError("compare: runs are compared in the report of a run folder, not of a pack file")
        target = Path(out) if out is not None else src.with_suffix(".html")
        target = output_path(target)
        if plots_dir is not None:
            make_folder(plots_dir)
        text = pack_report_html(src, color=color, fields=fields, tolerance=0.01 if tolerance is None else tolerance,
                                plots_dir=plots_dir, formats=formats)
    else:
        raise InvalidInputError(f"{src}: no such file or folder (give a pack file or a polypack run folder)")
    with atomic_open(target, "w", encoding="utf-8") as fh:
        fh.write(text)
    return target


# ================================================================== [sweep] runs
def _table2_side_by_side(rows):
    """``(header, rows)`` of Table 2 of 003_873b69fc71c74cf6.txt beside the heterogeneity report's rows
    (``fit.json``'s ``rows``): each set with the seed's row of its kind and value, and ``a / a_seed``."""
    from ..studies.seed003_heterogeneity import _g_dyn_cell, _seed_row

    def pm(x, e, digits):
        x = float("nan") if x is None else float(x)
        if e is None or not np.isfinite(float(e)):
            return f"{x:.{digits}f}"
        return f"{x:.{digits}f} ± {float(e):.{digits}f}"

    header = ("set", "P", "a", "a (seed)", "a / a seed", "C", "C (seed)", "G′p MPa", "G′p MPa (seed)",
              "G′p MPa dynamic (oscillatory shear)", "floppy")
    out = []
    for r in rows:
        key = r.get("parameter")
        s = _seed_row(r.get("kind"), key, r.get(key)) if key else None
        g = "0 (floppy)" if r.get("floppy") == r.get("realizations") else pm(r.get("G_MPa"), r.get("G_sd_MPa"), 3)
        out.append((r.get("set"), r.get("realizations"), pm(r.get("a"), r.get("a_se"), 3),
                    f"{s[1]:.3f}" if s else "–", f"{r['a'] / s[1]:.3f}" if s and r.get("a") is not None else "–",
                    pm(r.get("C"), r.get("C_se"), 2), f"{s[2]:.2f}" if s else "–", g,
                    f"{s[3]:.2f} ± {s[4]:.2f}" if s else "–",
                    _g_dyn_cell(r),
                    f"{r.get('floppy', 0)} of {r.get('realizations')}"))
    return header, out


def sweep_report(out, entries, *, title=None):
    """Write ``OUT/report.html`` of a ``[sweep]`` run: one page linking the value runs' reports.

    Parameters
    ----------
    out : path
        The sweep's output folder.
    entries : sequence of ``(value, folder)``
        The swept values (or, for a sweep of several ``[[sweep.set]]`` tables, the text
        ``"set: key=value"``) and their run folders (each an ordinary ``polypack run``
        folder, with its own ``report.html`` when written).
    title : str, optional
        Page title (default: the folder name).

    The page holds a table of the values (realizations finished, mean coordination, DOH
    ``a``, link to each value's report) and, when the sweep wrote the heterogeneity
    report (``OUT/heterogeneity/``), its Table 2, the fit of Eq. (7) of
    003_873b69fc71c74cf6.txt, the G′p^HE / G′p^HO table of Fig. 5 and the figures (Figs. 2, 5 and 6
    of the seed) inline.
    Returns the path written (atomically).
    """
    import base64

    from .._util import atomic_open

    out = Path(out)
    rows = []
    for value, folder in entries:
        folder = Path(folder)
        try:
            run = read_run(folder)
            n_done, n_all = len(run.records), run.p
            vals = [r.get("analysis", {}) for r in run.records]
            cs = [v.get("contacts", {}).get("coordination") for v in vals]
            ps = [v.get("pores", {}).get("fit", {}).get("seed", {}).get("a") for v in vals]
            cs = [float(c) for c in cs if c is not None]
            ps = [float(a) for a in ps if a is not None]
            c = float(np.mean(cs)) if cs else float("nan")
            a = float(np.mean(ps)) if ps else float("nan")
            status = f"{n_done} of {n_all}"
        except PolypackError as exc:
            c = a = float("nan")
            status = f"not readable ({exc})"
        rel = folder.relative_to(out) if folder.is_relative_to(out) else folder
        link = (("html", f'<a href="{_esc((rel / "report.html").as_posix())}">{_esc(rel.as_posix())}</a>')
                if (folder / "report.html").exists() else str(rel))
        rows.append((str(value), status, c, a, link))  # value: the swept value, or "set: key=value"
    parts = [f"<header><h1>{_esc(title or out.name)}</h1><p>polypack [sweep] run: one study per value; "
             "each value's run has its own report.</p></header><main>",
             "<h2>Values</h2>",
             _table(("value", "realizations finished", "mean coordination z", "DOH a (Eq. 6)", "report"), rows)]
    het = out / "heterogeneity"
    if (het / "fit.json").exists():
        fit = json.loads((het / "fit.json").read_text())
        parts.append("<h2>Stiffness against the degree of heterogeneity (seed 003)</h2>")
        parts.append("<p>Table 2 of 003_873b69fc71c74cf6.txt side by side: this run (mean ± standard error over "
                     "the realizations for a and C; G′p mean ± spread over shear planes and realizations) and the "
                     "seed's row of the same protocol and value (N = 8000). G′p is the static modulus of the "
                     "bonded network; the dynamic column is the storage modulus of the oscillatory shear test "
                     "([analysis.shear], the seed's protocol) of the structures that had it.</p>")
        parts.append(_table(*_table2_side_by_side(fit.get("rows", []))))
        f = fit.get("fit")
        if f:
            parts.append(f"<p>Eq. (7) of 003_873b69fc71c74cf6.txt: a0 = {_num(f.get('a0'))} ± {_num(f.get('a0_err'))}, "
                         f"β = {_num(f.get('beta'))} ± {_num(f.get('beta_err'))}, prefactor "
                         f"{_num(f.get('prefactor'))} ± {_num(f.get('prefactor_err'))} MPa. "
                         "Seed: a0 = 0.373 ± 0.001, β = 0.187 ± 0.032.</p>")
        parts.append(f"<p>{_esc(fit.get('note', ''))}</p>")
        f5 = fit.get("fig5")
        if f5 and f5.get("ratio"):
            parts.append(f"<p>{_esc(f5.get('note', ''))}. Static G′p (mean of C44, C55, C66) at each kn; the seed "
                         "calibrates kn between 50 and 150 N/m (§3.1 of 003_873b69fc71c74cf6.txt).</p>")
            parts.append(_table(("kn (N/m)", "G′p HE (MPa)", "G′p HO (MPa)", "G′p HE / G′p HO", "seed HE / HO"),
                                [(_num(k), _num(1e-6 * he), _num(1e-6 * ho), _num(r), _num(f5.get("seed_ratio")))
                                 for k, he, ho, r in zip(f5["kn_N_per_m"], f5["he"]["G_Pa"], f5["ho"]["G_Pa"],
                                                         f5["ratio"])]))
        elif f5:
            parts.append(f"<p>{_esc(f5.get('note', ''))}</p>")
        for name, cap in (("fig2.png", "DOH a against the coordination number C (seed Fig. 2)"),
                          ("fig5.png", "Plateau shear modulus G′p (MPa) of the most and the least heterogeneous "
                                       "structure against the particle normal stiffness kn (N/m), seed Fig. 5"),
                          ("fig6.png", "Plateau shear modulus G′p (MPa) against the DOH a with the power-law fit "
                                       "of Eq. (7) of 003_873b69fc71c74cf6.txt (seed Fig. 6)")):
            p = het / name
            if p.exists():
                b64 = base64.b64encode(p.read_bytes()).decode("ascii")
                parts.append(_figure(f'<img alt="{_esc(name)}" src="data:image/png;base64,{b64}">', _esc(cap)))
    parts.append("</main>")
    target = out / "report.html"
    with atomic_open(target, "w", encoding="utf-8") as fh:
        fh.write(page(f"polypack sweep: {title or out.name}", '<div class="pp-page">' + "".join(parts) + "</div>",
                      extra_css=_CSS))
    return target
