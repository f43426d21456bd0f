"""Rigidity of bonded networks (``pp.mechanics.rigidity``): exact lattices, dense oracles, index theorem.

Oracles: closed forms on lattices (FCC rigid; simple cubic and diamond central-force
networks with their known floppy modes and states of self-stress; BCC's sublattice spins;
the diamond's internal shear), a dense SVD of the rigidity matrix assembled here bond by
bond (floppy count, states of self-stress, which bonds are rigid), the count of
``elastic_tensor`` (inertia of its own factorization), and its moduli (a network without
a percolating rigid cluster has G = 0).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _lattices import bcc, diamond, fcc, simple_cubic

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.mechanics import BondNetwork, elastic_tensor
from polypack.mechanics.rigidity_analysis import deviatoric_norm, fabric_tensor, rigidity

KN, KS = 100.0, 10.0


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def dense_rigidity(net, mask, ell):
    """Oracle: the rigidity matrix R of the bonds among ``mask`` (rows: the 3 components of
    the relative contact-point displacement per bond; columns u, ell*theta per particle),
    one particle's translations pinned, and the spectrum of ``H = R^T K R`` scaled by its
    diagonal. Zero modes: scaled eigenvalues below 1e-9 (elastic_tensor's definition).
    Returns (zero-mode basis (n, 6, k), rank of R, number of bonds, index map)."""
    idx = np.full(net.n, -1)
    idx[mask] = np.arange(int(mask.sum()))
    on = np.flatnonzero(mask[net.i] & mask[net.j])
    n = int(mask.sum())
    r = np.zeros((3 * on.size, 6 * n))
    w = np.zeros((3 * on.size, 3 * on.size))
    arm_i, arm_j = np.asarray(net.lever_arm_i), np.asarray(net.lever_arm_j)
    for row, c in enumerate(on):
        p, q = idx[net.i[c]], idx[net.j[c]]
        s = slice(3 * row, 3 * row + 3)
        r[s, 6 * p:6 * p + 3] -= np.eye(3)
        r[s, 6 * q:6 * q + 3] += np.eye(3)
        # delta += theta_j x a_j - theta_i x a_i = -[a_j] theta_j + [a_i] theta_i
        r[s, 6 * p + 3:6 * p + 6] += _skew(arm_i[c]) / ell
        r[s, 6 * q + 3:6 * q + 6] -= _skew(arm_j[c]) / ell
        nn = np.outer(net.normal[c], net.normal[c])
        w[s, s] = net.normal_stiffness[c] * nn + net.shear_stiffness[c] * (np.eye(3) - nn)
    r = np.delete(r, [0, 1, 2], axis=1)
    h = r.T @ w @ r
    sc = 1.0 / np.sqrt(np.diag(h))
    ev, vec = np.linalg.eigh(h * sc[:, None] * sc[None, :])
    k = int(np.count_nonzero(ev < 1e-9))
    # a gap around the threshold, or the count is not well defined
    assert ev[k] > 3e-9 and (k == 0 or ev[k - 1] < 3e-10)
    null = np.zeros((6 * n, k))
    null[3:] = vec[:, :k] * sc[:, None]
    sv = np.linalg.svd(r, compute_uv=False)
    rank = int(np.count_nonzero(sv > 1e-10 * sv[0]))
    return null.reshape(n, 6, k), rank, on.size, idx


def _loose(n=150, z=4.4, seed=5):
    """A phi = 0.4 hard-sphere fluid bonded out to coordination z (the nearest pairs first)."""
    from polypack.neighbors import pairs_within

    pk = pp.pack(np.full(n, 0.5), volume_fraction=0.4, seed=seed, progress=False)
    i, j, d = pairs_within(pk.positions, pk.radii, pk.box, a=1.6)
    gaps = np.sort(d / (pk.radii[i] + pk.radii[j]) - 1.0)
    return BondNetwork.from_packing(pk, epsilon=float(gaps[int(round(z * n / 2)) - 1]))


# ------------------------------------------------------------------ lattices
def test_fcc_is_rigid_with_one_percolating_cluster():
    """FCC (Z = 12): no floppy mode, one rigid cluster of every particle wrapping all three
    axes, both with contact bonds and with central springs; every bond in the backbone, and
    under the unit strain 11 exactly the 8 of 12 bonds with b_x != 0; no non-affine motion
    (centrosymmetric); isotropic fabric with <n_y^2 n_z^2> = 1/12."""
    net = BondNetwork.from_packing(fcc(cells=2), epsilon=1e-6)
    for central in (False, True):
        r = rigidity(net, central=central)
        assert r.floppy_modes == 0 and r.floppy_modes_floating == 0
        assert list(r.cluster_sizes) == [net.n] and np.all(r.cluster == 0)
        assert r.percolating and r.spans.all()
        assert r.largest_cluster_fraction == 1.0
    # index theorem: S = -(6N - 3M - 3) with no floppy mode
    assert r.states_of_self_stress == -(3 * net.n - net.n_bonds - 3)
    r = rigidity(net)
    assert r.states_of_self_stress == -(6 * net.n - 3 * net.n_bonds - 3)
    assert r.backbone_fraction == 1.0 and r.backbone_bond_fraction == 1.0
    assert r.backbone_coordination == pytest.approx(12.0)
    bx = np.abs(net.normal[:, 0]) > 1e-9
    np.testing.assert_array_equal(r.backbone_bonds[0], bx)
    assert bx.mean() == pytest.approx(2 / 3)
    assert r.nonaffinity < 1e-20
    np.testing.assert_allclose(r.fabric, np.eye(3) / 3, atol=1e-12)
    assert r.fabric_anisotropy < 1e-12
    np.testing.assert_allclose(r.shear_fabric, 1 / 12, rtol=1e-12)


def test_central_simple_cubic_lines_and_self_stress():
    """Simple cubic with central springs, L^3 sites: every line of bonds carries a state of
    self-stress (uniform tension), S = 3 L^2, and slides along itself at no cost, F = 3 L^2
    - 3 (global translations pinned). No triangle: every bar is its own rigid body, nothing
    percolates."""
    L = 3
    net = BondNetwork.from_packing(simple_cubic(cells=L), epsilon=1e-6)
    r = rigidity(net, central=True, samples=16)
    assert r.floppy_modes == 3 * L ** 2 - 3
    assert r.states_of_self_stress == 3 * L ** 2
    assert r.cluster_sizes.max() == 2 and not r.percolating
    assert r.isostatic_coordination == 6.0
    # Hutchinson: the participations sum to the number of floppy modes (16 samples: sd ~ 6 %)
    assert np.nansum(r.participation) == pytest.approx(r.floppy_modes, rel=0.3)


def test_central_diamond_zero_modes():
    """Diamond with central springs (Z = 4 < 6): per primitive cell 6 unknowns and 4 bonds,
    so 2 zero modes at every wave vector except q = 0, where the 4 bonds of a site fix only
    the 3 components of the relative sublattice shift (sum n_k = 0: one state of
    self-stress, uniform tension). On N sites (N/2 cells): F = 2 (N/2 - 1) = N - 2, S = 1.
    With contact bonds (rotations) it is isostatic, 6N = 3M: F - S = -3."""
    net = BondNetwork.from_packing(diamond(cells=2), epsilon=1e-6)
    r = rigidity(net, central=True, samples=16)
    assert r.floppy_modes == net.n - 2
    assert r.states_of_self_stress == 1
    assert not r.percolating
    rc = rigidity(net)
    assert rc.floppy_modes - rc.states_of_self_stress == 6 * net.n - 3 * net.n_bonds - 3 == -3
    assert rc.isostatic_coordination == 4.0 and net.coordination == pytest.approx(4.0)


def test_diamond_nonaffinity_closed_form():
    """Under gamma_23 the diamond's sublattices shift by +-u/2 along x, u = d (kn-ks) /
    (sqrt3 (kn+2ks)) per unit strain (docs/mechanics.md), so Gamma = u^2 / (4 d^2) =
    (kn-ks)^2 / (12 (kn+2ks)^2) in each shear plane; axial strains relax nothing."""
    net = BondNetwork.from_packing(diamond(cells=2), epsilon=1e-6)
    r = rigidity(net)
    want = (KN - KS) ** 2 / (12 * (KN + 2 * KS) ** 2)
    np.testing.assert_allclose(r.nonaffinity_modes[3:], want, rtol=1e-8)
    assert r.nonaffinity == pytest.approx(want, rel=1e-8)
    np.testing.assert_allclose(r.nonaffinity_modes[:3], 0.0, atol=1e-12)


def test_bcc_sublattice_spins():
    """BCC with contact bonds: 3 floppy modes, opposite uniform spins of the two sublattices
    (docs/mechanics.md); in them no bonded pair moves as one body, so every particle is a
    rigid cluster of its own and nothing percolates, while the load still runs through
    every bond (Z = 8 > 4: rigid in translation)."""
    net = BondNetwork.from_packing(bcc(cells=2), epsilon=1e-6)
    et = elastic_tensor(net, solver="direct", floppy_samples=8)
    r = rigidity(net, et)
    assert r.floppy_modes == et.floppy_modes == 3
    assert not r.rigid_bonds.any() and list(r.cluster_sizes) == [1] * net.n
    assert not r.percolating
    assert r.backbone_bond_fraction == 1.0
    # the floppy space is the 3 spins: every particle carries the same share, 3 / N
    np.testing.assert_allclose(np.nansum(r.participation), 3.0, rtol=0.5)


# ------------------------------------------------------- small rigid bodies
def _with_bodies():
    """A floppy wrapping BCC lattice (contact bonds: 3 spin modes) plus, unbonded to it, a
    dimer, a triangle and a tetrahedron of small spheres touching each other."""
    base = bcc(cells=2)
    lat = BondNetwork.from_packing(base, epsilon=1e-6)
    c = 0.5 * np.asarray(base.box)
    r0 = 0.05
    tet = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]) * (r0 / np.sqrt(2.0))
    tri = np.array([[0, 0, 0], [2 * r0, 0, 0], [r0, np.sqrt(3) * r0, 0]])
    dim = np.array([[0, 0, 0], [0, 0, 2 * r0]])
    # the tetrahedron straddles the periodic boundary (its rigid turns need unwrapped positions)
    extra = np.vstack([tet, c + [-0.6, 0.2, -0.4] + tri, c + [0.2, -0.7, 0.1] + dim])
    pos = np.vstack([np.asarray(base.positions), extra]) % np.asarray(base.box)
    rad = np.concatenate([base.radii, np.full(len(extra), r0)])
    pk = pp.Packing(pos, rad, base.box)
    n0 = base.n
    tet_i = n0 + np.arange(4)
    tri_i = n0 + 4 + np.arange(3)
    dim_i = n0 + 7 + np.arange(2)
    pairs = [(a, b) for k, a in enumerate(tet_i) for b in tet_i[k + 1:]]
    pairs += [(tri_i[0], tri_i[1]), (tri_i[1], tri_i[2]), (tri_i[0], tri_i[2]), (dim_i[0], dim_i[1])]
    i = np.concatenate([lat.i, [p[0] for p in pairs]])
    j = np.concatenate([lat.j, [p[1] for p in pairs]])
    net = BondNetwork.from_pairs(pk, i, j, normal_stiffness=KN, shear_stiffness=KS)
    return net, tet_i, tri_i, dim_i


def test_dimer_triangle_tetrahedron_contact_bonds():
    """Contact bonds (ball joints, no moment): a dimer has one bond per sphere (rattlers,
    -1); each sphere of a triangle spins about the line through its two contact points
    (3 floppy modes, three clusters of one); a tetrahedron (6 bonds on 4 bodies: 24 - 18 =
    6 rigid motions) is one rigid cluster. The lattice keeps its own 3 floppy modes."""
    net, tet_i, tri_i, dim_i = _with_bodies()
    r = rigidity(net, samples=32)
    assert r.floppy_modes == 3
    assert r.floppy_modes_floating == 3
    assert np.all(r.cluster[dim_i] == -1) and r.rattlers[dim_i].all()
    assert len(set(r.cluster[tet_i])) == 1 and r.cluster_sizes[r.cluster[tet_i[0]]] == 4
    assert len(set(r.cluster[tri_i])) == 3 and np.all(r.cluster_sizes[r.cluster[tri_i]] == 1)
    # the participation: none in the rigid tetrahedron (its rigid turns removed), the 3 spins in the triangle
    assert np.nanmax(r.participation[tet_i]) < 1e-12
    assert r.participation[tri_i].sum() == pytest.approx(3.0, rel=0.4)
    # floating bodies carry no load
    assert not r.backbone[np.concatenate([tet_i, tri_i, dim_i])].any()


def test_dimer_triangle_tetrahedron_central():
    """Central springs (points, bars): the dimer is a rigid bar, the triangle and the
    tetrahedron rigid bodies, none with an internal floppy mode."""
    net, tet_i, tri_i, dim_i = _with_bodies()
    r = rigidity(net, central=True, samples=16)
    assert r.floppy_modes_floating == 0
    for ids, size in ((tet_i, 4), (tri_i, 3), (dim_i, 2)):
        assert len(set(r.cluster[ids])) == 1
        assert r.cluster_sizes[r.cluster[ids[0]]] == size


def test_rigid_slab_wraps_two_axes_only():
    """FCC with the bonds through the z boundary cut: a rigid slab that wraps x and y but
    not z does not percolate (every periodic axis is required)."""
    lat = BondNetwork.from_packing(fcc(cells=2), epsilon=1e-6)
    net = lat.select(lat.shift[:, 2] == 0)
    r = rigidity(net)
    assert list(r.cluster_sizes) == [net.n]
    assert r.spans.tolist() == [True, True, False]
    assert not r.percolating
    assert rigidity(lat).percolating


def test_hinged_triangles_stay_two_bodies():
    """Two central-force triangles that share only a bond hinge about it: two rigid bodies
    of 3, not one of 4 (a simple cubic face with one diagonal)."""
    pk = simple_cubic(cells=4)
    lat = BondNetwork.from_packing(pk, epsilon=1e-6)
    pos = np.asarray(pk.positions)
    p = 0
    qxy = int(np.flatnonzero(np.all(np.isclose(pos, pos[p] + [1.0, 1.0, 0.0]), axis=1))[0])
    net = BondNetwork.from_pairs(pk, np.append(lat.i, p), np.append(lat.j, qxy), normal_stiffness=KN,
                                 shear_stiffness=KS)
    r = rigidity(net, central=True, samples=16)
    assert np.sort(r.cluster_sizes)[-2:].tolist() == [3, 3]


# ------------------------------------------------------------- random packs
# (N = 100, seeds whose spectrum has a clear gap at the 1e-9 threshold; at N = 150, seed 5
# at Z = 3.8 has a soft mode at 1.6e-9, where "floppy" depends on the threshold). Z = 3.8:
# 6 % rigid bonds, no percolation; Z = 4.0: largest rigid cluster 55 %; Z = 5.5: 99 %.
@pytest.mark.parametrize("z,seed", [(3.8, 5), (4.0, 7), (5.5, 6)])
def test_count_clusters_and_self_stress_against_dense_svd(z, seed):
    """Random networks around the isostatic point: the floppy count equals elastic_tensor's
    and the dense SVD's, the states of self-stress the dense left null space
    (S = 3M - rank), and the rigid bonds exactly those whose two particles turn alike in
    every vector of the dense null basis."""
    net = _loose(100, z, seed)
    et = elastic_tensor(net, solver="direct", floppy_samples=8)
    r = rigidity(net, et)
    assert r.floppy_modes == et.floppy_modes
    mask = r.active
    ell = float(np.mean(net.packing.radii))
    null, rank, m_a, idx = dense_rigidity(net, mask, ell)
    assert r.floppy_modes == null.shape[2]
    if rank == 6 * int(mask.sum()) - 3 - null.shape[2]:  # no soft mode between the two thresholds
        assert r.states_of_self_stress == 3 * m_a - rank
    on = mask[net.i] & mask[net.j]
    w = null[:, 3:, :]
    amp = np.abs(w).max() if null.shape[2] else 1.0
    dw = np.linalg.norm(w[idx[net.j[on]]] - w[idx[net.i[on]]], axis=1).max(axis=1) if null.shape[2] else 0 * idx[net.i[on]]
    np.testing.assert_array_equal(r.rigid_bonds[on], dw < 1e-6 * amp)
    # its own factorization (given a tensor without samples) agrees
    r2 = rigidity(net, elastic_tensor(net, solver="direct"))
    assert r2.floppy_modes == r.floppy_modes
    np.testing.assert_array_equal(r2.rigid_bonds, r.rigid_bonds)


def test_rigidity_percolation_matches_the_modulus():
    """Diluting a phi = 0.4 network through the isostatic point Z_c = 4: below it no rigid
    cluster spans the box and the relaxed shear modulus vanishes; above it one does and G > 0."""
    lo, hi = _loose(300, 3.5, seed=5), _loose(300, 4.6, seed=5)
    rl, rh = rigidity(lo), rigidity(hi)
    assert not rl.percolating and rl.elastic.shear_modulus < 1e-8 * rl.elastic.affine_shear_modulus
    assert rh.percolating and rh.elastic.shear_modulus > 1e-3 * rh.elastic.affine_shear_modulus
    assert rh.largest_cluster_fraction > 0.5 > rl.largest_cluster_fraction
    assert rh.backbone_coordination > 4.0
    # Hutchinson estimate of the count from the participations (64 samples: sd ~ 3 %)
    r64 = rigidity(hi, samples=64)
    assert np.nansum(r64.participation) == pytest.approx(r64.floppy_modes, rel=0.15)


def test_fabric_helpers():
    n = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    np.testing.assert_allclose(fabric_tensor(n), np.eye(3) / 3)
    f = fabric_tensor(n, [2, 1, 1])  # eigenvalues 1/2, 1/4, 1/4: a = 1/4 ... norm sqrt(1/24)
    assert deviatoric_norm(f) == pytest.approx(np.sqrt((1 / 6) ** 2 + 2 * (1 / 12) ** 2))


def test_public_name_is_the_function():
    """``pp.mechanics.rigidity`` stays the function once every mechanics module is imported
    (a submodule of the same name would shadow it)."""
    import polypack.mechanics.stages  # noqa: F401
    import polypack.mechanics.rigidity_analysis  # noqa: F401

    assert callable(pp.mechanics.rigidity) and pp.mechanics.rigidity is rigidity


def test_bad_input():
    net = BondNetwork.from_packing(fcc(cells=2), epsilon=1e-6)
    with pytest.raises(InvalidInputError, match="force_fraction"):
        rigidity(net, force_fraction=0)
    with pytest.raises(InvalidInputError, match="samples"):
        rigidity(net, samples=0)
    with pytest.raises(InvalidInputError, match="BondNetwork"):
        rigidity("net")
    with pytest.raises(InvalidInputError, match="elastic does not belong"):
        rigidity(net, elastic_tensor(BondNetwork.from_packing(fcc(cells=3), epsilon=1e-6)))
    with pytest.raises(InvalidInputError, match="floppy_samples"):
        elastic_tensor(net, floppy_samples=-1)


# ------------------------------------------------------------- study stage
def _study(analysis, **protocol):
    return {
        "study": {"name": "rig", "seed": 5, "realizations": 2},
        "psd": {"model": "monodisperse", "d": 1.0, "n": 60},
        "protocol": {"kind": "crm", "volume_fraction": 0.6, **protocol},
        "analysis": analysis,
        "output": {"plots": False},
    }


def test_rigidity_stage_matches_the_direct_api_and_reuses_the_tensor(tmp_path):
    """[analysis.rigidity] beside [analysis.elastic]: the summary columns equal the direct
    API on the pack read back from the GSD file, and the elastic stage's tensor (with its
    floppy-space samples) is reused, not recomputed."""
    import csv
    import json

    from polypack.mechanics import stages

    out = tmp_path / "run"
    opts = {"epsilon": 0.05, "normal_stiffness": 50.0}
    pp.ensemble.run_study(_study({"elastic": dict(opts), "rigidity": dict(opts, force_fraction=0.5)}), out,
                          progress=False)
    with open(out / "summary.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 and not stages._LAST  # the cache is emptied once used
    for k, row in enumerate(rows):
        pk = pp.io.read(out / "realizations" / f"r{k:04d}.gsd")
        net = BondNetwork.from_packing(pk, epsilon=0.05, normal_stiffness=50.0, shear_stiffness=5.0)
        r = rigidity(net, elastic_tensor(net, radius=0.25e-6, floppy_samples=8), force_fraction=0.5)
        for col, want in (("floppy_modes", r.floppy_modes), ("states_of_self_stress", r.states_of_self_stress),
                          ("largest_cluster_fraction", r.largest_cluster_fraction),
                          ("backbone_fraction", r.backbone_fraction),
                          ("backbone_coordination", r.backbone_coordination),
                          ("excess_coordination", r.backbone_coordination - 4.0),
                          ("percolating", int(r.percolating)), ("nonaffinity", r.nonaffinity),
                          ("shear_fabric.1", r.shear_fabric[1]), ("backbone_shear_fabric.2", r.backbone_shear_fabric[2]),
                          ("nonaffinity_modes.4", r.nonaffinity_modes[4])):
            assert float(row[f"rigidity.{col}"]) == pytest.approx(want, rel=1e-8, abs=1e-12), col
        rec = json.loads((out / "realizations" / f"r{k:04d}.json").read_text())
        assert rec["analysis"]["rigidity"]["elastic_reused"] is True
    # alone (no elastic stage) it computes the tensor itself, with the same numbers
    out2 = tmp_path / "alone"
    pp.ensemble.run_study(_study({"rigidity": dict(opts, force_fraction=0.5)}), out2, progress=False)
    rec = json.loads((out2 / "realizations" / "r0000.json").read_text())["analysis"]["rigidity"]
    assert rec["elastic_reused"] is False
    assert rec["backbone_coordination"] == pytest.approx(float(rows[0]["rigidity.backbone_coordination"]), rel=1e-8)


def test_rigidity_stage_on_a_floppy_pack_finishes():
    """A phi = 0.3 pack bonded at epsilon = 0.01 has no wrapping cluster: no percolation, no
    backbone, and the record still holds numbers (no NaN)."""
    from polypack.mechanics.stages import run_rigidity

    pk = pp.pack(np.full(60, 0.5), volume_fraction=0.3, seed=3, progress=False)
    out = run_rigidity(pk, {"epsilon": 0.01}, None)
    assert out["percolating"] == 0 and out["backbone_fraction"] == 0.0
    # not a single bond (a dilute pack): a floppy record, not an error that stops the study
    dilute = pp.Packing(np.array([[1.0, 1, 1], [5, 5, 5]]), np.full(2, 0.5), np.full(3, 10.0))
    out = run_rigidity(dilute, {"epsilon": 0.01}, None)
    assert out["status"] == "floppy" and out["percolating"] == 0 and out["n_bonds"] == 0


@pytest.mark.parametrize("table,msg", [({"force_fraction": 0}, "force_fraction"), ({"samples": 0}, "samples"),
                                       ({"bogus": 1}, "bogus")])
def test_rigidity_stage_bad_options(table, msg):
    from polypack.study import validate

    data = _study({"rigidity": table})
    with pytest.raises(InvalidInputError, match=msg):
        validate(data)


def test_floppy_strain_modes_have_no_backbone():
    """A straight chain wrapping x (rigid only against stretching along x): under eps_11 every
    bond carries the same force (backbone = all bonds); under gamma_13 and gamma_12 the chain
    tilts at no cost, its relaxed forces are round-off, and the backbone is empty (the floor
    at 1e-4 of the affine force, not a fraction of the mean of round-off)."""
    n = 6
    pos = np.column_stack([np.arange(n) + 0.5, np.full(n, 2.0), np.full(n, 2.0)])
    pk = pp.Packing(pos, np.full(n, 0.5), np.array([float(n), 4.0, 4.0]))
    net = BondNetwork.from_packing(pk, epsilon=1e-6)
    assert net.n_bonds == n
    r = rigidity(net)
    assert r.backbone_bonds[0].all()
    assert not r.backbone_bonds[1].any() and not r.backbone_bonds[2].any()  # no affine force at all
    # gamma_13, gamma_12 load every bond affinely, but the chain tilts at no cost: round-off only
    assert r.elastic.stiffness[4, 4] == 0.0 and r.elastic.stiffness[5, 5] == 0.0
    assert not r.backbone_bonds[4].any() and not r.backbone_bonds[5].any()
    # each sphere has two collinear ball joints: it spins about the chain axis on its own,
    # so no bond is rigid and nothing percolates, though the chain carries tension
    assert not r.rigid_bonds.any() and not r.percolating


def test_viewer_fields_reach_the_report(tmp_path):
    """The report's viewer takes the backbone, rigid-cluster, non-affine and participation
    fields of a pack (finite, one per sphere; categories for backbone and clusters)."""
    from polypack.report.viewer import particle_fields

    net, tet_i, tri_i, dim_i = _with_bodies()
    r = rigidity(net, samples=8)
    f = r.viewer_fields()
    assert set(f) == {"backbone", "rigid_cluster", "nonaffine_displacement", "floppy_participation"}
    assert f["rigid_cluster"][dim_i].tolist() == [11, 11] and f["backbone"][tet_i].sum() == 0
    enc = particle_fields(net.packing, coordination=False, fields=f)
    assert enc["backbone"]["kind"] == "category" and enc["rigid_cluster"]["kind"] == "category"
    assert enc["nonaffine_displacement"]["kind"] == "scale"
    pp.io.write(tmp_path / "p.gsd", net.packing)
    html = pp.report.report(tmp_path / "p.gsd", tmp_path / "p.html", fields=f, color="backbone")
    assert Path(html).exists() and "rigid_cluster" in Path(html).read_text()
    with pytest.raises(InvalidInputError, match="mode"):
        r.viewer_fields("44")
