"""Tangential bonds (sliding and rolling springs, rotational Brownian motion) of the BD kernel."""

from __future__ import annotations

import math

import numpy as np
import pytest

import polypack as pp
from polypack.analysis._base import OVERLAP_TOLERANCE as HARD_SPHERE_TOLERANCE  # the estimators' overlap check
from polypack._kernels import bd
from polypack.errors import InvalidInputError


def _params(dt, r_cut=2.5, width=0.004, ks=0.0, kr=0.0, roll_max=np.inf, rotate=0.0):
    q = np.zeros(bd.N_PARAMS)
    q[bd.P_DT] = dt
    q[bd.P_NOISE] = math.sqrt(2.0 * dt)
    q[bd.P_R_CUT] = r_cut
    q[bd.P_SKIN] = 0.4
    q[bd.P_BOND_WIDTH] = width
    q[bd.P_SWEEPS] = 4
    q[bd.P_PROJ_TOL] = 1e-9
    q[bd.P_TAB_LO] = 0.0
    q[bd.P_TAB_DH] = 0.1
    q[bd.P_K_SLIDE] = ks
    q[bd.P_K_ROLL] = kr
    q[bd.P_ROLL_MAX] = roll_max
    q[bd.P_ROTATE] = rotate
    return q


class _Kernel:
    """Flat kernel state of ``n`` spheres (no DLVO force: a zero table)."""

    def __init__(self, pos, box, params, seed=1, max_bonds=8):
        n = pos.shape[0]
        self.pos = np.array(pos, dtype=np.float64)
        self.box = np.full(3, float(box))
        self.params = params
        self.state = np.zeros(bd.N_STATE)
        self.istate = np.zeros(bd.N_ISTATE, np.int64)
        self.table = np.zeros(8)
        self.bonds = np.zeros((n * max_bonds, 2), np.int64)
        self.adj = np.zeros((n, max_bonds), np.int64)
        self.deg = np.zeros(n, np.int64)
        from polypack.neighbors import choose_cells

        self.ncell = choose_cells(self.box, n, max(params[bd.P_R_CUT], 1.0) + params[bd.P_SKIN])
        self.rng = np.random.SeedSequence(seed).generate_state(4, np.uint64)
        self.anchors = np.zeros((self.bonds.shape[0], 6))
        self.orient = np.zeros((n, 3))
        self.orient[:, 2] = 1.0

    def run(self, steps, noise=True):
        q = self.params if noise else self.params.copy()
        if not noise:
            q[bd.P_NOISE] = 0.0
        st = bd.run_tangential(self.pos, self.box, q, self.state, self.istate, self.table, self.bonds,
                               self.adj, self.deg, self.ncell, self.rng, steps, self.anchors, self.orient)
        assert st == bd.Status.OK

    @property
    def nb(self):
        return int(self.istate[bd.I_NBONDS])


def _dimers(m_side=4, spacing=14.0, seed=5):
    """Dimers at centre distance 2.002 (inside the 0.004 shell) on a cubic lattice, random axes."""
    rng = np.random.default_rng(seed)
    pos = []
    for ix in range(m_side):
        for iy in range(m_side):
            for iz in range(m_side):
                c = (np.array([ix, iy, iz]) + 0.5) * spacing
                u = rng.normal(size=3)
                u /= np.linalg.norm(u)
                pos += [c - 1.001 * u, c + 1.001 * u]
    return np.array(pos), m_side * spacing


def test_free_sphere_rotational_diffusion():
    """A free sphere's body axis decorrelates as <e(0).e(t)> = exp(-2 D_r t) with
    D_r = kT / (8 pi eta a^3) = (3/4) D0 / a^2 (reduced units a = D0 = 1).

    1000 independent spheres (no forces, no bonds); the mean of e(0).e(t) at
    t = 0.4 has a standard error below 0.02 (per-sphere variance <= 1/2): the 4-sigma
    tolerance 0.06 on exp(-0.6) = 0.55 is a 10 % test of D_r, against the factor 4/3 of
    a translational-friction slip (D_r = D0/a^2: 0.45) or a missing factor 2 (0.30 / 0.74).
    """
    rng = np.random.default_rng(1)
    n = 1000
    pos = rng.random((n, 3)) * 40.0
    dt = 1e-3
    k = _Kernel(pos, 40.0, _params(dt, r_cut=0.0, width=-1.0, rotate=1.0), seed=2)
    e0 = k.orient.copy()
    k.run(400)
    dot = np.sum(e0 * k.orient, axis=1)
    assert np.allclose(np.linalg.norm(k.orient, axis=1), 1.0, atol=1e-12)
    expect = math.exp(-2.0 * 0.75 * 0.4)
    assert abs(dot.mean() - expect) < 0.06, (dot.mean(), expect)
    # translational MSD unaffected by the rotations: 6 D0 t within 4 standard errors (sd of |dr|^2 ~ 6 t sqrt(2/3))
    msd = np.sum((k.pos - pos) ** 2, axis=1)
    assert abs(msd.mean() - 2.4) < 4 * 2.4 * math.sqrt(2 / 3) / math.sqrt(n)


