"""Tests for the survivors of the independent round-3 mutation check (tools/mutants_round3.py, issue 37).

Each test pins a form that the suite left free: a one-line bug of the round-3 modules passed every
test a maintainer would run.  Oracles: closed forms of lattices, the documented limits, hand counts.
"""

import math

import numpy as np
import pytest
from _lattices import fcc, simple_cubic

import polypack as pp
from polypack import registry
from polypack.mechanics import BondNetwork, elastic_tensor

KN, KS = 100.0, 10.0


# ----------------------------------------------------------------- issue 31: rigid / floppy
def _sheets(cells=3):
    """Simple cubic lattice (d = 1) bonded along x and y only: xy sheets with no bond across z."""
    pk = simple_cubic(cells=cells)
    c = cells

    def idx(a, b, e):
        return ((a % c) * c + (b % c)) * c + (e % c)

    i, j = [], []
    for a in range(c):
        for b in range(c):
            for e in range(c):
                for d in ((1, 0, 0), (0, 1, 0)):
                    i.append(idx(a, b, e))
                    j.append(idx(a + d[0], b + d[1], e + d[2]))
    return BondNetwork.from_pairs(pk, i, j, normal_stiffness=KN, shear_stiffness=KS)


def test_one_floppy_strain_mode_is_not_rigid():
    """Sheets bonded along x and y, no rotations: only eps_33 costs no energy (no bond has a z
    component), so exactly 1 of 6 strain modes is floppy and the network is floppy, not rigid.
    Closed form per unit cell (d = 1, affine: the lattice is centrosymmetric): C11 = C22 = kn,
    C44 = C55 = ks/4 (one bond sees gamma d/2 across), C66 = ks/2 (both bonds do).  With rotations
    a uniform spin cancels the tangential loads of gamma_23 and gamma_13: 3 floppy modes."""
    net = _sheets()
    for rotations, diag, soft in [(False, [KN, KN, 0, KS / 4, KS / 4, KS / 2], 1),
                                  (True, [KN, KN, 0, 0, 0, KS / 2], 3)]:
        et = elastic_tensor(net, rotations=rotations, solver="direct")
        np.testing.assert_allclose(np.diag(et.stiffness), diag, rtol=1e-9, atol=1e-9 * KN)
        assert et.floppy_strains == soft
        assert et.rigid is False and et.status == "floppy" and f"{soft} of 6" in et.floppy_reason


def _row(gp, gpp):
    return {"storage_modulus": gp, "loss_modulus": gpp, "normal": 2, "shear": 0, "phase_angle": math.atan2(gpp, gp)}


def test_shear_assessment_limits_are_the_documented_ones():
    """_assess at each documented limit, from both sides: loss tangent G''/G' <= LOSS_TANGENT_LIMIT (1),
    G' at most (1 + STATIC_EXCESS_LIMIT) = 1.25 times the static modulus, inertial error <= 1."""
    from polypack.mechanics import dem

    assert dem.LOSS_TANGENT_LIMIT == 1.0 and dem.STATIC_EXCESS_LIMIT == 0.25 and dem.INERTIAL_ERROR_LIMIT == 1.0
    ok = dem._assess([_row(1.0, 0.9)], 1.0, 1.0, 0.5, True)
    assert ok == ("ok", [])
    for rows, g, static, inertial in [([_row(1.0, 1.5)], 1.0, 1.0, 0.5),     # G'' > G' (phase 56 deg)
                                      ([_row(1.0, 0.1)], 1.0, 1 / 1.3, 0.5),  # G' 30 % above static
                                      ([_row(1.0, 0.1)], 1.0, 1.0, 1.1),      # inertial error above 1
                                      ([_row(-1.0, 0.1)], -1.0, 1.0, math.nan)]:
        status, problems = dem._assess(rows, g, static, inertial, True)
        assert status == "not_converged" and problems, (rows, g, static, inertial)
    assert dem._assess([_row(1.0, 0.1)], 1.0, 1 / 1.2, 0.5, True)[0] == "ok"  # 20 % above static: ok


