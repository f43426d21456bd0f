"""Study stage ``[analysis.moduli]``: effective elastic moduli of a particulate composite.

The realized pack is the microstructure of a composite (spheres of each species are
inclusions of their phase in a matrix, §4 of 000_2cedc098acbd866b.txt); the phases are
given in the study file.  Per realization: the classical estimates (Mori–Tanaka,
self-consistent, Hashin–Shtrikman bounds; :mod:`polypack.mechanics.effective`), the
three-point bounds with ζ2 and η2 measured on the pack
(:class:`polypack.analysis.ThreePointParameters`, one inclusion phase only) and the
RDF-dependent pair estimate (:func:`polypack.mechanics.mefm`, partial RDFs of the pack).

It needs both :mod:`polypack.analysis` (ζ2, η2) and :mod:`polypack.mechanics` (the
estimates), which are siblings of one layer, so it lives one layer up, next to the stage
runner.  ``polypack moduli FILE|RUN_DIR`` uses the same functions.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError

__all__ = ["ESTIMATES", "phases_of", "moduli_of_pack", "run_moduli", "summarize"]

#: Estimates reported per pack (keys of the result; scalars ``moduli.<estimate>.<quantity>``).
ESTIMATES = ("mori_tanaka", "self_consistent", "hs_lower", "hs_upper", "three_point_lower", "three_point_upper",
             "mefm")
QUANTITIES = ("bulk", "shear", "young", "poisson")


def phases_of(opts, path="analysis.moduli"):
    """``(matrix, [inclusion, ...])`` Phases of a resolved ``[analysis.moduli]`` table."""
    from ..mechanics import Phase

    def one(pair, what):
        try:
            return Phase.from_young(*pair)
        except InvalidInputError as exc:
            raise InvalidInputError(f"{path}.{what} = {list(pair)!r}: {exc}") from None

    incs = opts["inclusions"]
    incs = [incs] if not isinstance(incs[0], (list, tuple)) else incs
    return one(opts["matrix"], "matrix"), [one(p, "inclusions") for p in incs]


def moduli_of_pack(pk, matrix, inclusions, three_point=True, pair_estimate=True, path="inclusions"):
    """Every estimate for one pack: ``{name: Phase}`` plus ``volume_fraction``, ``fractions``,
    and ``zeta2``/``eta2`` when measured.

    ``inclusions`` has one Phase per species of the pack, or a single Phase for all.
    The three-point bounds need one inclusion phase (all species alike).
    """
    from ..analysis import ThreePointParameters
    from ..geometry import ball_volume
    from ..mechanics import hashin_shtrikman, mefm, mori_tanaka, self_consistent, three_point_bounds

    if pk.dim != 3:
        raise InvalidInputError(f"effective moduli need a 3D pack of spheres; this pack has dim={pk.dim}")
    ns = pk.n_species
    incs = list(inclusions)
    if len(incs) == 1 and ns > 1:
        incs = incs * ns
    if len(incs) != ns:
        raise InvalidInputError(
            f"{path}: the pack has {ns} species but {len(incs)} inclusion phases were given; give 1 or {ns}")
    vol = float(np.prod(pk.box))
    fr = np.array([float(np.sum(ball_volume(pk.radii[pk.species == s], 3))) / vol for s in range(ns)])
    out = {
        "volume_fraction": float(fr.sum()),
        "fractions": fr.tolist(),
        "mori_tanaka": mori_tanaka(matrix, incs, fr),
        "self_consistent": self_consistent(matrix, incs, fr),
    }
    lo, up = hashin_shtrikman([matrix, *incs], [1 - fr.sum(), *fr])
    out["hs_lower"], out["hs_upper"] = lo, up
    if three_point and all(p == incs[0] for p in incs):
        tp = ThreePointParameters().compute(pk)
        out["zeta2"], out["eta2"] = float(tp.zeta2), float(tp.eta2)
        out["three_point_lower"], out["three_point_upper"] = three_point_bounds(
            matrix, incs[0], fr.sum(), min(max(tp.zeta2, 0.0), 1.0), min(max(tp.eta2, 0.0), 1.0)
        )
    if pair_estimate:
        out["mefm"] = mefm(matrix, incs, pk)
    return out


def _phase_entry(p, matrix):
    d = {q: float(getattr(p, q)) for q in QUANTITIES}
    for q in ("bulk", "shear", "young"):
        ref = getattr(matrix, q)
        d[q + "_ratio"] = float(getattr(p, q)) / ref if ref not in (0.0, float("inf")) else None
    return d


def run_moduli(packing, opts, seed):
    """``[analysis.moduli]``: the estimates of :func:`moduli_of_pack` as plain data.

    Each estimate is a table ``{bulk, shear, young, poisson, bulk_ratio, shear_ratio,
    young_ratio}`` (ratios to the matrix: E*/E0 and μ*/μ0 of Figs. 8–9 of
    000_2cedc098acbd866b.txt); ``seed`` is unused (every estimate is deterministic).
    """
    path = "analysis.moduli"
    matrix, incs = phases_of(opts, path)
    try:
        res = moduli_of_pack(packing, matrix, incs, three_point=opts.get("three_point", True),
                             pair_estimate=opts.get("mefm", True), path=f"{path}.inclusions")
    except InvalidInputError as exc:
        msg = str(exc)
        raise InvalidInputError(msg if msg.startswith(path) else f"{path}: {msg}") from None
    out = {"estimator": "EffectiveModuli", "matrix": matrix.to_dict(), "inclusions": [p.to_dict() for p in incs],
           "volume_fraction": res["volume_fraction"], "fractions": res["fractions"]}
    for k in ("zeta2", "eta2"):
        if k in res:
            out[k] = res[k]
    for k in ESTIMATES:
        if k in res:
            out[k] = _phase_entry(res[k], matrix)
    return out


def summarize(rows, matrix):
    """Mean and standard error over realizations of every estimate (rows of :func:`moduli_of_pack`)."""
    keys = [k for k in ESTIMATES if all(k in r for r in rows)]
    res = {"n_realizations": len(rows), "volume_fraction": float(np.mean([r["volume_fraction"] for r in rows]))}

    def stat(v):
        v = np.asarray(v, dtype=np.float64)
        return {"mean": float(v.mean()), "stderr": float(v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else None}

    for extra in ("zeta2", "eta2"):
        if all(extra in r for r in rows):
            res[extra] = stat([r[extra] for r in rows])
    for k in keys:
        entry = {}
        for q, ref in (("bulk", matrix.bulk), ("shear", matrix.shear), ("young", matrix.young), ("poisson", None)):
            s = stat([getattr(r[k], q) for r in rows])
            entry[q] = s
            if ref:
                entry[q + "_ratio"] = {"mean": s["mean"] / ref, "stderr": None if s["stderr"] is None else s["stderr"] / ref}
        res[k] = entry
    return res
