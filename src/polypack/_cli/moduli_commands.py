"""``polypack moduli``: effective elastic moduli of a pack or a run's ensemble.

Classical estimates (Mori-Tanaka, self-consistent, Hashin-Shtrikman), the three-point
bulk bounds with ζ2 measured on the packs, and the RDF-dependent pair estimate (MEFM)
from the packs' partial RDFs; realizations of a run folder give means and standard
errors. Also the Figs. 8-9-style plot of 000_2cedc098acbd866b.txt (E*/E0 and μ*/μ0
against the volume fraction, CRM vs SCRM packs beside MT, HS and the bounds).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from ._generated import options_from

ESTIMATES = ("mori_tanaka", "self_consistent", "hs_lower", "hs_upper", "three_point_lower", "three_point_upper", "mefm")


def moduli_of_pack(pk, matrix, inclusions, three_point=True, pair_estimate=True):
    """Every estimate for one pack (:func:`polypack.ensemble.moduli_stage.moduli_of_pack`)."""
    from ..ensemble.moduli_stage import moduli_of_pack as _of_pack

    return _of_pack(pk, matrix, inclusions, three_point=three_point, pair_estimate=pair_estimate,
                    path="--inclusions")


def summarize(rows, matrix):
    """Mean and standard error over realizations (:func:`polypack.ensemble.moduli_stage.summarize`)."""
    from ..ensemble.moduli_stage import summarize as _summarize

    return _summarize(rows, matrix)


def study_table(folder):
    """The ``[analysis.moduli]`` table of a run folder's resolved study, or None."""
    p = Path(folder) / "study.resolved.json"
    if not p.is_file():
        return None
    table = json.loads(p.read_text(encoding="utf-8")).get("study", {}).get("analysis", {}).get("moduli")
    return table or None


def study_phases(folder):
    """``(matrix, inclusions)`` of the ``[analysis.moduli]`` table of a run folder's resolved study, or None."""
    from ..ensemble.moduli_stage import phases_of

    table = study_table(folder)
    return None if table is None else phases_of(table)


def load_packs(path):
    """A packing file, or every realization ``realizations/r*.gsd`` of a run folder."""
    from .. import io
    from ..errors import InvalidInputError

    p = Path(path)
    if p.is_dir():
        files = sorted((p / "realizations").glob("r*.gsd")) if (p / "realizations").is_dir() else sorted(p.glob("*.gsd"))
        if not files:
            raise InvalidInputError(f"{p} holds no realizations/r*.gsd (a polypack run folder) nor *.gsd files")
        return [io.read(f) for f in files], [str(f) for f in files]
    return [io.read(p)], [str(p)]


def plot_figs_8_9(curves, matrix, inclusion, fractions=None, axes=None, title=None):
    """E*/E0 and μ*/μ0 against c in the style of Figs. 8-9 of 000_2cedc098acbd866b.txt.

    ``curves`` maps a protocol label (e.g. "CRM", "SCRM") to a list of summaries
    (:func:`summarize`) at increasing volume fraction; MEFM points carry ensemble error
    bars, MT, HS bounds and the three-point bounds are drawn beside them.
    """
    import matplotlib.pyplot as plt

    from ..mechanics import hashin_shtrikman, mori_tanaka, three_point_bounds

    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    c = np.linspace(0.0, 0.65 if fractions is None else max(fractions), 60)
    mt = [mori_tanaka(matrix, inclusion, x) for x in c]
    hs = [hashin_shtrikman([matrix, inclusion], [1 - x, x]) for x in c]
    for ax, q, ref, label in ((axes[0], "young", matrix.young, "E*/E0"), (axes[1], "shear", matrix.shear, "μ*/μ0")):
        ax.plot(c, [getattr(p, q) / ref for p in mt], "k-", label="Mori-Tanaka (= HS lower)")
        ax.plot(c, [getattr(h[1], q) / ref for h in hs], "k:", label="Hashin-Shtrikman upper")
        markers = iter("osd^v")
        for name, rows in curves.items():
            xs = np.array([r["volume_fraction"] for r in rows])
            ys = np.array([r["mefm"][q + "_ratio"]["mean"] for r in rows])
            es = np.array([r["mefm"][q + "_ratio"]["stderr"] or 0.0 for r in rows])
            ax.errorbar(xs, ys, yerr=es, fmt=next(markers) + "-", capsize=3, label=f"MEFM, RDF of {name} packs")
            if all("three_point_lower" in r for r in rows):
                lo = [r["three_point_lower"][q + "_ratio"]["mean"] for r in rows]
                up = [r["three_point_upper"][q + "_ratio"]["mean"] for r in rows]
                ax.fill_between(xs, lo, up, alpha=0.15, label=f"three-point bounds (ζ2, η2 of packs), {name}")
            if "well_stirred" in rows[0]:
                ax.plot(xs, [r["well_stirred"][q + "_ratio"]["mean"] for r in rows], "--", label="MEFM, well-stirred g")
        ax.set_xlabel("inclusion volume fraction c (–)")
        ax.set_ylabel(f"{label} (–)")
        ax.legend(fontsize=7)
    if title:
        axes[0].figure.suptitle(title)
    return axes


