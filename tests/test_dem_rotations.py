"""Single-step checks of the DEM's rotations (issue 37): the kernels of
:mod:`polypack._kernels.contacts` and :mod:`polypack._kernels.dem` against rigid-body
kinematics, and the critical time step against a dense generalised eigenvalue solve.

The contact law is Eq. (1)-(2) of 003_873b69fc71c74cf6.txt; local damping Eq. (3)-(4) of
003_873b69fc71c74cf6.txt acts on the spin relative to the Lees-Edwards flow's own rotation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from polypack._kernels import contacts as C
from polypack._kernels import dem as K


def _rot(axis, theta):
    """Rotation matrix by ``theta`` about the unit vector ``axis`` (Rodrigues)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(theta) * kx + (1 - math.cos(theta)) * kx @ kx


def _pair_contact(fs, ks=7.0, kn=100.0):
    """One bonded contact 0-1 (unbreakable) with stored shear force ``fs``."""
    one = np.ones(1)
    return dict(ci=np.zeros(1, np.int64), cj=np.ones(1, np.int64), cshift=np.zeros((1, 3)), ckn=one * kn,
                cks=one * ks, crest=one * 2.0, cfnb=one * np.inf, cfsb=one * np.inf,
                cstate=np.full(1, C.BONDED, np.int64), cfs=np.array([fs], float), cfn=np.zeros(1))


def _contact_step(pos, vel, omg, radii, c, dt):
    force, torque, acc = np.zeros((2, 3)), np.zeros((2, 3)), np.zeros(C.N_ACC)
    C.contact_forces(pos, vel, omg, radii, np.eye(3) * 100.0, np.zeros((3, 3)), dt, c["ci"], c["cj"], c["cshift"],
                     c["ckn"], c["cks"], c["crest"], c["cfnb"], c["cfsb"], c["cstate"], c["cfs"], c["cfn"], 0.0,
                     force, torque, acc)
    return c["cfs"][0].copy(), force, torque


def _rigid(pos_old, omega, dt, centre):
    """Positions after a rigid rotation by ``omega dt`` about ``centre`` and the rigid velocities there."""
    R = _rot(omega, np.linalg.norm(omega) * dt)
    pos = (pos_old - centre) @ R.T + centre
    vel = np.cross(omega, pos - centre)
    return pos, vel, np.tile(omega, (2, 1)), R


def test_stored_shear_force_tilts_with_a_rigid_rotation_about_an_axis_normal_to_the_contact():
    """A bonded pair (radii 1 and 0.6) turned rigidly by 0.2 rad about an axis normal to its line of
    centres: the contact point does not slide (rigid velocities), and the stored shear force in
    the plane of the turn comes out turned with the pair, R fs, to 1e-12 (projection on the new
    contact plane with its magnitude restored is exact for this orientation).  Without the
    magnitude restored it would be cos(0.2) = 2 % short."""
    radii = np.array([1.0, 0.6])
    pos_old = np.array([[10.0, 10.0, 10.0], [11.6, 10.0, 10.0]])
    omega = np.array([0.0, 0.0, 4.0])  # normal to n = x; the shear force along y turns in the x-y plane
    dt = 0.05
    fs = np.array([0.0, 0.3, 0.0])
    pos, vel, omg, R = _rigid(pos_old, omega, dt, pos_old.mean(axis=0))
    c = _pair_contact(fs)
    c["crest"][:] = 1.6
    fs_new, _, _ = _contact_step(pos, vel, omg, radii, c, dt)
    np.testing.assert_allclose(fs_new, R @ fs, rtol=0, atol=1e-12)


@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_stored_shear_force_turns_by_omega_dt_under_a_spin_about_the_contact_normal(sense):
    """Both spheres spin with ω along the contact normal n (rigid rotation of the pair about its
    line of centres): the contact does not slide and the shear force turns about n by ω dt in the
    right-hand sense, its magnitude kept to (ω dt)²/2.  ω dt = 0.01: angle to 1e-4 (a spin not
    averaged over the two spheres, or of the wrong sign, turns it by 2 ω dt or -ω dt)."""
    radii = np.array([1.0, 1.0])
    pos = np.array([[10.0, 10.0, 10.0], [12.0, 10.0, 10.0]])
    n = np.array([1.0, 0.0, 0.0])
    dt, w = 0.002, 5.0 * sense
    omg = np.tile(w * n, (2, 1))
    fs = np.array([0.0, 0.4, -0.3])
    c = _pair_contact(fs)
    fs_new, _, _ = _contact_step(pos, np.zeros((2, 3)), omg, radii, c, dt)
    assert np.linalg.norm(fs_new) == pytest.approx(np.linalg.norm(fs), rel=1e-4, abs=0)
    assert abs(fs_new @ n) < 1e-15
    angle = math.atan2(np.cross(fs, fs_new) @ n, fs @ fs_new)
    assert angle == pytest.approx(w * dt, rel=1e-4, abs=0)