def test_bonded_dimer_equipartition():
    """Sliding and rolling springs of free bonded dimers obey equipartition.

    Energy U = k_s |d|^2 / 2 + k_r |xi|^2 / 2 (kT = 1): the two tangential components
    of d and the two of xi (xi is normal to u - w) are quadratic degrees of freedom, so
    <|d_t|^2> = 2 / k_s and <|xi|^2> = 2 / k_r to O(1/k) (small-angle Jacobians).
    64 dimers, 60000 steps, correlation times 1 / (3.5 k_s) and 1 / (0.375 k_r) (about
    70 and 130 steps): > 30000 independent samples each, standard error < 1 %; the
    Euler-Maruyama bias is k mu dt / 2 < 1 %.  The 6 % tolerance fails for a wrong
    torque sign (no equilibrium), a missing lever arm or a factor 2 in either spring.
    """
    pos, L = _dimers()
    ks, kr = 200.0, 1000.0
    dt = 2e-5
    k = _Kernel(pos, L, _params(dt, ks=ks, kr=kr), seed=3)
    k.run(1, noise=False)  # captures the 64 bonds (their anchors u = n, w = -n)
    assert k.nb == 64
    k.run(2000)  # equilibrate (> 15 correlation times)
    d2 = []
    x2 = []
    for _ in range(300):
        k.run(200)
        b = k.bonds[: k.nb]
        r = k.pos[b[:, 1]] - k.pos[b[:, 0]]
        n = r / np.linalg.norm(r, axis=1)[:, None]
        u, w = k.anchors[: k.nb, :3], k.anchors[: k.nb, 3:]
        d = r + w - u
        dt_ = d - np.sum(d * n, axis=1)[:, None] * n
        d2.append(np.sum(dt_ ** 2, axis=1))
        x2.append(np.sum((0.5 * (u + w)) ** 2, axis=1))
    assert k.nb == 64  # the dimers never met
    d2 = np.concatenate(d2).mean()
    x2 = np.concatenate(x2).mean()
    assert abs(d2 * ks / 2 - 1) < 0.06, d2 * ks / 2
    assert abs(x2 * kr / 2 - 1) < 0.06, x2 * kr / 2
    gap = np.linalg.norm(k.pos[k.bonds[: k.nb, 1]] - k.pos[k.bonds[: k.nb, 0]], axis=1) - 2
    assert gap.min() > -1e-8 and gap.max() < 0.004 + 1e-8


def test_rolling_yield_caps_the_moment():
    """Beyond the critical rolling displacement the anchors slip: |xi| never exceeds it."""
    pos, L = _dimers(m_side=2)
    k = _Kernel(pos, L, _params(1e-4, ks=100.0, kr=100.0, roll_max=0.02), seed=4)
    k.run(1, noise=False)
    k.run(3000)  # thermal |xi| ~ sqrt(2/100) = 0.14 >> 0.02: the yield is active
    x = np.linalg.norm(0.5 * (k.anchors[: k.nb, :3] + k.anchors[: k.nb, 3:]), axis=1)
    # one step of rotation after the last yield: |xi| <= 0.02 + a few rms rotation steps sqrt(1.5e-4)
    assert x.max() < 0.02 + 5 * math.sqrt(1.5e-4)
    assert np.allclose(np.linalg.norm(k.anchors[: k.nb, :3], axis=1), 1.0, atol=1e-9)


