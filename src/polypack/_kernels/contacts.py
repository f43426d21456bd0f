"""Soft-contact forces: the linear contact law with PFC contact bonds (§2.1 of 003_873b69fc71c74cf6.txt).

Shared by the bonded discrete-element dynamics (:mod:`polypack._kernels.dem`) and the
void-expansion generator.  Flat arrays in, flat arrays out.

Contacts
--------
A contact ``c`` joins sphere ``ci[c]`` to the periodic image of sphere ``cj[c]`` given by
the integer vector ``cshift[c]`` (stored as float64): the branch vector is

    b = x[j] + h @ shift - x[i],      d = |b|,      n = b / d,

with ``h`` the (3, 3) cell matrix (columns are the cell vectors; diagonal for an
orthorhombic box, one off-diagonal tilt for a Lees-Edwards cell).  The normal force
magnitude ``F_n`` is positive in compression and acts on ``j`` along ``+n``:

* a *bonded* contact (``cstate == BONDED``) follows Eq. (1) of 003_873b69fc71c74cf6.txt
  about its reference length, ``F_n = kn (rest - d)``, in compression and in tension
  (a contact bond carries tension across a gap);
* an *unbonded* contact (``CONTACT`` or ``BROKEN``) only pushes:
  ``F_n = kn max(0, r_i + r_j - d)``.

The shear force (on ``j``) is incremental, Eq. (2) of 003_873b69fc71c74cf6.txt:
``ΔF_s = -ks ΔU_s`` with ``ΔU_s`` the tangential relative displacement of the contact
point over the step.  The contact point lies half way across the overlap (or gap), so
the lever arms are ``l_i = (d + r_i - r_j) / 2`` from ``i`` and ``l_j = d - l_i`` from
``j`` (the PFC convention ``x_A + (R_A - U_n / 2) n``).  Before the increment the stored
shear force is rotated with the contact plane: projected on the new plane with its
magnitude kept, then turned about ``n`` by the mean spin of the two spheres.

Bonds break as PFC contact bonds: in tension when ``-F_n >= F_n^B``, in shear when
``|F_s| >= F_s^B``; the contact then becomes an ordinary (``BROKEN``) contact.  An
unbonded contact in compression slides when ``|F_s| > mu F_n`` (Coulomb), the shear
force being scaled back onto the cone; without overlap it carries nothing and its
shear history is cleared.  A bonded contact never slides.

Accumulators
------------
:func:`contact_forces` adds into ``force``/``torque`` and into the slots of ``acc``:
the virial ``sum f_a b_b`` (``A_VIRIAL`` + 3 a + b), the sum ``f_a shift_b`` used for
the work of a deforming cell (``A_SHIFTSUM`` + 3 a + b), the stored elastic energy
``F_n^2 / 2kn + |F_s|^2 / 2ks``, the energy dissipated by sliding, the counts of
bonds broken in tension and in shear and of contacts that carry force, and the sum of
the contact force magnitudes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Contact states (``cstate``).
CONTACT = 0
BONDED = 1
BROKEN = 2

#: Slots of the accumulator array ``acc``.
A_VIRIAL = 0  # 9 entries: sum over contacts of f_a b_b (f on j)
A_SHIFTSUM = 9  # 9 entries: sum of f_a shift_b (work of a moving cell)
A_STORED = 18
A_SLIP = 19
A_BREAK_TENSION = 20
A_BREAK_SHEAR = 21
A_ACTIVE = 22
A_FORCE_SUM = 23
N_ACC = 24


@njit(cache=True)
def contact_law(bonded, kn, ks, rest, fnb, fsb, mu, d, overlap, fs):
    """Normal force and shear-force correction of one contact (no geometry).

    Parameters
    ----------
    bonded : bool
        The contact carries a PFC contact bond.
    kn, ks : float
        Normal and shear stiffness of the contact (force per length).
    rest : float
        Reference length of the bond (only read when ``bonded``).
    fnb, fsb : float
        Normal (tensile) and shear strength of the bond (``inf``: unbreakable).
    mu : float
        Friction coefficient of unbonded contacts.
    d, overlap : float
        Centre distance and geometric overlap ``r_i + r_j - d``.
    fs : (3,) float64
        Trial shear force, already incremented; scaled in place when sliding.

    Returns
    -------
    fn : float
        Normal force, positive in compression.
    status : int
        0 intact or unbonded, 1 bond broke in tension, 2 bond broke in shear.
    slip : float
        Energy dissipated by sliding.
    """
    status = 0
    if bonded:
        fn = kn * (rest - d)
        fs2 = fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2]
        if -fn >= fnb:
            status = 1
        elif fs2 >= fsb * fsb:
            status = 2
        else:
            return fn, 0, 0.0
    # unbonded (or a bond broken just now)
    if overlap <= 0.0:
        fs[0] = 0.0
        fs[1] = 0.0
        fs[2] = 0.0
        return 0.0, status, 0.0
    fn = kn * overlap
    slip = 0.0
    fs2 = fs[0] * fs[0] + fs[1] * fs[1] + fs[2] * fs[2]
    lim = mu * fn
    if fs2 > lim * lim:
        mag = np.sqrt(fs2)
        if ks > 0.0:
            slip = lim * (mag - lim) / ks
        scale = lim / mag
        fs[0] *= scale
        fs[1] *= scale
        fs[2] *= scale
    return fn, status, slip


@njit(cache=True)
def contact_forces(pos, vel, omg, radii, h, dh, dt, ci, cj, cshift, ckn, cks, crest, cfnb, cfsb,
                   cstate, cfs, cfn, mu, force, torque, acc, full=True):
    """Update every contact over one step and add its forces and torques.

    Parameters
    ----------
    pos : (N, 3) float64
        Centres at time ``t`` (not wrapped; images come from ``cshift``).
    vel, omg : (N, 3) float64
        Translational and angular velocities over ``[t - dt, t]``.
    radii : (N,) float64
    h : (3, 3) float64
        Cell matrix at ``t``.
    dh : (3, 3) float64
        Change of the cell matrix over ``[t - dt, t]``.
    dt : float
        Time step (``0`` evaluates forces without updating the shear history).
    ci, cj : (M,) int64
    cshift : (M, 3) float64
        Integer image vector of ``j`` seen from ``i``.
    ckn, cks, crest, cfnb, cfsb : (M,) float64
        Stiffnesses, reference lengths and strengths per contact.
    cstate : (M,) int64
        ``CONTACT``, ``BONDED`` or ``BROKEN``; bonds that break are set to ``BROKEN``.
    cfs : (M, 3) float64
        Shear force on ``j`` (history), updated in place.
    cfn : (M,) float64
        Normal force (positive in compression), written.
    mu : float
        Friction coefficient of unbonded contacts.
    force, torque : (N, 3) float64
        Accumulated in place.
    acc : (N_ACC,) float64
        Accumulators (see module docstring), added to in place.
    full : bool
        Also accumulate the virial, the stored energy and the force statistics (else only
        forces, torques, the slip loss, breakages and the shift sums of imaged contacts).
    """
    m = ci.shape[0]
    ftrial = np.empty(3)
    for c in range(m):
        i = ci[c]
        j = cj[c]
        s0 = cshift[c, 0]
        s1 = cshift[c, 1]
        s2 = cshift[c, 2]
        imaged = s0 != 0.0 or s1 != 0.0 or s2 != 0.0
        bx = pos[j, 0] - pos[i, 0]
        by = pos[j, 1] - pos[i, 1]
        bz = pos[j, 2] - pos[i, 2]
        if imaged:
            bx += h[0, 0] * s0 + h[0, 1] * s1 + h[0, 2] * s2
            by += h[1, 0] * s0 + h[1, 1] * s1 + h[1, 2] * s2
            bz += h[2, 0] * s0 + h[2, 1] * s1 + h[2, 2] * s2
        d = np.sqrt(bx * bx + by * by + bz * bz)
        ri = radii[i]
        rj = radii[j]
        overlap = ri + rj - d
        state = cstate[c]
        bonded = state == BONDED
        if not bonded and overlap <= 0.0:
            cfs[c, 0] = 0.0
            cfs[c, 1] = 0.0
            cfs[c, 2] = 0.0
            cfn[c] = 0.0
            continue
        inv = 1.0 / d
        nx = bx * inv
        ny = by * inv
        nz = bz * inv
        li = 0.5 * (d + ri - rj)
        lj = d - li
        # rotate the stored shear force into the current contact plane, keeping its size
        fx = cfs[c, 0]
        fy = cfs[c, 1]
        fz = cfs[c, 2]
        f2 = fx * fx + fy * fy + fz * fz
        if f2 > 0.0:
            fdn = fx * nx + fy * ny + fz * nz
            fx -= fdn * nx
            fy -= fdn * ny
            fz -= fdn * nz
            g2 = fx * fx + fy * fy + fz * fz
            if g2 > 0.0:
                sc = np.sqrt(f2 / g2)
                fx *= sc
                fy *= sc
                fz *= sc
            # twist about n by the mean spin of the two spheres
            wn = 0.5 * ((omg[i, 0] + omg[j, 0]) * nx + (omg[i, 1] + omg[j, 1]) * ny
                        + (omg[i, 2] + omg[j, 2]) * nz) * dt
            tx = ny * fz - nz * fy
            ty = nz * fx - nx * fz
            tz = nx * fy - ny * fx
            fx += wn * tx
            fy += wn * ty
            fz += wn * tz
        if dt > 0.0:
            # relative displacement of the contact point over the step (j's image minus i)
            # v_c(j) = v_j + w_j x (-lj n), v_c(i) = v_i + w_i x (li n)
            wx = -(omg[j, 1] * nz - omg[j, 2] * ny) * lj - (omg[i, 1] * nz - omg[i, 2] * ny) * li
            wy = -(omg[j, 2] * nx - omg[j, 0] * nz) * lj - (omg[i, 2] * nx - omg[i, 0] * nz) * li
            wz = -(omg[j, 0] * ny - omg[j, 1] * nx) * lj - (omg[i, 0] * ny - omg[i, 1] * nx) * li
            ux = (vel[j, 0] - vel[i, 0] + wx) * dt
            uy = (vel[j, 1] - vel[i, 1] + wy) * dt
            uz = (vel[j, 2] - vel[i, 2] + wz) * dt
            if imaged:
                ux += dh[0, 0] * s0 + dh[0, 1] * s1 + dh[0, 2] * s2
                uy += dh[1, 0] * s0 + dh[1, 1] * s1 + dh[1, 2] * s2
                uz += dh[2, 0] * s0 + dh[2, 1] * s1 + dh[2, 2] * s2
            un = ux * nx + uy * ny + uz * nz
            k = cks[c]
            fx -= k * (ux - un * nx)
            fy -= k * (uy - un * ny)
            fz -= k * (uz - un * nz)
        ftrial[0] = fx
        ftrial[1] = fy
        ftrial[2] = fz
        kn = ckn[c]
        fn, status, slip = contact_law(bonded, kn, cks[c], crest[c], cfnb[c], cfsb[c], mu, d, overlap,
                                       ftrial)
        if status != 0:
            cstate[c] = BROKEN
            if status == 1:
                acc[A_BREAK_TENSION] += 1.0
            else:
                acc[A_BREAK_SHEAR] += 1.0
        fx = ftrial[0]
        fy = ftrial[1]
        fz = ftrial[2]
        cfs[c, 0] = fx
        cfs[c, 1] = fy
        cfs[c, 2] = fz
        cfn[c] = fn
        acc[A_SLIP] += slip
        if fn == 0.0 and fx == 0.0 and fy == 0.0 and fz == 0.0:
            continue
        # total force on j
        Fx = fn * nx + fx
        Fy = fn * ny + fy
        Fz = fn * nz + fz
        force[j, 0] += Fx
        force[j, 1] += Fy
        force[j, 2] += Fz
        force[i, 0] -= Fx
        force[i, 1] -= Fy
        force[i, 2] -= Fz
        # torques: tau_i = (li n) x (-F) = -li n x fs ; tau_j = (-lj n) x F = -lj n x fs
        tx = ny * fz - nz * fy
        ty = nz * fx - nx * fz
        tz = nx * fy - ny * fx
        torque[i, 0] -= li * tx
        torque[i, 1] -= li * ty
        torque[i, 2] -= li * tz
        torque[j, 0] -= lj * tx
        torque[j, 1] -= lj * ty
        torque[j, 2] -= lj * tz
        if imaged:
            acc[A_SHIFTSUM + 0] += Fx * s0
            acc[A_SHIFTSUM + 1] += Fx * s1
            acc[A_SHIFTSUM + 2] += Fx * s2
            acc[A_SHIFTSUM + 3] += Fy * s0
            acc[A_SHIFTSUM + 4] += Fy * s1
            acc[A_SHIFTSUM + 5] += Fy * s2
            acc[A_SHIFTSUM + 6] += Fz * s0
            acc[A_SHIFTSUM + 7] += Fz * s1
            acc[A_SHIFTSUM + 8] += Fz * s2
        if not full:
            continue
        acc[A_VIRIAL + 0] += Fx * bx
        acc[A_VIRIAL + 1] += Fx * by
        acc[A_VIRIAL + 2] += Fx * bz
        acc[A_VIRIAL + 3] += Fy * bx
        acc[A_VIRIAL + 4] += Fy * by
        acc[A_VIRIAL + 5] += Fy * bz
        acc[A_VIRIAL + 6] += Fz * bx
        acc[A_VIRIAL + 7] += Fz * by
        acc[A_VIRIAL + 8] += Fz * bz
        e = 0.0
        if kn > 0.0:
            e += 0.5 * fn * fn / kn
        ks = cks[c]
        if ks > 0.0:
            e += 0.5 * (fx * fx + fy * fy + fz * fz) / ks
        acc[A_STORED] += e
        acc[A_ACTIVE] += 1.0
        acc[A_FORCE_SUM] += np.sqrt(Fx * Fx + Fy * Fy + Fz * Fz)


def warmup():
    """Compile the kernels of this module on a tiny input."""
    pos = np.array([[0.0, 0.0, 0.0], [1.9, 0.1, 0.0]])
    vel = np.zeros((2, 3))
    omg = np.zeros((2, 3))
    radii = np.ones(2)
    h = np.eye(3) * 10.0
    dh = np.zeros((3, 3))
    one = np.ones(1)
    cfs = np.zeros((1, 3))
    contact_forces(pos, vel, omg, radii, h, dh, 1e-3, np.zeros(1, np.int64), np.ones(1, np.int64),
                   np.zeros((1, 3)), one * 100.0, one * 10.0, one * 2.0, one * np.inf, one * np.inf,
                   np.ones(1, np.int64), cfs, np.zeros(1), 0.0, np.zeros((2, 3)), np.zeros((2, 3)),
                   np.zeros(N_ACC))