# -------------------------------------------------------------------------- one step of dem.run


def _params(dt, alpha, amplitude=0.0, omega=2.0 * np.pi, a=0, g=2):
    p = np.zeros(K.N_P)
    p[K.P_DT] = dt
    p[K.P_OMEGA] = omega
    p[K.P_AMPLITUDE] = amplitude
    p[K.P_RAMP] = 1.0
    p[K.P_ALPHA] = alpha
    p[K.P_VOLUME] = 100.0 ** 3
    p[K.P_LENGTH] = 100.0
    p[K.P_AXIS_A] = a
    p[K.P_AXIS_G] = g
    p[K.P_MODE] = K.MODE_LEES_EDWARDS
    p[K.P_SAMPLE_EVERY] = 0
    return p


def _dem_step(pos, vel, omg, radii, mass, inertia, c, p, step=0):
    st = np.zeros(K.N_ST)
    st[K.ST_STEP] = step
    status, k, _ = K.run(1, pos, vel, omg, radii, mass, inertia, np.zeros(2, np.int64), pos.copy(),
                         np.eye(3) * 100.0, c["ci"], c["cj"], c["cshift"], c["ckn"], c["cks"], c["crest"],
                         c["cfnb"], c["cfsb"], c["cstate"], c["cfs"], c["cfn"], p, st, np.zeros((1, K.N_S)), 0,
                         pos.copy(), np.zeros(0), np.zeros((1, 0)))
    assert status == K.STATUS_DONE and k == 1


def test_sphere_under_a_torque_gains_torque_times_time_over_two_fifths_m_r_squared():
    """Two touching solid spheres (radii 1 and 0.5, density 3) at rest, the bond carrying a shear
    force F along z (normal along x): one undamped step gives each sphere the spin τ dt / (⅖ m r²)
    with τ = l F about y (l: its lever arm to the contact point), m = ρ 4/3 π r³ computed here;
    the masses and moments of inertia are the DEM's own (``polypack.mechanics.dem._masses``)."""
    from polypack.mechanics.dem import _masses

    radii = np.array([1.0, 0.5])
    rho = 3.0
    m = rho * 4.0 / 3.0 * np.pi * radii ** 3
    mass, inertia = _masses(radii, rho)
    np.testing.assert_allclose(mass, m, rtol=1e-14)
    np.testing.assert_allclose(inertia, 0.4 * m * radii ** 2, rtol=1e-14)
    pos = np.array([[50.0, 50.0, 50.0], [51.5, 50.0, 50.0]])
    F = 0.25
    c = _pair_contact([0.0, 0.0, F])
    c["crest"][:] = 1.5
    vel, omg = np.zeros((2, 3)), np.zeros((2, 3))
    dt = 1e-3
    _dem_step(pos, vel, omg, radii, mass, inertia, c, _params(dt, alpha=0.0))
    li, lj = 1.0, 0.5  # contact point at the touching point
    # torque on i: (li n) x (-F e_z) = li F e_y; on j: (-lj n) x (F e_z) = lj F e_y
    np.testing.assert_allclose(omg[:, 1], [li * F * dt / (0.4 * m[0]), lj * F * dt / (0.4 * m[1] * 0.25)],
                               rtol=1e-12)
    np.testing.assert_allclose(omg[:, [0, 2]], 0.0, atol=1e-300)
    # the translations: -F and +F along z over m
    np.testing.assert_allclose(vel[:, 2], [-F * dt / m[0], F * dt / m[1]], rtol=1e-12)