def test_stiff_bonds_keep_the_bond_angle_flexible_ones_do_not():
    """A bonded trimer (bent chain) keeps its bond angle within the thermal width
    sqrt(kT / k) under stiff tangential springs, and diffuses away from it when the
    springs are zero (the flexible limit: free rolling)."""
    c = np.array([10.0, 10.0, 10.0])
    pos = np.array([c + [-2.001, 0, 0], c, c + [0, 2.001, 0]])  # right angle at the middle sphere

    def angle(p):
        a1 = p[0] - p[1]
        a2 = p[2] - p[1]
        return math.degrees(math.acos(a1 @ a2 / np.linalg.norm(a1) / np.linalg.norm(a2)))

    stiff = _Kernel(pos.copy(), 20.0, _params(2e-5, ks=2000.0, kr=8000.0), seed=6)
    free = _Kernel(pos.copy(), 20.0, _params(2e-5, ks=0.0, kr=0.0), seed=6)
    dev_s, dev_f = [], []
    for k, dev in ((stiff, dev_s), (free, dev_f)):
        k.run(1, noise=False)
        assert k.nb == 2
        for _ in range(50):
            k.run(400)
            dev.append(abs(angle(k.pos) - 90.0))
    # thermal angular width of the stiff chain: a few degrees; free rolling over t = 0.4 a^2/D0: tens
    assert max(dev_s) < 8.0, max(dev_s)
    assert max(dev_f) > 20.0, max(dev_f)


def test_zero_stiffness_is_the_flexible_model_bit_for_bit():
    kw = dict(seed=4, stable_window=2e-3, max_time=0.02, progress=False)
    with pytest.warns(RuntimeWarning):
        a = pp.brownian(120, 0.4, 0.0, bonds="flexible", **kw)
    with pytest.warns(RuntimeWarning):
        b = pp.brownian(120, 0.4, 0.0, bonds="tangential", sliding_stiffness=0.0, rolling_stiffness=0.0, **kw)
    assert a.meta["brownian"]["n_bonds"] > 10
    assert np.array_equal(a.positions, b.positions)
    assert a.meta["bonds"] == b.meta["bonds"]


def test_tangential_gel_lies_between_the_limits():
    """0 mV gels of 200 spheres: stiff tangential springs restructure less than free
    rolling (lower coordination than flexible) and more than rigid clusters."""
    kw = dict(seed=2, stable_window=5e-3, max_time=0.3, progress=False)
    t = pp.brownian(200, 0.4, 0.0, bonds="tangential", **kw)
    bt = t.meta["brownian"]
    assert bt["bonds"] == "tangential" and bt["tangential"]["rolling_moment"] > 0
    assert t.min_gap() >= -HARD_SPHERE_TOLERANCE  # as the estimators check (brownian.FINAL_OVERLAP_TOLERANCE)
    fl = pp.brownian(200, 0.4, 0.0, bonds="flexible", **kw).meta["brownian"]["coordination"]
    rg = pp.brownian(200, 0.4, 0.0, bonds="rigid", **kw).meta["brownian"]["coordination"]
    assert rg + 0.3 < bt["coordination"] < fl - 0.3, (rg, bt["coordination"], fl)