def test_bondless_records_are_counted_floppy():
    """A pack without a single bond: both mechanics records carry the summary flag floppy = 1 (the
    fraction of floppy structures is its mean), not just the status word."""
    from polypack.mechanics.stages import run_elastic, run_shear

    dilute = pp.Packing(np.array([[1.0, 1.0, 1.0], [4.0, 4.0, 4.0], [1.0, 4.0, 2.0]]), [0.5, 0.5, 0.5], 8.0)
    el = run_elastic(dilute, registry.get("analysis", "elastic").resolve({}), None)
    sh = run_shear(dilute, registry.get("analysis", "shear").resolve({}), None)
    assert el["floppy"] == 1 and el["rigid"] is False
    assert sh["floppy"] == 1 and sh["converged"] == 0


def test_not_converged_shear_is_not_floppy_and_its_inertial_error_uses_the_static_modulus():
    """100 steps per cycle on a rigid pack (G' ~ +47 % over its static limit): the record is
    not_converged, floppy = 0, no G' nor G'' to average; the inertial error is (omega H / c_s)^2 / 3
    with c_s from the *smaller* of G' and the static modulus (the overshooting G' would hide the
    error); the bulk density is rho * phi of the rescaled monodisperse pack."""
    from polypack.mechanics.stages import run_shear

    pk = pp.pack(np.full(60, 0.5), volume_fraction=0.6, seed=5)
    cap = registry.get("analysis", "shear")
    rec = run_shear(pk, cap.resolve({"epsilon": 0.05, "directions": [[2, 0]], "cycles": 2, "steps_per_cycle": 100}),
                    None)
    assert rec["status"] == "not_converged" and rec["floppy"] == 0 and rec["converged"] == 0
    assert rec["storage_modulus"] is None and rec["loss_modulus"] is None
    assert rec["measured_loss_modulus"] is not None
    gp, static = rec["measured_storage_modulus"], rec["static_storage_modulus"]
    assert gp > 1.25 * static  # the case where min() matters
    s = rec["radius_m"] / 0.5
    h = float(np.max(pk.box)) * s
    rho_bulk = rec["density"] * float(np.sum(4.0 / 3.0 * np.pi * pk.radii ** 3)) / float(np.prod(pk.box))
    want = (2.0 * np.pi * rec["frequency"] * h) ** 2 * rho_bulk / static / 3.0
    assert rec["inertial_error"] == pytest.approx(want, rel=1e-9, abs=0)


def test_discarding_every_cycle_is_refused():
    """discard_cycles must leave a cycle to fit: [0, cycles)."""
    from polypack.mechanics import dem

    assert dem.check_protocol(cycles=2, discard_cycles=1)["discard_cycles"] == 1
    with pytest.raises(pp.InvalidInputError, match=r"discard_cycles=2: must be an integer in \[0, cycles\)"):
        dem.check_protocol(cycles=2, discard_cycles=2)


def test_elastic_stage_flags_a_partly_floppy_tensor(monkeypatch):
    """The summary flag floppy counts every floppy tensor, not only the fully floppy ones: the xy
    sheets (3 of 6 strain modes floppy with rotations) give floppy = 1."""
    from polypack.mechanics import stages

    net = _sheets()
    monkeypatch.setattr(stages, "network_of", lambda packing, opts, path: (net, "distance"))
    rec = stages.run_elastic(net.packing, registry.get("analysis", "elastic").resolve({"radius": 0.0}), None)
    assert rec["floppy_strains"] == 3 and rec["status"] == "floppy" and rec["floppy"] == 1


# ----------------------------------------------------------------- issue 34: full field, voxels
def test_homogeneous_medium_gives_the_phase_young_modulus_and_poisson_ratio():
    """E = 9KG/(3K+G) and nu = (3K-2G)/(2(3K+G)) of the result are the phase's own."""
    from polypack.mechanics import Phase, homogenize

    ph = Phase.from_young(3.01e9, 0.394)
    r = homogenize(np.zeros((6, 6, 6), np.int64), ph, Phase.from_young(76e9, 0.23))
    assert r.young == pytest.approx(3.01e9, rel=1e-12, abs=0) and r.poisson == pytest.approx(0.394, rel=1e-12, abs=0)