@pytest.mark.parametrize("a, g", [(0, 2), (1, 0), (2, 1), (0, 1)])
def test_local_damping_leaves_a_sphere_spinning_with_the_lees_edwards_flow_alone(a, g):
    """Under the drive u = γ̇ x_g e_a the flow spins at γ̇/2 (e_g × e_a).  A bonded pair along the
    flow axis, both spheres moving and spinning with the flow, under a torque from the stored
    shear force: local damping (α = 0.7, Eq. (3) of 003_873b69fc71c74cf6.txt) must not act on
    that spin, so one step changes each spin by exactly τ dt / I, τ computed here from the shear
    force after its increment by the spin (ks d dt (ω × n)).  Damping the flow's own spin changes
    the step by α |τ| dt / I (70 %)."""
    radii = np.array([1.0, 1.0])
    n = np.zeros(3)
    n[a] = 1.0
    eg = np.zeros(3)
    eg[g] = 1.0
    c3 = 3 - a - g
    pos = np.full((2, 3), 50.0)
    pos[:, g] = 57.0  # off the origin of the gradient axis: a flow velocity
    pos[1, a] += 2.0
    dt, amp, om = 1e-3, 0.02, 2.0 * np.pi * 5.0
    step = 37
    gam = lambda s: amp * math.sin(om * s * dt)  # noqa: E731  (ramp = 1 cycle: full amplitude)
    gdot = (gam(step) - gam(step - 1)) / dt
    spin = 0.5 * gdot * np.cross(eg, n)
    assert abs(spin[c3]) > 0 and np.count_nonzero(spin) == 1
    vel = np.zeros((2, 3))
    vel[:, a] = gdot * pos[:, g]
    omg = np.tile(spin, (2, 1))
    fs0 = 0.3 * eg  # in the contact plane; its torque -l n x fs is along e_c, the axis of the flow's spin
    c = _pair_contact(fs0, ks=7.0)
    mass, inertia = np.ones(2), np.full(2, 0.4)
    _dem_step(pos, vel, omg, radii, mass, inertia, c, _params(dt, alpha=0.7, amplitude=amp, omega=om, a=a, g=g),
              step=step)
    d = 2.0
    fs1 = fs0 + 7.0 * d * dt * np.cross(spin, n)
    tau_i = np.cross(1.0 * n, -fs1)  # contact point at +n from i, force -fs on i
    tau_j = np.cross(-1.0 * n, fs1)
    assert abs(tau_i[c3]) > 0.1
    np.testing.assert_allclose(omg[0], spin + tau_i * dt / 0.4, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(omg[1], spin + tau_j * dt / 0.4, rtol=1e-12, atol=1e-15)


# ------------------------------------------------------------------ critical time step, ks = kn


def _dense_stiffness(pos, radii, box, i, j, shift, kn, ks):
    """K from the energy of each bond's contact-point displacement, built by rigid-body kinematics."""
    npart = pos.shape[0]
    Kd = np.zeros((6 * npart, 6 * npart))
    for c in range(i.size):
        b = pos[j[c]] + shift[c] * box - pos[i[c]]
        d = np.linalg.norm(b)
        n = b / d
        li = 0.5 * (d + radii[i[c]] - radii[j[c]])
        lj = d - li
        Kc = kn * np.outer(n, n) + ks * (np.eye(3) - np.outer(n, n))
        B = np.zeros((3, 6 * npart))
        for q in range(6):
            e = np.zeros(6)
            e[q] = 1.0
            # contact-point displacement of sphere j's side minus sphere i's side
            B[:, 6 * j[c] + q] += e[:3] + np.cross(e[3:], -lj * n)
            B[:, 6 * i[c] + q] -= e[:3] + np.cross(e[3:], li * n)
        Kd += B.T @ Kc @ B
    return Kd


def test_critical_time_step_equals_a_dense_generalised_eigenvalue_solve_with_ks_equal_kn():
    """2 / ω_max with ω_max² the largest eigenvalue of K u = ω² M u, K assembled here from the
    contact-point kinematics and M = diag(m, m, m, ⅖mr², ...) of solid spheres (scipy.linalg.eigh),
    on a small bidisperse random bonded pack with ks = kn (the rotational modes are then the
    highest: a moment of inertia or a rotational block off by a factor shows).  Agreement 1e-5."""
    import polypack as pp
    from polypack.mechanics import BondNetwork, critical_time_step

    rng = np.random.default_rng(4)
    sizes = np.where(rng.random(40) < 0.5, 0.5, 0.35)
    pk = pp.pack(sizes, 0.55, seed=2, progress=False)
    net = BondNetwork.from_packing(pk, epsilon=0.05, normal_stiffness=100.0, shear_stiffness=100.0)
    assert net.n_bonds > 20
    rho = 2.5
    Kd = _dense_stiffness(np.asarray(pk.positions), np.asarray(pk.radii), np.asarray(pk.box), np.asarray(net.i),
                          np.asarray(net.j), np.asarray(net.shift, float), 100.0, 100.0)
    m = rho * 4.0 / 3.0 * np.pi * np.asarray(pk.radii) ** 3
    Mdiag = np.concatenate([np.r_[mi, mi, mi, 0.4 * mi * r * r, 0.4 * mi * r * r, 0.4 * mi * r * r]
                            for mi, r in zip(m, pk.radii)])
    lam = scipy.linalg.eigh(Kd, np.diag(Mdiag), eigvals_only=True)
    dt_dense = 2.0 / math.sqrt(lam[-1])
    assert critical_time_step(net, density=rho) == pytest.approx(dt_dense, rel=1e-5, abs=0)
    # the same network with translations only would allow a longer step: the rotations matter here
    lam_t = scipy.linalg.eigh(Kd[np.ix_(*[np.flatnonzero(np.arange(Kd.shape[0]) % 6 < 3)] * 2)],
                              np.diag(Mdiag[np.arange(Mdiag.size) % 6 < 3]), eigvals_only=True)
    assert 2.0 / math.sqrt(lam_t[-1]) > 1.05 * dt_dense