def _phases_from_folder(own, flags):
    """``prepare`` hook: ``--matrix``/``--inclusions`` both or neither; neither: the run folder's study."""
    from ..errors import InvalidInputError

    path = own["path"]
    if (flags.get("matrix") is None) != (flags.get("inclusions") is None):
        raise InvalidInputError("give both --matrix and --inclusions, or neither (a run folder whose study has "
                                "an [analysis.moduli] table)")
    if flags.get("matrix") is None:
        table = study_table(path) if Path(path).is_dir() else None
        if table is None:
            raise InvalidInputError(
                f"{path}: give --matrix E,nu and --inclusions E,nu (only a run folder whose study has an "
                "[analysis.moduli] table provides them)")
        flags = {**flags, "matrix": table["matrix"], "inclusions": table["inclusions"]}
    return flags


_FOLDER = "Unset with a run folder: its study's \\[analysis.moduli] value."


def register(app: typer.Typer) -> None:
    @app.command()
    @options_from("mechanics", "moduli", repeat=("inclusions",), prepare=_phases_from_folder,
                  notes={"matrix": "'E,nu' (e.g. 3.01e9,0.394). " + _FOLDER,
                         "inclusions": "'E,nu', once for all species or repeated once per species. " + _FOLDER})
    def moduli(
        path: Path = typer.Argument(..., help="Packing file, or a run folder (its realizations give error bars)."),
        json_out: Optional[Path] = typer.Option(None, "--json", help="Write the summary as JSON here."),
        options: dict = None,
    ):
        """Effective moduli of a pack: MT, SC, HS, three-point bounds (zeta2, eta2 of the pack) and MEFM (its RDFs).

        The option flags are the keys of \\[analysis.moduli] in a study (same defaults).
        """
        from .._util import atomic_open, check_new_output, file_kind
        from ..mechanics import Phase

        if json_out is not None:  # checked before computing
            check_new_output(json_out, file_kind(json_out), inputs=(path,), option="--json")
        m = Phase.from_young(*options["matrix"])
        incs = [Phase.from_young(*p) for p in options["inclusions"]]
        three_point = options["three_point"]
        packs, names = load_packs(path)
        rows = []
        for pk in packs:
            rows.append(moduli_of_pack(pk, m, incs, three_point=three_point, pair_estimate=options["mefm"]))
        res = {"path": str(path), "files": names, "matrix": m.to_dict(), "inclusions": [p.to_dict() for p in incs],
               **summarize(rows, m)}
        typer.echo(f"{path}: {len(packs)} pack(s), inclusion volume fraction {res['volume_fraction']:.4f}")
        if "zeta2" in res:
            z, e = res["zeta2"], res["eta2"]
            err = "" if z["stderr"] is None else f" ± {z['stderr']:.4f}"
            typer.echo(f"  zeta2 = {z['mean']:.4f}{err}, eta2 = {e['mean']:.4f}")
        typer.echo(f"  {'estimate':20s} {'E*/E0':>16s} {'G*/G0':>16s} {'K*/K0':>10s} {'nu*':>8s}")
        for k in ESTIMATES:
            if k not in res:
                continue
            r = res[k]

            def fmt(q):
                s = r[q + "_ratio"]
                return f"{s['mean']:.4f}" + ("" if s["stderr"] is None else f" ± {s['stderr']:.4f}")

            typer.echo(f"  {k:20s} {fmt('young'):>16s} {fmt('shear'):>16s} {r['bulk_ratio']['mean']:10.4f} "
                       f"{r['poisson']['mean']:8.4f}")
        if json_out is not None:
            with atomic_open(json_out, "w") as fh:
                json.dump(res, fh, indent=1)
            typer.echo(f"  wrote {json_out}")