def test_non_square_voxels_keep_a_disk_a_disk():
    """Disks (r = 0.3, c = 0.283) on a square lattice of unit cells, 32 x 16 voxels per cell (h_y = 2 h_x):
    the labels cover the disk's area (within 4 %: 2.2 % at this resolution), and its conductivity (contrast
    10) is isotropic (square symmetry; within 3 %, the discretization's 1.2 %). Voxel sizes taken from one
    axis make the disk a 2:1 ellipse (labels) or the cell a 2:1 rectangle (Green operator)."""
    from polypack.mechanics import homogenize

    pk = pp.Packing(np.array([[0.5, 0.5], [1.5, 0.5], [0.5, 1.5], [1.5, 1.5]]), [0.3] * 4, [2.0, 2.0])
    img = pp.io.voxelize(pk, (64, 32))
    assert img.spacing.tolist() == [1 / 32, 1 / 16]
    assert img.voxel_inclusion_fraction == pytest.approx(np.pi * 0.09, rel=0.04)
    k = homogenize(img, 1.0, 10.0, property="conductivity", tolerance=1e-10).conductivity
    # measured: 1.631 / 1.650 (1.2 %); the same labels on square voxels (the 2:1 rectangle) 1.736 / 1.569 (10 %)
    assert k[0, 0] == pytest.approx(k[1, 1], rel=0.03) and abs(k[0, 1]) < 1e-6


@pytest.mark.parametrize("dim", [2, 3])
def test_composite_voxel_conductivity_is_maxwell_garnett(dim):
    """The coated composite-voxel rule is the Maxwell-Garnett (Hashin-Shtrikman) form of the voxel's
    dimension: 2D k0 (k1 + k0 + phi d)/(k1 + k0 - phi d), 3D k0 (k1 + 2 k0 + 2 phi d)/(k1 + 2 k0 - phi d)."""
    from polypack.mechanics.fullfield import _coated_conductivity

    k0, k1 = 1.0, 10.0
    d = k1 - k0
    phi = np.array([0.0, 0.25, 0.5, 0.9, 1.0])
    want = (k0 * (k1 + k0 + phi * d) / (k1 + k0 - phi * d) if dim == 2
            else k0 * (k1 + 2 * k0 + 2 * phi * d) / (k1 + 2 * k0 - phi * d))
    np.testing.assert_allclose(_coated_conductivity(k0, k1, phi, dim), want, rtol=1e-13)


def test_stage_extrapolated_error_is_relative_to_the_matrix():
    """[analysis.homogenize] with a resolution series: the Richardson estimate and its error are
    both divided by the matrix modulus (recomputed from the record's own per-resolution moduli)."""
    from polypack.mechanics import Phase
    from polypack.mechanics.fullfield import richardson
    from polypack.mechanics.stages import homogenize_record

    pk = pp.pack(np.full(20, 0.5), volume_fraction=0.3, seed=2, progress=False)
    m, f = Phase.from_young(3.01e9, 0.394), Phase.from_young(76e9, 0.23)
    rec = homogenize_record(pk, m, [f], {"resolution": [8, 10, 12], "tolerance": 1e-6})
    for q in ("bulk", "shear"):
        vals = [c[q] for c in rec["convergence"]]
        e = richardson([8, 10, 12], vals)
        ref = getattr(m, q)
        got = rec["extrapolated"][q + "_ratio"]
        assert got["value"] == pytest.approx(e["value"] / ref, rel=1e-12, abs=0)
        assert got["error"] == pytest.approx(e["error"] / ref, rel=1e-12, abs=0) and got["error"] < 1.0


# ----------------------------------------------------------------- issue 35: deposition rules, profile
def test_roll_rule_drops_over_the_whole_rectangular_footprint():
    """Roll rule on a 4 x 16 footprint (400 spheres, d = 1): the first 40 spheres land on a nearly
    bare floor at their drop column (or a diameter from it), so they cover the whole long axis: the
    share in y in [5.5, 14.5] is about 9/16 (measured 0.55, 0.53, 0.48 for seeds 1-3); drop columns
    drawn on [0, Lx) for both axes give 0 there (the later spheres then pile a ridge that rolls out
    over the floor: the floor layer alone does not tell).  The surface is flat: height 6.7 (the
    ridge: 11.6).  The statistics: on_floor is the number of spheres resting at z = r."""
    pk = pp.deposit(np.full(400, 0.5), width=(4.0, 16.0), dim=3, rule="roll", seed=1)
    y = pk.positions[:40, 1]
    assert 0.35 < np.mean((y >= 5.5) & (y <= 14.5)) < 0.8
    assert pk.box[2] < 8.0
    floor = np.abs(pk.positions[:, 2] - pk.radii) < 1e-9
    assert pk.meta["on_floor"] == int(floor.sum()) and pk.meta["stuck"] == 0


