"""The contact kernel (polypack._kernels.contacts.contact_forces) on one contact of unequal spheres,
against forces and torques computed by hand from the PFC contact point ``x_i + (r_i - U_n/2) n``.

Sphere i (radius 1) spins about z at w = 2; sphere j (radius 0.5) rests 1.4 away along x (overlap
0.1), bonded at its current length (no normal force). Over dt the material point of i at the
contact point (lever 0.95) moves by w 0.95 dt along y, so the shear force on j is +ks w 0.95 dt
along y and the torques are lever x force about each centre (levers +0.95 x and -0.45 x).
Exact to round-off (1e-15 absolute on values ~1e-2).
"""

import numpy as np
import pytest

from polypack._kernels import contacts as C


def test_unequal_spheres_shear_force_and_torques_by_hand():
    pos = np.array([[2.0, 3.0, 3.0], [3.4, 3.0, 3.0]])
    radii = np.array([1.0, 0.5])
    vel = np.zeros((2, 3))
    omg = np.array([[0.0, 0.0, 2.0], [0.0, 0.0, 0.0]])
    h = np.eye(3) * 10.0
    dt, ks = 1e-3, 10.0
    one = np.ones(1)
    cfs = np.zeros((1, 3))
    cfn = np.zeros(1)
    force = np.zeros((2, 3))
    torque = np.zeros((2, 3))
    acc = np.zeros(C.N_ACC)
    C.contact_forces(pos, vel, omg, radii, h, np.zeros((3, 3)), dt, np.zeros(1, np.int64), np.ones(1, np.int64),
                     np.zeros((1, 3)), one * 100.0, one * ks, one * 1.4, one * np.inf, one * np.inf,
                     np.full(1, C.BONDED, np.int64), cfs, cfn, 0.0, force, torque, acc)
    fs = ks * 2.0 * 0.95 * dt  # 0.019
    assert cfn[0] == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(cfs[0], [0.0, fs, 0.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(force, [[0.0, -fs, 0.0], [0.0, fs, 0.0]], rtol=0, atol=1e-15)
    # tau_i = (0.95 x) x (-fs y) = -0.95 fs z ;  tau_j = (-0.45 x) x (fs y) = -0.45 fs z
    np.testing.assert_allclose(torque, [[0.0, 0.0, -0.95 * fs], [0.0, 0.0, -0.45 * fs]], rtol=0, atol=1e-15)
