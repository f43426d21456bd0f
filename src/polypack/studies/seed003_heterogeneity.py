"""Seed 003's heterogeneity study: Table 2, Figs. 2 and 6 and the power law Eq. (7) of 003_873b69fc71c74cf6.txt.

Run by a swept study with ``[sweep] report = "heterogeneity"`` (:mod:`polypack.ensemble.sweep`), it
writes ``<out>/heterogeneity/``:

* ``table2.csv`` / ``table2.md``: per value N_V/N, DOH ``a`` and ``b`` (Eq. (6) of
  003_873b69fc71c74cf6.txt, printed form, from ``[analysis.pores]``), coordination ``C``
  (``[analysis.contacts]``) and ``G'p`` in MPa (mean ± standard deviation over the
  structures' shear moduli C44, C55, C66, the static counterpart of the seed's six
  shear directions, and over realizations);
* ``fit.json``: the power law Eq. (7) of 003_873b69fc71c74cf6.txt over every structure of
  every set (:func:`polypack.analysis.power_law_fit`);
* ``fig2.png`` (C against a) and ``fig6.png`` (G'p against a with the fit), each with the
  seed's Table 2 values beside the measurement;
* ``fig5.png``: Fig. 5 of 003_873b69fc71c74cf6.txt, the static G'p of the most and the least
  heterogeneous rigid structure (largest and smallest ``a``; from the Brownian-dynamics set
  when there is one, as the seed, else from every set) against the normal stiffness ``kn``
  (:data:`FIG5_KN`, ``ks / kn`` of the study), and the ratio G'p^HE / G'p^HO per ``kn``
  (seed: ≈ 3.4) in ``fit.json`` (``fig5``) and ``table2.md`` (:func:`stiffness_series`).

Structures whose record has an ``[analysis.shear]`` result (the ``dynamic`` values of a sweep,
:mod:`polypack.ensemble.sweep`) also get their dynamic G'p (storage modulus of the oscillatory shear test,
mean over its directions; :func:`_dynamic_values`) beside the static one: ``G_dyn_Pa`` per point and
``G_dyn_MPa`` per row in ``fit.json``, a ``G'p dynamic`` column in ``table2.md`` / ``table2.csv`` and open
diamonds in ``fig6.png``; the fit stays on the chosen ``modulus``.

Every set (each swept value, each included folder) is labelled by its study's protocol (its
registered display name, :attr:`polypack.registry.Capability.title`) and the value that tells it
apart (:func:`set_label`: ``"VEM N_V/N = 0.5"``, ``"Brownian Ψ0 = 14 mV"``) and sits beside the
seed's Table 2 row of the same kind and value; ``examples/heterogeneity_bd.toml`` fits a
Brownian-dynamics Ψ0 series together with the VEM set.

``G'p`` comes from ``[analysis.elastic]`` records when the study has that stage
(``plate_shear_modulus`` / ``shear_moduli``); otherwise the report computes it from each
saved pack through :mod:`polypack.mechanics` (bonds at ``epsilon``, the exact static tensor
of :func:`polypack.mechanics.elastic_tensor`) with the options of ``[sweep.elastic]``
(defaults: epsilon 0.01, kn 100 N/m, ks 10 N/m, Table 1 of the seed).  Moduli are in Pa
when the pack is in metres (the seed's r0 = 0.25 µm).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..errors import InvalidInputError

__all__ = ["SEED_TABLE2", "ELASTIC_DEFAULTS", "FLOPPY_FLOOR", "FIG5_KN", "SEED_FIG5_RATIO", "heterogeneity_report",
           "set_label", "stiffness_series"]

#: Table 2 of 003_873b69fc71c74cf6.txt (N = 8000, Φ = 0.4, kn = 100 N/m): VEM rows
#: (N_V/N, a, C, G'p MPa, error) and BD rows (Ψ0 mV, a, C, G'p MPa, error).
SEED_TABLE2 = {
    "vem": [(1000 / 8000, 0.594, 4.68, 1.73, 0.383), (2000 / 8000, 0.521, 4.71, 1.83, 0.136),
            (4000 / 8000, 0.467, 4.69, 1.62, 0.190), (8000 / 8000, 0.418, 4.69, 1.32, 0.237),
            (13000 / 8000, 0.399, 4.69, 1.32, 0.267), (16000 / 8000, 0.392, 4.61, 1.17, 0.231)],
    "bd": [(0.0, 0.373, 4.52, 0.480, 0.049), (12.0, 0.404, 4.84, 1.19, 0.141), (13.0, 0.410, 4.75, 1.05, 0.124),
           (14.0, 0.472, 5.08, 1.46, 0.120), (15.0, 0.536, 4.97, 1.62, 0.213)],
}

#: The seed's particle normal stiffness kn (N/m) of Table 2 (Table 1 of 003_873b69fc71c74cf6.txt).
SEED_KN = 100.0

#: ``[sweep.elastic]`` defaults of the report's own static tensor (Table 1 of the seed).
#: ``stiffness``: "contact" (per contact, polypack's default) or "particle" (per ball, in series).
ELASTIC_DEFAULTS = {"epsilon": 0.01, "normal_stiffness": SEED_KN, "shear_stiffness": SEED_KN / 10, "stiffness": "contact"}


#: Normal stiffnesses (N/m) of Fig. 5 of 003_873b69fc71c74cf6.txt (the seed calibrates kn between 50 and
#: 150 N/m and keeps kn = 100 N/m); ks = kn times the study's ks / kn (Table 1: 1/10).
FIG5_KN = (25.0, 50.0, 100.0, 200.0, 400.0)

#: G'p^HE / G'p^HO of the seed's most and least heterogeneous BD structures (Ψ0 = 15 and 0 mV), §3.1 of
#: 003_873b69fc71c74cf6.txt (experiment: 3.6 at Φ = 0.4).
SEED_FIG5_RATIO = 3.4


def _records(folder: Path):
    from ..ensemble.runner import is_complete

    recs = []
    for p in sorted((folder / "realizations").glob("r[0-9]*.json")):
        rec = json.loads(p.read_text())
        if is_complete(rec):
            recs.append((rec, p.with_suffix(".gsd")))
    return recs


#: A structure whose static shear modulus is below this fraction of its affine (Voigt) modulus
#: is floppy (no rigid cluster spans the box: G'p = 0).  The solvers of
#: :func:`polypack.mechanics.elastic_tensor` agree to ~1e-8 of the affine scale, so a smaller
#: value is round-off of a zero modulus (e.g. 1e-11 MPa against an affine 22 MPa), and fitting
#: its logarithm would wreck the power law of Eq. (7) of 003_873b69fc71c74cf6.txt.
FLOPPY_FLOOR = 1e-6


def _stated_rigid(rec, modulus):
    """``rigid`` as the structure's record states it (``[analysis.elastic]``'s ``rigid``, or the
    ``[analysis.shear]`` status for ``modulus = "shear"``); None for records made before it existed."""
    ana = rec.get("analysis", {})
    if modulus == "shear":
        st = (ana.get("shear") or {}).get("status")
        return None if st is None else st != "floppy"
    r = (ana.get("elastic") or {}).get("rigid")
    return None if r is None else bool(r)


def _semantics(rec, src, elastic):
    """How the stiffnesses of this structure's G'p were read: "contact" or "particle"."""
    if src.startswith("report"):
        return elastic.get("stiffness", "contact")
    ana = rec.get("analysis", {})
    for key in ("shear", "elastic"):
        st = (ana.get(key) or {}).get("stiffness_semantics") if isinstance(ana.get(key), dict) else None
        if st is not None and key in src:
            return st
    return "contact"


def _structure_values(rec, gsd, elastic, modulus="elastic"):
    """``(a, b, C, G'p, G'p_sd, source, G_affine)`` of one structure.

    ``modulus = "shear"`` takes the dynamic storage moduli of the ``[analysis.shear]``
    record (mean and spread over its shear directions, as the seed's error bars);
    ``"elastic"`` the static shear moduli C44, C55, C66 of ``[analysis.elastic]`` or, when
    the record has none, of the report's own :func:`polypack.mechanics.elastic_tensor`.
    ``G_affine`` is the affine shear modulus of the bonded network when known (the reference
    of :data:`FLOPPY_FLOOR`), else NaN.
    """
    ana = rec.get("analysis", {})
    pores = ana.get("pores")
    if pores is None:
        raise InvalidInputError("heterogeneity report: the study needs [analysis.pores] (DOH, Eq. 6)")
    fit = pores["fit"]["seed"]
    a, b = float(fit["a"]), float(fit["b"])
    c = ana.get("contacts", {}).get("coordination")
    el = ana.get("elastic")
    sh = ana.get("shear")
    g_aff = float(el.get("affine_shear_modulus", math.nan)) if isinstance(el, dict) else math.nan
    if modulus == "shear":
        if not isinstance(sh, dict) or "direction" not in sh:
            raise InvalidInputError("heterogeneity report: sweep.modulus = \"shear\" needs [analysis.shear] in the study")
        if sh.get("status") == "floppy":
            g3 = np.zeros(1)  # G'p = 0: no DEM was run
        else:  # not converged: None -> NaN, left out of the fit and counted
            g3 = np.asarray([np.nan if d["storage_modulus"] is None else d["storage_modulus"]
                             for d in sh["direction"].values()] or [np.nan], dtype=np.float64)
        src = "[analysis.shear] (dynamic G')"
        if c is None:
            c = sh.get("coordination")
    elif isinstance(el, dict) and ("shear_moduli" in el or "plate_shear_modulus" in el):
        g3 = np.asarray(el.get("shear_moduli", [el.get("plate_shear_modulus")]), dtype=np.float64)
        src = "[analysis.elastic]"
        if c is None:
            c = el.get("coordination")
    else:
        from .. import io
        from ..mechanics import BondNetwork, elastic_tensor

        pk = io.read(str(gsd))
        net = BondNetwork.from_packing(pk, epsilon=elastic["epsilon"], normal_stiffness=elastic["normal_stiffness"],
                                       shear_stiffness=elastic["shear_stiffness"],
                                       stiffness=elastic.get("stiffness", "contact"))
        et = elastic_tensor(net)
        g3 = np.asarray(et.shear_moduli, dtype=np.float64)
        g_aff = float(et.affine_shear_modulus)
        src = "report (pp.mechanics.elastic_tensor)"
        if c is None:
            c = net.coordination
    return a, b, float(c) if c is not None else float("nan"), float(g3.mean()), float(g3.std(ddof=0)), src, g_aff


_LEGACY_WORDS = {"ls": "LS", "shake": "shaken"}  # kinds of run folders written before the registry


def _kind_word(kind) -> str:
    """The protocol's registered display name (``register(..., label=...)``)."""
    from .. import registry
    from ..errors import PolypackError

    try:
        return registry.get("protocol", str(kind)).title
    except PolypackError:
        return _LEGACY_WORDS.get(kind, str(kind))
#: The option that tells a set of the seed's protocols apart (with its label form, :func:`_value_words`)
#: when a folder is included without a swept value.
_KIND_KEYS = {"vem": "void_ratio", "brownian": "surface_potential"}


def _protocol(folder: Path) -> dict:
    """The ``[protocol]`` table of a run folder (``study.resolved.json``); ``{}`` when absent."""
    try:
        with open(folder / "study.resolved.json", encoding="utf-8") as fh:
            doc = json.load(fh)
    except (OSError, ValueError):
        return {}
    prot = doc.get("study", {}).get("protocol", {})
    return prot if isinstance(prot, dict) else {}


def _value_words(key: str, v) -> str:
    if key == "surface_potential" and isinstance(v, (int, float)):
        return f"Ψ0 = {1e3 * v:g} mV"
    if key == "void_ratio" and isinstance(v, (int, float)):
        return f"N_V/N = {v:g}"
    return f"{key} = {v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else f"{key} = {v}"


def set_label(folder, parameter=None, value=None, title=None):
    """``(label, kind, key, value)`` of one structure set (run folder) in the heterogeneity report.

    The label names the protocol kind of the folder's study and the value that tells the
    set apart: the swept ``parameter`` = ``value`` when given, else the kind's own option
    (``void_ratio`` of VEM, ``surface_potential`` of Brownian dynamics), e.g.
    ``"VEM N_V/N = 0.5"`` or ``"Brownian Ψ0 = 14 mV"``; ``title`` (a ``[[sweep.set]]``
    ``label``) replaces the protocol's name (``"BD creeping Ψ0 = 14 mV"``); a folder without a
    study record is labelled by its name.
    """
    folder = Path(folder)
    prot = _protocol(folder)
    kind = prot.get("kind")
    if kind is None:
        return (folder.name if title is None else f"{title} ({folder.name})"), None, None, folder.name
    word = _kind_word(kind) if title is None else title
    if parameter is not None:
        key = parameter.split(".")[-1]
    else:
        key = _KIND_KEYS.get(kind)
        value = prot.get(key) if key is not None else None
    if key is None or value is None:
        return f"{word} ({folder.name})", kind, None, folder.name
    return f"{word} {_value_words(key, value)}", kind, key, value


def _seed_row(kind, key, value):
    """The seed's Table 2 row of a set (VEM by N_V/N, BD by Ψ0), or None."""
    if not isinstance(value, (int, float)):
        return None
    if kind == "vem" and key == "void_ratio":
        return {round(x[0], 6): x for x in SEED_TABLE2["vem"]}.get(round(value, 6))
    if kind == "brownian" and key == "surface_potential":
        return {round(x[0], 3): x for x in SEED_TABLE2["bd"]}.get(round(1e3 * value, 3))
    return None


def heterogeneity_report(out, sets, *, parameter="protocol.void_ratio", include=(), elastic=None, modulus="elastic",
                         fmt="png", fig5_kn=None):
    """Table 2, Figs. 2 and 6 and the fit of Eq. (7) of 003_873b69fc71c74cf6.txt over the structures of ``sets``.

    ``sets`` is a list of ``(value, run_folder)`` of the swept ``parameter``, or of ``(value, run_folder,
    parameter, title)`` (a sweep of several ``[[sweep.set]]`` tables: each value with its set's own swept
    parameter and label, None for the protocol's title); ``include``
    more run folders (other structure sets, e.g. SCRM or Brownian-dynamics packs at
    Φ = 0.4) that enter the fit and the figures.  Every set is labelled by its protocol
    kind and value (:func:`set_label`, e.g. ``"VEM N_V/N = 0.5"``, ``"Brownian Ψ0 = 14 mV"``)
    and compared with the seed's Table 2 row of that kind and value where there is one.
    ``fig5_kn``: the normal stiffnesses (N/m) of Fig. 5 (default :data:`FIG5_KN`; ``()``: no
    Fig. 5).  Returns ``{what: path}``.
    """
    from .._util import atomic_path, make_folder
    from ..analysis.powerlaw import power_law_fit

    elastic = dict(ELASTIC_DEFAULTS, **(elastic or {}))
    rep = Path(out) / "heterogeneity"
    make_folder(rep)
    rows, points = [], []
    sources = set()
    semantics = set()
    unconverged = []
    where = []  # (folder, pack file, G'p source) of each point, for Fig. 5
    groups = []
    for item in sets:  # (value, folder[, parameter[, title]])
        item = tuple(item)
        v, f = item[:2]
        par = item[2] if len(item) > 2 and item[2] is not None else parameter
        title = item[3] if len(item) > 3 else None
        groups.append((Path(f), *set_label(f, par, v, title)))
    groups += [(Path(f), *set_label(f)) for f in include]
    keys = list(dict.fromkeys(g[3] for g in groups if g[3] is not None)) or [parameter.split(".")[-1]]
    for folder, label, kind, vkey, v in groups:
        vals, floppy = [], 0
        dyn = []  # dynamic G'p (oscillatory shear) of the structures that have it
        dyn_tested = dyn_floppy = 0
        dyn_static = []  # the static G'p of the same structures (those with a dynamic G'p)
        for rec, gsd in _records(folder):
            a, b, c, g, gsd_sd, src, g_aff = _structure_values(rec, gsd, elastic, modulus)
            gd = _dynamic_values(rec)
            sources.add(src)
            semantics.add(_semantics(rec, src, elastic))
            if not math.isfinite(g):  # a dynamic test that did not converge: no modulus
                unconverged.append(f"{label} r{rec['index']:04d}")
                continue
            stated = _stated_rigid(rec, modulus)  # the record's own answer (issue 31), when it has one
            if stated is not None:
                rigid = stated and bool(g > 0)
            else:  # older records: round-off of zero is below FLOPPY_FLOOR of the affine modulus
                rigid = bool(g > FLOPPY_FLOOR * g_aff) if math.isfinite(g_aff) else bool(g > 0)
            if not rigid:  # a zero modulus: its round-off is not reported as a value
                g, gsd_sd = 0.0, 0.0
                floppy += 1
            vals.append((a, b, c, g, gsd_sd))
            where.append((folder, gsd, src))
            point = {"set": label, "kind": kind, "parameter": vkey, "value": v, "index": rec["index"],
                     "a": a, "b": b, "C": c, "G_Pa": g, "G_sd_Pa": gsd_sd, "rigid": rigid}
            if gd is not None:  # the static and the dynamic G'p of one structure side by side
                point.update(G_dyn_Pa=gd[0] if math.isfinite(gd[0]) else None, G_dyn_sd_Pa=gd[1],
                             dynamic_status=gd[2])
                dyn_tested += 1
                dyn_floppy += gd[2] == "floppy"
                if math.isfinite(gd[0]):
                    dyn.append(gd[:2])
                    dyn_static.append(g)
            points.append(point)
        if not vals:
            continue
        arr = np.asarray(vals)
        nr = arr.shape[0]
        se = (lambda x: float(x.std(ddof=1) / math.sqrt(nr)) if nr > 1 else float("nan"))
        gall = np.sqrt(np.mean(arr[:, 4] ** 2) + (arr[:, 3].var(ddof=1) if nr > 1 else 0.0))
        row = {"set": label, "kind": kind, "parameter": vkey, (vkey or keys[0]): v, "value": v, "realizations": nr,
               "a": float(arr[:, 0].mean()), "a_se": se(arr[:, 0]), "b": float(arr[:, 1].mean()),
               "C": float(np.nanmean(arr[:, 2])), "C_se": se(arr[:, 2]),
               "G_MPa": float(arr[:, 3].mean()) * 1e-6, "G_sd_MPa": float(gall) * 1e-6,
               "floppy": floppy, "dynamic": len(dyn), "dynamic_tested": dyn_tested, "dynamic_floppy": dyn_floppy,
               "G_dyn_MPa": None, "G_dyn_sd_MPa": None, "G_dyn_static_MPa": None}
        if dyn:  # mean over the structures; spread over their shear directions and the structures
            d = np.asarray(dyn)
            row["G_dyn_MPa"] = float(d[:, 0].mean()) * 1e-6
            row["G_dyn_static_MPa"] = float(np.mean(dyn_static)) * 1e-6  # the same structures' static G'p
            row["G_dyn_sd_MPa"] = float(np.sqrt(np.mean(d[:, 1] ** 2) + (d[:, 0].var(ddof=1) if len(d) > 1
                                                                          else 0.0))) * 1e-6
        rows.append(row)
    if not points:
        raise InvalidInputError(f"heterogeneity report: no complete realization under {out}")
    a = np.array([p["a"] for p in points])
    g = np.array([p["G_Pa"] for p in points]) * 1e-6
    sd = np.array([p["G_sd_Pa"] for p in points]) * 1e-6
    fit = None
    # structures without a rigid cluster (G'p = 0, FLOPPY_FLOOR) lie below a0 and do not enter the fit
    pos = np.array([p["rigid"] for p in points], dtype=bool)
    dropped = int(np.count_nonzero(~pos))
    if np.count_nonzero(pos) >= 3 and np.ptp(a[pos]) > 0:
        sig = sd[pos] if np.all(sd[pos] > 0) else None
        fit = power_law_fit(a[pos], g[pos], sigma=sig)
        fit_note = fit.note
    else:
        fit_note = "fewer than 3 structures with G'p > 0 and a range of a: no fit"
    if dropped:
        fit_note += (f"; {dropped} floppy structure(s) (G'p below {FLOPPY_FLOOR:g} of the affine modulus: "
                     f"G'p = 0) left out of the fit")
    if unconverged:
        fit_note += (f"; {len(unconverged)} structure(s) without a modulus (a shear test that did not converge, "
                     "or NaN in an old record) left out: " + ", ".join(unconverged[:8]))
    fig5 = (None if fig5_kn is not None and len(fig5_kn) == 0
            else _fig5(points, where, elastic, FIG5_KN if fig5_kn is None else tuple(fig5_kn)))
    files = {}
    key = keys[0] if len(keys) == 1 else "value"  # the value column: the one swept key, else "value"
    cols = ["set", *keys, "realizations", "a", "a_se", "b", "C", "C_se", "G_MPa", "G_sd_MPa", "floppy",
            "G_dyn_MPa", "G_dyn_sd_MPa", "G_dyn_static_MPa"]
    with atomic_path(rep / "table2.csv") as tmp:
        with open(tmp, "w") as fh:
            fh.write(",".join(cols) + "\n")
            for r in rows:
                fh.write(",".join("" if r.get(c) is None else str(r[c]) for c in cols) + "\n")
    files["table"] = rep / "table2.csv"
    lines = [f"| set | {key} | P | a | b | C | G'p (MPa) | G'p dynamic (MPa) | seed a | seed C | seed G'p (MPa) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        s = _seed_row(r["kind"], r["parameter"], r["value"])
        sa = f"{s[1]:.3f} | {s[2]:.2f} | {s[3]:.2f} ± {s[4]:.2f}" if s else "– | – | –"
        a_cell = f"{r['a']:.3f} ± {r['a_se']:.3f}" if math.isfinite(r["a_se"]) else f"{r['a']:.3f}"  # P = 1: no SE
        lines.append(f"| {r['set']} | {r['value']} | {r['realizations']} | {a_cell} | "
                     f"{r['b']:.3f} | {r['C']:.2f} | {_g_cell(r)} | {_g_dyn_cell(r)} | {sa} |")
    lines.append("")
    per = " and per ".join(sorted(semantics))
    stiff = f"kn = {elastic['normal_stiffness']:g} N/m, ks = {elastic['shear_stiffness']:g} N/m"
    lines.append(f"G'p source: {', '.join(sorted(sources))}; bonds at epsilon = {elastic['epsilon']:g}, "
                 f"{stiff}; stiffnesses per {per} (particle: per ball, in series per "
                 "contact, k/2 for equal balls; Table 1 of 003_873b69fc71c74cf6.txt).")
    if fit is not None:
        lines.append(f"Eq. (7) of 003_873b69fc71c74cf6.txt: a0 = {fit.a0:.4f} ± {fit.a0_err:.4f}, "
                     f"beta = {fit.beta:.3f} ± {fit.beta_err:.3f}, A = {fit.prefactor:.3g} ± "
                     f"{fit.prefactor_err:.2g} MPa ({fit_note}; without the lowest point a0' = "
                     f"{fit.a0_without_lowest:.4f}). Seed: a0 = 0.373 ± 0.001, beta = 0.187 ± 0.032.")
    else:
        lines.append(fit_note)
    if fig5 is not None:
        lines.append(fig5["note"] + ".")
    with atomic_path(rep / "table2.md") as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n")
    files["table_md"] = rep / "table2.md"
    with atomic_path(rep / "fit.json") as tmp:
        Path(tmp).write_text(json.dumps({"fit": fit.to_dict() if fit is not None else None, "note": fit_note,
                                         "points": points, "rows": rows, "g_source": sorted(sources),
                                         "elastic": elastic, "fig5": fig5, "units": "MPa"}, indent=1))
    files["fit"] = rep / "fit.json"
    files.update(_plots(rep, points, fit, fmt, stiffness=f"{stiff} per {per}"))
    if fig5 is not None and fig5.get("ratio") is not None:
        files["fig5"] = _plot_fig5(rep, fig5, fmt)
    return files


def _study_elastic(folder: Path, elastic, src):
    """The elastic settings that made a structure's G'p: the study's resolved ``[analysis.elastic]``
    when its record gave the modulus, else the report's own (``[sweep.elastic]``, distance bonds)."""
    if src == "[analysis.elastic]":
        try:
            with open(folder / "study.resolved.json", encoding="utf-8") as fh:
                opts = json.load(fh).get("study", {}).get("analysis", {}).get("elastic")
        except (OSError, ValueError):
            opts = None
        if isinstance(opts, dict):
            return dict(opts)
    return {"bonds": "distance", "epsilon": elastic["epsilon"], "normal_stiffness": elastic["normal_stiffness"],
            "shear_stiffness": elastic["shear_stiffness"], "stiffness": elastic.get("stiffness", "contact"),
            "radius": 0.0}


def stiffness_series(pack, opts, kn_values=FIG5_KN):
    """Static G'p (mean of C44, C55, C66) of one pack at each normal stiffness of ``kn_values``.

    The network is that of :func:`polypack.mechanics.stages.network_of` with ``opts``
    (the study's ``[analysis.elastic]`` table: bond rule, ``epsilon``, stiffness semantics)
    and ``ks = kn * (ks / kn of opts)`` (Table 1 of 003_873b69fc71c74cf6.txt: 1/10); the tensor
    is :func:`polypack.mechanics.elastic_tensor` with the options' rotations, radius and solver.
    Fig. 5 of 003_873b69fc71c74cf6.txt.  Returns ``(G'p array in Pa, ks / kn)``.
    """
    from ..mechanics import elastic_tensor
    from ..mechanics.stages import _stiffnesses, network_of

    kns = np.asarray(kn_values, dtype=np.float64)
    if kns.ndim != 1 or kns.size < 2 or not np.all(np.isfinite(kns) & (kns > 0)):
        raise InvalidInputError(f"fig5 kn values = {list(np.atleast_1d(kn_values))!r}: give two or more "
                                "stiffnesses > 0 (N/m)")
    kn0, ks0 = _stiffnesses(opts)
    ratio = ks0 / kn0 if kn0 > 0 else 0.1
    radius = float(opts.get("radius", 0.25e-6) or 0.0)
    out = []
    for kn in kns:
        net, _ = network_of(pack, dict(opts, normal_stiffness=float(kn), shear_stiffness=float(kn) * ratio))
        et = elastic_tensor(net, rotations=opts.get("rotations", True), radius=radius if radius > 0 else None,
                            solver=opts.get("solver", "auto"))
        out.append(float(np.mean(et.shear_moduli)))
    return np.asarray(out), float(ratio)


def _fig5_pick(points):
    """``(he, ho, among)``: indices of the most and least heterogeneous rigid structure (largest and
    smallest ``a``) of the Brownian-dynamics set(s) when they hold two or more rigid structures (the seed's
    Ψ0 = 15 and 0 mV), else of every set; None when fewer than two rigid structures differ in ``a``."""
    rigid = [k for k, p in enumerate(points) if p["rigid"]]
    bd = [k for k in rigid if points[k].get("kind") == "brownian"]
    pool, among = (bd, "the Brownian-dynamics set(s), as the seed") if len(bd) >= 2 else (rigid, "every set")
    if len(pool) < 2 or len({points[k]["a"] for k in pool}) < 2:
        return None
    return max(pool, key=lambda k: points[k]["a"]), min(pool, key=lambda k: points[k]["a"]), among


def _fig5(points, where, elastic, kn_values):
    """Fig. 5 of 003_873b69fc71c74cf6.txt over the report's structures: ``dict`` for fit.json."""
    from .. import io

    pick = _fig5_pick(points)
    if pick is None:
        return {"kn_N_per_m": list(map(float, kn_values)), "ratio": None,
                "note": "Fig. 5: fewer than two rigid structures with different a: no G'p against kn"}
    he, ho, among = pick
    missing = [str(where[k][1]) for k in (he, ho) if not Path(where[k][1]).is_file()]
    if missing:  # G'p read from the records of a run whose packs are gone
        return {"kn_N_per_m": list(map(float, kn_values)), "ratio": None,
                "note": f"Fig. 5: no pack file {missing[0]}: no G'p against kn"}
    res = {"kn_N_per_m": list(map(float, kn_values)), "among": among}
    for name, k in (("he", he), ("ho", ho)):
        folder, gsd, src = where[k]
        opts = _study_elastic(folder, elastic, src)
        g, ratio = stiffness_series(io.read(str(gsd)), opts, kn_values)
        p = points[k]
        res[name] = {"set": p["set"], "index": p["index"], "a": p["a"], "G_Pa": g.tolist(),
                     "ks_over_kn": ratio, "settings": {kk: opts.get(kk) for kk in
                                                       ("bonds", "epsilon", "stiffness", "radius")}}
    res["ratio"] = (np.asarray(res["he"]["G_Pa"]) / np.asarray(res["ho"]["G_Pa"])).tolist()
    res["seed_ratio"] = SEED_FIG5_RATIO
    res["note"] = (f"Fig. 5: most heterogeneous {res['he']['set']} r{res['he']['index']:04d} (a = {res['he']['a']:.3f}),"
                   f" least {res['ho']['set']} r{res['ho']['index']:04d} (a = {res['ho']['a']:.3f}), among the rigid "
                   f"structures of {among}; G'p^HE/G'p^HO = "
                   + ", ".join(f"{r:.3g}" for r in res["ratio"]) + " at kn = "
                   + ", ".join(f"{k:g}" for k in kn_values) + f" N/m (seed ≈ {SEED_FIG5_RATIO})")
    return res


def _dynamic_values(rec):
    """``(G', spread, status)`` in Pa of a structure's ``[analysis.shear]`` record (the dynamic G'p: mean and
    standard deviation over its shear directions, the seed's oscillatory test); ``(0, 0, "floppy")`` for a
    floppy network (no DEM run), NaN when the test did not converge; None without a shear record."""
    sh = rec.get("analysis", {}).get("shear")
    if not isinstance(sh, dict) or ("direction" not in sh and "status" not in sh):
        return None
    status = str(sh.get("status") or "ok")
    if status == "floppy":
        return 0.0, 0.0, status
    g = np.asarray([np.nan if d.get("storage_modulus") is None else d["storage_modulus"]
                    for d in (sh.get("direction") or {}).values()] or [np.nan], dtype=np.float64)
    if not np.all(np.isfinite(g)):
        return math.nan, math.nan, status if status != "ok" else "not_converged"
    return float(g.mean()), float(g.std(ddof=0)), status


def _g_dyn_cell(row):
    """The dynamic G'p cell of a Table 2 row: mean ± spread over the structures that had the shear test."""
    tested, n = row.get("dynamic_tested", row.get("dynamic", 0)), row.get("dynamic", 0)
    if not tested:
        return "–"
    lost = f", {tested - n} not converged" if tested > n else ""
    if n and row.get("dynamic_floppy") == n:
        return f"0 (floppy, {n} of {row['realizations']}{lost})"
    if not n:
        return f"– ({tested} not converged)"
    same = ""  # fewer structures than the row's (sweep dynamic_realizations): their own static G'p beside
    if tested < row["realizations"] and row.get("G_dyn_static_MPa") is not None:
        same = f"; static G'p of the same {row['G_dyn_static_MPa']:.3g}"
    return f"{row['G_dyn_MPa']:.3g} ± {row['G_dyn_sd_MPa']:.2g} ({n} of {row['realizations']}{lost}{same})"


def _g_cell(row):
    """The G'p cell of a Table 2 row: mean ± spread, and how many structures are floppy."""
    if row["floppy"] == row["realizations"]:
        return "0 (floppy)"
    cell = f"{row['G_MPa']:.3g} ± {row['G_sd_MPa']:.2g}"
    return cell + (f" ({row['floppy']} of {row['realizations']} floppy)" if row["floppy"] else "")


#: One colour family per protocol kind, shaded along the set's values (seed Fig. 6 tells the two
#: generators apart by marker; with eleven values one colour cycle would repeat).
_KIND_CMAPS = {"vem": "Blues", "brownian": "Oranges"}
_OTHER_CMAPS = ("Greens", "Purples", "Greys", "RdPu", "BuGn", "YlOrBr", "PuBu", "Reds")


def _set_colours(sets, kinds):
    """``{set: RGBA}``: the sets of one protocol kind (``kinds[set]``) in shades of one colour map
    (VEM blues, Brownian dynamics oranges, others greens, purples, greys), light to dark in report
    order, so no two sets of a figure share a colour."""
    from matplotlib import colormaps

    groups = {}
    for s in sets:
        groups.setdefault(kinds.get(s), []).append(s)
    others = iter(_OTHER_CMAPS * len(groups))
    out = {}
    for kind, members in groups.items():
        cmap = colormaps[_KIND_CMAPS.get(kind) or next(others)]
        for i, s in enumerate(members):
            out[s] = cmap(0.45 + 0.5 * i / max(len(members) - 1, 1))
    return out


def _plots(rep, points, fit, fmt, stiffness=""):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .._util import atomic_path

    files = {}
    order = {}
    for p in points:  # sets in report order (swept first), one marker per protocol kind (seed Fig. 6:
        order.setdefault(p["set"], p.get("kind"))  # circles VEM, triangles BD)
    sets = list(order)
    marker = {"vem": "o", "brownian": "^"}
    colour = _set_colours(sets, order)
    # Fig. 2: C against a
    fig, ax = plt.subplots(figsize=(5, 4))
    for s in sets:
        pa = [p["a"] for p in points if p["set"] == s]
        pc = [p["C"] for p in points if p["set"] == s]
        ax.plot(pa, pc, marker.get(order[s], "D"), ms=4, color=colour[s], label=f"{s} (this run)")
    for key, mk, lab in (("vem", "s", "seed VEM (Table 2, N = 8000)"), ("bd", "^", "seed BD (Table 2)")):
        ax.plot([x[1] for x in SEED_TABLE2[key]], [x[2] for x in SEED_TABLE2[key]], mk, mfc="none", color="k",
                label=lab)
    ax.set_xlabel("DOH parameter a (Eq. 6), dimensionless")
    ax.set_ylabel("coordination number C (bonds at ε = 0.01)")
    ax.set_title("seed 003 Fig. 2: coordination against heterogeneity", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(rep / f"fig2.{fmt}") as tmp:
        fig.savefig(tmp, format=fmt, dpi=130)
    plt.close(fig)
    files["fig2"] = rep / f"fig2.{fmt}"
    # Fig. 6: G'p against a with the fit (legend below the axes: it hid the most heterogeneous points)
    fig, ax = plt.subplots(figsize=(5.5, 6))
    for s in sets:
        sel = [p for p in points if p["set"] == s]
        eb = ax.errorbar([p["a"] for p in sel], [p["G_Pa"] * 1e-6 for p in sel], yerr=[p["G_sd_Pa"] * 1e-6 for p in sel],
                         fmt=marker.get(order[s], "D"), ms=4, capsize=2, color=colour[s], label=f"{s} (this run)")
        dyn = [p for p in sel if p.get("G_dyn_Pa") is not None]
        if dyn:  # the dynamic G'p (oscillatory shear) beside the static one, same colour, open symbol
            ax.errorbar([p["a"] for p in dyn], [p["G_dyn_Pa"] * 1e-6 for p in dyn],
                        yerr=[(p.get("G_dyn_sd_Pa") or 0.0) * 1e-6 for p in dyn], fmt="D", mfc="none", ms=6,
                        capsize=2, color=eb[0].get_color(), label=f"{s}: dynamic G′ (oscillatory shear)")
    for key, mk, lab in (("vem", "s", "seed VEM (Table 2)"), ("bd", "^", "seed BD (Table 2)")):
        ax.errorbar([x[1] for x in SEED_TABLE2[key]], [x[3] for x in SEED_TABLE2[key]],
                    yerr=[x[4] for x in SEED_TABLE2[key]], fmt=mk, mfc="none", color="k", capsize=2, label=lab)
    a_all = [p["a"] for p in points] + [x[1] for x in SEED_TABLE2["vem"] + SEED_TABLE2["bd"]]
    lo, hi = min(a_all) - 0.03, max(a_all) + 0.03
    if fit is not None and math.isfinite(fit.a0):
        xs = np.linspace(max(fit.a0, lo), hi, 300)
        ax.plot(xs, fit(xs), "-", color="tab:red", label=f"power-law fit (seed eq. 7): a0 = {fit.a0:.3g} ± {fit.a0_err:.2g}, "
                f"β = {fit.beta:.3g} ± {fit.beta_err:.2g}" + ("" if fit.a0_determined else " (a0 not determined)"))
        if lo <= fit.a0 <= hi:
            ax.axvline(fit.a0, ls="--", color="tab:red", lw=0.8, label="critical DOH a0 (fit)")
    ax.axvline(0.373, ls=":", color="k", lw=0.8, label="seed a0 = 0.373")
    ax.set_xlim(lo, hi)
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("DOH parameter a (Eq. 6), dimensionless")
    ax.set_ylabel("plateau storage modulus G'p (MPa)")
    ax.set_title("seed 003 Fig. 6: G'p against DOH" + (f" ({stiffness})" if stiffness else "") + ";\n"
                 "bars: spread over the shear directions", fontsize=8)
    ax.legend(fontsize=6, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    fig.tight_layout()
    with atomic_path(rep / f"fig6.{fmt}") as tmp:  # tight: the legend below the axes is part of the figure
        fig.savefig(tmp, format=fmt, dpi=130, bbox_inches="tight")
    plt.close(fig)
    files["fig6"] = rep / f"fig6.{fmt}"
    return files


def _plot_fig5(rep, fig5, fmt):
    """Fig. 5 of 003_873b69fc71c74cf6.txt: G'p (MPa) of the most and least heterogeneous structure against kn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .._util import atomic_path

    kn = np.asarray(fig5["kn_N_per_m"])
    fig, ax = plt.subplots(figsize=(5, 4))
    for name, mk, words in (("he", "s", "most heterogeneous"), ("ho", "o", "least heterogeneous")):
        d = fig5[name]
        ax.plot(kn, np.asarray(d["G_Pa"]) * 1e-6, mk + "-", ms=5,
                label=f"{words}: {d['set']}, realization {d['index']} (a = {d['a']:.3f})")
    particle = fig5["he"]["settings"].get("stiffness") == "particle"
    seed_kn = SEED_KN if particle else SEED_KN / 2  # Table 1's kn is per ball: in series, half per contact
    for row, mk, words in ((SEED_TABLE2["bd"][-1], "s", "seed, most heterogeneous"),
                           (SEED_TABLE2["bd"][0], "o", "seed, least heterogeneous")):  # Table 2 at the seed's kn
        ax.errorbar([seed_kn], [row[3]], yerr=[row[4]], fmt=mk, mfc="none", color="k", capsize=2,
                    label=f"{words}: BD Ψ0 = {row[0]:g} mV (a = {row[1]:.3f}), Table 2")
    per = "per particle, in series" if particle else "per contact"
    ax.set_xlabel(f"normal stiffness kn (N/m, {per}); ks = kn × {fig5['he']['ks_over_kn']:.3g}")
    ax.set_ylabel("plateau storage modulus G'p (MPa), static")
    r = fig5["ratio"]
    ax.set_title(f"seed 003 Fig. 5: G'p against kn; G'p(HE) / G'p(HO) = {min(r):.3g}–{max(r):.3g} "
                 f"(seed ≈ {fig5['seed_ratio']})", fontsize=8)
    ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path = rep / f"fig5.{fmt}"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, dpi=130)
    plt.close(fig)
    return path