def _cap(h, r):
    """Volume of a spherical cap of height h (0 <= h <= 2r)."""
    return np.pi * h * h * (3.0 * r - h) / 3.0


def test_small_fraction_profile_cuts_spheres_by_exact_caps():
    """Four columns (blocks = 2 on a 4 x 8 footprint: block edges x = 2, y = 4), each a large sphere (r = 0.5) in each of two
    layers [0, 1), [1, 2) and one small sphere (r = 0.25) cut by the layer edge z = 1 at a different
    height per column: each column's layer fractions from the cap volume pi h^2 (3r - h)/3 by hand,
    the layer's fraction pooled over the columns, its error the columns' spread (ddof = 1) over
    sqrt(4) (footprint blocks cut each axis by its own length).  An explicit split = r_max counts only the smaller spheres (radius < split)."""
    from polypack.analysis.deposits import small_fraction_profile

    zs = [1.125, 1.0, 0.875, 1.05]
    cols = [(1.0, 3.0), (1.0, 7.0), (3.0, 3.0), (3.0, 7.0)]  # y = 3 and 7: blocks 0 and 1 (not both 1)
    pos, rad = [], []
    for (x, y), z in zip(cols, zs):
        pos += [[x, y, 0.5], [x, y, 1.5], [x + 0.6, y + 0.6, z]]
        rad += [0.5, 0.5, 0.25]
    pk = pp.Packing(np.array(pos), np.array(rad), [4.0, 8.0, 2.0], periodic=(True, True, False))
    vl = 4.0 / 3.0 * np.pi * 0.125
    low = np.array([_cap(1.0 - (z - 0.25), 0.25) for z in zs])  # the small sphere's part below z = 1
    high = 4.0 / 3.0 * np.pi * 0.25 ** 3 - low
    per_col = np.c_[low / (low + vl), high / (high + vl)]
    pooled = [low.sum() / (low.sum() + 4 * vl), high.sum() / (high.sum() + 4 * vl)]
    for split in (None, 0.5):
        pr = small_fraction_profile(pk, window=(0.0, 2.0), n_layers=2, blocks=2, split=split)
        np.testing.assert_allclose(pr["fraction"], pooled, rtol=1e-12)
        np.testing.assert_allclose(pr["fraction_err"], np.std(per_col, axis=0, ddof=1) / 2.0, rtol=1e-12)


def test_small_fraction_profile_default_window_stays_four_diameters_inside():
    """Default window: from 4 d_max above the floor to 4 d_max below the free surface's lowest point."""
    from polypack.analysis.deposits import free_surface_height, small_fraction_profile

    g = np.arange(6) + 0.5
    X, Y, Z = np.meshgrid(g, g, np.arange(16) + 0.5, indexing="ij")
    pos = np.c_[X.ravel(), Y.ravel(), Z.ravel()]
    rad = np.where(pos[:, 2] < 8.0, 0.25, 0.5)
    pk = pp.Packing(pos, rad, [6.0, 6.0, 16.0], periodic=(True, True, False))
    pr = small_fraction_profile(pk, n_layers=2, blocks=2)
    assert list(pr["window"]) == pytest.approx([4.0, free_surface_height(pk) - 4.0], rel=1e-12, abs=0)


@pytest.mark.parametrize("rule", ["roll", "surface"])
def test_3d_deposit_keeps_each_sphere_with_its_species(rule):
    """A shuffled (order = random) 3D deposit of a two-species size set: every sphere keeps its own
    species (species 1 are the r = 0.25 spheres), whatever the deposition order."""
    from types import SimpleNamespace

    sizes = SimpleNamespace(radii=np.r_[np.full(60, 0.5), np.full(60, 0.25)], species=np.r_[np.zeros(60), np.ones(60)],
                            dim=3)
    pk = pp.deposit(sizes, width=4.5, seed=3, rule=rule)
    assert pk.meta["order"] == "random" and pk.n == 120
    np.testing.assert_array_equal(pk.species, (pk.radii < 0.4).astype(int))