def test_dlvo_rolling_moment_follows_the_pull_off_force():
    """rolling_moment="dlvo": a F_adh / 100 with F_adh the whole DLVO pull-off force at contact; at 0 mV
    the van der Waals default within O(h_c/a) (exact Hamaker against Derjaguin), falling with Ψ0 by the
    double layer's π a W(h_c); recorded in meta and accepted by the study schema."""
    from polypack.generate.brownian import ROLLING_TO_ADHESION, BrownianSimulation
    from polypack.generate.dlvo import adhesion_force, dlvo_parameters
    from polypack.study import validate

    a, box = 0.25e-6, 4e-6
    pos = np.random.default_rng(1).random((60, 3)) * box
    mc = {}
    for psi in (0.0, 0.015):
        p = dlvo_parameters(psi, minimum_separation=4e-9)
        t = BrownianSimulation(pos, box, p, bonds="tangential", rolling_moment="dlvo", bond_width=4e-9).tangential
        assert t["moment_rule"] == "dlvo" and not t["default_moment"]
        assert t["rolling_moment"] == ROLLING_TO_ADHESION * a * adhesion_force(p)
        mc[psi] = t["rolling_moment_kT"]
    p0 = dlvo_parameters(0.0, minimum_separation=4e-9)
    vdw = BrownianSimulation(pos, box, p0, bonds="tangential", bond_width=4e-9).tangential["rolling_moment_kT"]
    assert 0 < 1 - mc[0.0] / vdw < 3 * 4e-9 / a
    np.testing.assert_allclose([mc[0.0], mc[0.015]], [28.59, 22.23], rtol=1e-3)  # kT (docs/brownian.md)
    with pytest.warns(RuntimeWarning, match="not stable"):  # a 2 ms run: only the recorded moment matters
        g = pp.brownian(40, 0.4, 0.012, seed=1, bonds="tangential", rolling_moment="dlvo", minimum_separation=4e-9,
                        bond_width=4e-9, max_time=2e-3, min_time=2e-3, progress=False).meta["brownian"]["tangential"]
    assert g["moment_rule"] == "dlvo" and g["rolling_moment_kT"] == pytest.approx(24.52, rel=1e-3)
    base = {"study": {"seed": 1}, "psd": {"model": "monodisperse", "n": 40}, "output": {"plots": False}}
    ok = validate({**base, "protocol": {"kind": "brownian", "bonds": "tangential", "rolling_moment": "dlvo"}})
    assert ok["protocol"]["rolling_moment"] == "dlvo"
    with pytest.raises(InvalidInputError, match='^protocol.rolling_moment = "vdw": allowed'):
        validate({**base, "protocol": {"kind": "brownian", "bonds": "tangential", "rolling_moment": "vdw"}})
    with pytest.raises(InvalidInputError, match="^rolling_moment='Dlvo': allowed"):
        pp.brownian(40, bonds="tangential", rolling_moment="Dlvo")
    with pytest.raises(InvalidInputError, match="rolling_moment='dlvo': the DLVO force .* is not attractive"):
        BrownianSimulation(pos, box, dlvo_parameters(0.1, minimum_separation=4e-9), bonds="tangential",
                           rolling_moment="dlvo", bond_width=4e-9)


def test_bad_tangential_input():
    with pytest.raises(InvalidInputError, match="rolling_moment"):
        pp.brownian(100, bonds="tangential", rolling_moment=-1.0)
    with pytest.raises(InvalidInputError, match="sliding_stiffness"):
        pp.brownian(100, bonds="tangential", sliding_stiffness=1.0)  # 1 N/m: explicit steps unstable


def test_forces_and_torques_are_the_energy_gradients():
    """F = -dU/dx and tau = -dU/dtheta of U = k_s |d|^2/2 + k_r |xi|^2/2, by central
    differences (step 1e-6: truncation ~1e-12, round-off ~1e-10, tolerance 1e-7)."""
    rng = np.random.default_rng(0)
    pos = np.array([[5.0, 5.0, 5.0], [7.0, 5.1, 5.2]])
    box = np.full(3, 20.0)
    q = np.zeros(bd.N_PARAMS)
    q[bd.P_K_SLIDE], q[bd.P_K_ROLL], q[bd.P_ROLL_MAX] = 3.0, 5.0, np.inf
    bonds = np.array([[0, 1]])
    anc = np.zeros((1, 6))
    for k, s in ((0, 1.0), (3, -1.0)):
        v = rng.normal(size=3) + [s, 0, 0]
        anc[0, k:k + 3] = v / np.linalg.norm(v)

    def energy(p, a):
        u, w = a[0, :3], a[0, 3:]
        d = p[1] - p[0] + w - u
        xi = 0.5 * (u + w)
        return 0.5 * 3.0 * d @ d + 0.5 * 5.0 * xi @ xi

    def rotated(v, th):
        t = np.linalg.norm(th)
        k = th / t
        return v * math.cos(t) + np.cross(k, v) * math.sin(t) + k * (k @ v) * (1 - math.cos(t))

    force = np.zeros((2, 3))
    torque = np.zeros((2, 3))
    bd._tangential_forces(pos, box, q, bonds, 1, anc.copy(), force, torque)
    e = 1e-6
    for i in range(2):
        for c in range(3):
            dp = np.zeros((2, 3))
            dp[i, c] = e
            assert abs(force[i, c] + (energy(pos + dp, anc) - energy(pos - dp, anc)) / (2 * e)) < 1e-7
            th = np.zeros(3)
            th[c] = e
            ap, am = anc.copy(), anc.copy()
            ap[0, 3 * i:3 * i + 3] = rotated(anc[0, 3 * i:3 * i + 3], th)
            am[0, 3 * i:3 * i + 3] = rotated(anc[0, 3 * i:3 * i + 3], -th)
            assert abs(torque[i, c] + (energy(pos, ap) - energy(pos, am)) / (2 * e)) < 1e-7
    assert np.allclose(force.sum(axis=0), 0.0)