# ----------------------------------------------------------------- issue 36: rigidity analysis
def test_backbone_shear_fabric_reads_each_shear_strains_backbone():
    """FCC (contact bonds, d = 1): the bonds along (0, 1, +-1) carry no force under eps_11 (eps b = 0)
    and every bond carries one under gamma_23; backbone_shear_fabric[0] = <n_y^2 n_z^2> over the
    gamma_23 backbone (all bonds: 2 of 6 directions at 1/4, so 1/12), recomputed from the result's
    own backbone_bonds[3] (the eps_11 backbone would give 0)."""
    from polypack.mechanics import rigidity

    net = BondNetwork.from_packing(fcc(cells=2), epsilon=1e-6)
    r = rigidity(net)
    n = np.asarray(net.normal)
    for p, (a, b) in enumerate([(1, 2), (0, 2), (0, 1)]):
        w = r.backbone_bonds[3 + p].astype(float)
        assert r.backbone_shear_fabric[p] == pytest.approx(np.sum(w * n[:, a] ** 2 * n[:, b] ** 2) / w.sum(),
                                                            rel=1e-12, abs=0)
    assert r.backbone_bonds[3].all() and not r.backbone_bonds[0].all()
    assert r.backbone_shear_fabric[0] == pytest.approx(1.0 / 12.0, rel=1e-9, abs=0)


def test_rigid_fraction_leaves_out_clusters_of_one():
    """Straight chains along x with rotations: each sphere spins freely about the chain's axis (a zero
    mode touching no bond), so no bond is rigid and every sphere is a rigid cluster of its own: the
    fraction of spheres in rigid clusters of two or more is 0 (all spheres are clusters of one)."""
    from polypack.mechanics import rigidity

    c, m = 4, 2
    pos = np.array([[a + 0.5, 2.0 * b + 0.5, 2.0 * e + 0.5] for a in range(c) for b in range(m) for e in range(m)])
    pk = pp.Packing(pos, np.full(len(pos), 0.5), [float(c), 2.0 * m, 2.0 * m])
    r = rigidity(BondNetwork.from_packing(pk, epsilon=0.01, normal_stiffness=KN, shear_stiffness=KS))
    assert not r.rigid_bonds.any() and r.n_rattlers == 0
    assert list(r.cluster_sizes) == [1] * len(pos) and r.rigid_fraction == 0.0


# ----------------------------------------------------------------- issue 30: declarations, generated flags
def test_number_checks_refuse_infinity_and_non_integers():
    """A number option refuses inf (only the *_or_inf checks take it); an integer option refuses 2.5
    (and takes 100.0 as the integer 100), in a study table as in the API."""
    from polypack.psd._capabilities import Generation

    rdf = registry.get("analysis", "rdf")
    with pytest.raises(pp.InvalidInputError, match=r"analysis.rdf.dr = inf: must be finite"):
        rdf.resolve({"r_max": 2.0, "dr": float("inf")}, "analysis.rdf")
    specs = registry.option_specs(Generation)
    with pytest.raises(pp.InvalidInputError, match=r"psd.n = 100.5: expected an integer"):
        registry.resolve_table(specs, {"n": 100.5}, "psd")
    n = registry.resolve_table(specs, {"n": 100.0}, "psd")["n"]
    assert n == 100 and isinstance(n, int)


def test_api_kwargs_renames_fields_to_their_api_names():
    """Fields declared with api= reach the public function under that name (shake_method -> method)."""
    from polypack.generate._capabilities import CRMOptions

    assert registry.api_kwargs(CRMOptions, {"shake_method": "paper", "volume_fraction": 0.5}) == \
        {"method": "paper", "volume_fraction": 0.5}


def test_number_or_word_options_are_text_flags():
    """A flag whose value may be a number or a word ("jammed", inf, a list) is a text flag read as a
    study value: --volume-fraction jammed reaches the table as "jammed", 0.55 as the number."""
    from polypack._cli._generated import _table, cli_fields, cli_type

    for kind, name, key in [("protocol", "crm", "volume_fraction"), ("protocol", "brownian", "rolling_moment"),
                            ("analysis", "windows", "window_radius")]:
        assert cli_type(cli_fields(registry.get(kind, name))[key]) is str, (name, key)
    crm = registry.get("protocol", "crm")
    assert _table(crm, {"volume_fraction": "jammed"}, "protocol")["volume_fraction"] == "jammed"
    assert _table(crm, {"volume_fraction": "0.55"}, "protocol")["volume_fraction"] == 0.55
