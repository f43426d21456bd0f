"""Bonded discrete-element dynamics under oscillatory shear (§2.1, §2.4 of 003_873b69fc71c74cf6.txt).

Flat arrays in, flat arrays out.  :func:`run` advances spheres with translations and
rotations by the central-difference (leapfrog) scheme of PFC:

    v(t + dt/2) = v(t - dt/2) + (F(t) + F_d(t)) dt / m,      x(t + dt) = x(t) + v(t + dt/2) dt,

and the same for the angular velocity with the torque and the moment of inertia.
Forces come from :func:`polypack._kernels.contacts.contact_forces`.

Local non-viscous damping, Eq. (3) of 003_873b69fc71c74cf6.txt and Eq. (4) of 003_873b69fc71c74cf6.txt, acts per component,
``F_d,k = -alpha |F_k| sign(v'_k)``, on the velocity ``v'`` relative to the imposed
shear flow ``u = gamma_dot x_g e_a`` (and on the spin relative to the flow's rotation
``gamma_dot / 2 (e_g x e_a)``), so that a sample following the drive affinely is not
damped.

Drive: the shear strain ``gamma(t) = A_k sin(omega t)`` in cycle ``k`` with an
amplitude ramped linearly over the first ``ramp`` cycles, ``A_k = A min(1, (k+1)/ramp)``.
Two boundaries (``P_MODE``):

``MODE_LEES_EDWARDS``
    A deforming periodic cell: ``h(t) = h0 + gamma(t) L_g e_a e_g^T``, so images across
    the gradient axis move with the flow (Lees-Edwards).
``MODE_PLATES``
    An orthorhombic cell periodic on the other two axes; spheres with ``kind`` 1 are
    fixed, ``kind`` 2 are translated rigidly by ``gamma(t) L_g`` along ``a`` (the upper
    plate) at constant volume.
``MODE_RELAX``
    No drive; after every step all velocities are set to zero (the seed's relaxation).

Samples (one row every ``sample_every`` steps, columns ``S_*``): time, strain, the
Love-Weber stress ``-(1/V) sum f ⊗ b`` (symmetrised) minus the kinetic term, the
shear stress from the plates' forces, the stored and kinetic energies, the cumulative
work of the drive, damping and sliding losses, bond breakages and the mean unbalanced
force.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .contacts import (A_ACTIVE, A_BREAK_SHEAR, A_BREAK_TENSION, A_FORCE_SUM, A_SHIFTSUM, A_SLIP,
                       A_STORED, A_VIRIAL, N_ACC, contact_forces)

MODE_LEES_EDWARDS = 0
MODE_PLATES = 1
MODE_RELAX = 2

#: Particle kinds.
KIND_FREE = 0
KIND_FIXED = 1
KIND_DRIVEN = 2

#: Slots of the float parameter array ``p``.
P_DT = 0
P_OMEGA = 1
P_AMPLITUDE = 2
P_RAMP = 3  # ramp cycles (>= 1)
P_ALPHA = 4  # local damping coefficient
P_MU = 5  # friction of unbonded contacts
P_VOLUME = 6
P_LENGTH = 7  # L_g, gradient-axis length (strain = displacement / L_g)
P_AXIS_A = 8  # flow axis
P_AXIS_G = 9  # gradient axis
P_MODE = 10
P_SAMPLE_EVERY = 11
P_SKIN = 12  # neighbour-list skin: stop when a pair may have moved this much
N_P = 13

#: Slots of the state array ``st`` (carried between calls).
ST_STEP = 0  # steps done
ST_WORK = 1  # cumulative work of the drive
ST_DAMP = 2  # cumulative damping loss
ST_SLIP = 3  # cumulative sliding loss
ST_BREAK_TENSION = 4
ST_BREAK_SHEAR = 5
ST_PREV_VALID = 6  # 1 once the previous step's boundary sums are stored
ST_PREV_SHIFTSUM = 7  # 9 entries: previous sum f_a shift_b
ST_PREV_PLATE = 16  # 3 entries: previous force on the driven plate
ST_GAMMA_BUILD = 19  # strain when the neighbour list was built
N_ST = 20

#: Columns of a sample row.
S_TIME = 0
S_STRAIN = 1
S_STRESS = 2  # 6 entries, Voigt order xx yy zz yz xz xy
S_PLATE_STRESS = 8
S_STORED = 9
S_KINETIC = 10
S_WORK = 11
S_DAMP = 12
S_SLIP = 13
S_BREAKS = 14
S_UNBALANCED = 15  # mean |F| over free spheres
S_CONTACT_FORCE = 16  # mean contact-force magnitude over force-carrying contacts
N_S = 17

#: Return status of :func:`run`.
STATUS_DONE = 0
STATUS_REBUILD = 1  # a neighbour pair may have moved by more than the skin

_VOIGT_A = (0, 1, 2, 1, 0, 0)
_VOIGT_B = (0, 1, 2, 2, 2, 1)


@njit(cache=True)
def strain_at(step, p):
    """Shear strain after ``step`` steps: ramped ``A_k sin(omega t)``."""
    dt = p[P_DT]
    omega = p[P_OMEGA]
    t = step * dt
    period = 2.0 * np.pi / omega
    k = np.floor(t / period)
    ramp = p[P_RAMP]
    frac = (k + 1.0) / ramp
    if frac > 1.0:
        frac = 1.0
    return p[P_AMPLITUDE] * frac * np.sin(omega * t)


@njit(cache=True)
def layer_stress(pos, h, ci, cj, cshift, cfn, cfs, a, g, edges, area, out):
    """Shear stress ``σ_ag`` in slabs ``edges[k] <= x_g < edges[k+1]`` (planar measure).

    Each contact counts with the fraction ``w`` of its branch segment (from ``x_i`` along
    ``b``) that lies in the slab: ``σ_ag = -(1 / (A Δz)) Σ w f_a b_g``, the mean over the
    slab's heights of the force per area across planes normal to ``g`` (contacts to
    plate spheres count with the part of their branch inside the slab).
    """
    nl = edges.shape[0] - 1
    for k in range(nl):
        out[k] = 0.0
    m = ci.shape[0]
    for c in range(m):
        fn = cfn[c]
        if fn == 0.0 and cfs[c, 0] == 0.0 and cfs[c, 1] == 0.0 and cfs[c, 2] == 0.0:
            continue
        i = ci[c]
        j = cj[c]
        b0 = pos[j, 0] - pos[i, 0] + h[0, 0] * cshift[c, 0] + h[0, 1] * cshift[c, 1] + h[0, 2] * cshift[c, 2]
        b1 = pos[j, 1] - pos[i, 1] + h[1, 0] * cshift[c, 0] + h[1, 1] * cshift[c, 1] + h[1, 2] * cshift[c, 2]
        b2 = pos[j, 2] - pos[i, 2] + h[2, 0] * cshift[c, 0] + h[2, 1] * cshift[c, 1] + h[2, 2] * cshift[c, 2]
        d = np.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        bg = b0 if g == 0 else (b1 if g == 1 else b2)
        ba = b0 if a == 0 else (b1 if a == 1 else b2)
        fa = fn * ba / d + cfs[c, a]
        z0 = pos[i, g]
        lo = min(z0, z0 + bg)
        hi = max(z0, z0 + bg)
        for k in range(nl):
            o = min(hi, edges[k + 1]) - max(lo, edges[k])
            if o > 0.0:
                # w * b_g = overlap length with the sign of b_g
                out[k] -= fa * (o if bg >= 0.0 else -o)
    for k in range(nl):
        out[k] /= area * (edges[k + 1] - edges[k])


@njit(cache=True)
def run(n_steps, pos, vel, omg, radii, mass, inertia, kind, pos0, h0, ci, cj, cshift, ckn, cks,
        crest, cfnb, cfsb, cstate, cfs, cfn, p, st, samples, n_sample, xbuild, layer_edges, layer_samples):
    """Advance ``n_steps`` steps (or until a neighbour-list rebuild is due).

    Parameters
    ----------
    n_steps : int
    pos, vel, omg : (N, 3) float64
        Centres (unwrapped), velocities at the half step, angular velocities; updated.
    radii, mass, inertia : (N,) float64
    kind : (N,) int64
        ``KIND_FREE``, ``KIND_FIXED`` or ``KIND_DRIVEN``.
    pos0 : (N, 3) float64
        Reference positions of the plate spheres (read for ``kind != 0``).
    h0 : (3, 3) float64
        Undeformed cell matrix.
    ci ... cfn
        Contact arrays (see :mod:`polypack._kernels.contacts`).
    p : (N_P,) float64
        Parameters (slots ``P_*``).
    st : (N_ST,) float64
        Run state (slots ``ST_*``), updated.
    samples : (K, N_S) float64
        Sample rows, filled from row ``n_sample``.
    n_sample : int
        Rows already filled.
    xbuild : (N, 3) float64
        Positions when the neighbour list was built (rebuild test).
    layer_edges : (L + 1,) float64
        Slab edges along the gradient axis for :func:`layer_stress` (fewer than 2: none).
    layer_samples : (K, L) float64
        The slab shear stresses of every sample row.

    Returns
    -------
    status : int
        ``STATUS_DONE`` or ``STATUS_REBUILD``.
    steps : int
        Steps done in this call.
    n_sample : int
        Rows filled after the call.
    """
    n = pos.shape[0]
    dt = p[P_DT]
    alpha = p[P_ALPHA]
    mu = p[P_MU]
    vol = p[P_VOLUME]
    lg = p[P_LENGTH]
    a = int(p[P_AXIS_A])
    g = int(p[P_AXIS_G])
    mode = int(p[P_MODE])
    every = int(p[P_SAMPLE_EVERY])
    skin = p[P_SKIN]
    # third axis and the sign of (e_g x e_a) along it: the flow's spin is gdot/2 * sgn e_c
    c3 = 3 - a - g
    sgn = 1.0 if (g - a) % 3 == 2 else -1.0  # e_g x e_a = +e_c iff (g, a, c) is cyclic
    force = np.zeros((n, 3))
    torque = np.zeros((n, 3))
    acc = np.zeros(N_ACC)
    h = np.empty((3, 3))
    dh = np.zeros((3, 3))
    kt = np.zeros(6)
    vold = np.zeros(3)
    for k in range(n_steps):
        step = int(st[ST_STEP])
        if mode == MODE_RELAX:
            gam = 0.0
            gam_prev = 0.0
        else:
            gam = strain_at(step, p)
            gam_prev = strain_at(step - 1, p) if step > 0 else 0.0
        dgam = gam - gam_prev
        gdot = dgam / dt
        for q in range(3):
            for r in range(3):
                h[q, r] = h0[q, r]
                dh[q, r] = 0.0
        if mode == MODE_LEES_EDWARDS:
            h[a, g] += gam * lg
            dh[a, g] = dgam * lg
        # kinematic spheres: position at t, velocity over [t - dt, t]
        if mode == MODE_PLATES:
            for i in range(n):
                if kind[i] != KIND_FREE:
                    for q in range(3):
                        pos[i, q] = pos0[i, q]
                        vel[i, q] = 0.0
                        omg[i, q] = 0.0
                    if kind[i] == KIND_DRIVEN:
                        pos[i, a] += gam * lg
                        vel[i, a] = dgam * lg / dt
        # rebuild test: largest displacement since the list was built
        if skin > 0.0:
            dmax2 = 0.0
            for i in range(n):
                dx = pos[i, 0] - xbuild[i, 0]
                dy = pos[i, 1] - xbuild[i, 1]
                dz = pos[i, 2] - xbuild[i, 2]
                d2 = dx * dx + dy * dy + dz * dz
                if d2 > dmax2:
                    dmax2 = d2
            reach = 2.0 * np.sqrt(dmax2)
            if mode == MODE_LEES_EDWARDS:
                reach += abs(gam - st[ST_GAMMA_BUILD]) * lg
            if reach > skin:
                return STATUS_REBUILD, k, n_sample
        for i in range(n):
            for q in range(3):
                force[i, q] = 0.0
                torque[i, q] = 0.0
        for q in range(N_ACC):
            acc[q] = 0.0
        sampling = every > 0 and (step % every) == 0 and n_sample < samples.shape[0]
        contact_forces(pos, vel, omg, radii, h, dh, dt, ci, cj, cshift, ckn, cks, crest, cfnb, cfsb,
                       cstate, cfs, cfn, mu, force, torque, acc, sampling)
        if sampling and layer_edges.shape[0] > 1:
            layer_stress(pos, h, ci, cj, cshift, cfn, cfs, a, g, layer_edges, vol / lg, layer_samples[n_sample])
        st[ST_BREAK_TENSION] += acc[A_BREAK_TENSION]
        st[ST_BREAK_SHEAR] += acc[A_BREAK_SHEAR]
        st[ST_SLIP] += acc[A_SLIP]
        # work of the drive over [t - dt, t] (trapezoid on the forces at both ends)
        if mode == MODE_LEES_EDWARDS:
            if st[ST_PREV_VALID] > 0.0:
                w = 0.0
                for q in range(3):
                    for r in range(3):
                        w += dh[q, r] * 0.5 * (acc[A_SHIFTSUM + 3 * q + r] + st[ST_PREV_SHIFTSUM + 3 * q + r])
                st[ST_WORK] -= w
            for q in range(9):
                st[ST_PREV_SHIFTSUM + q] = acc[A_SHIFTSUM + q]
            st[ST_PREV_VALID] = 1.0
        plate_f = 0.0
        fixed_f = 0.0
        if mode == MODE_PLATES:
            for i in range(n):
                if kind[i] == KIND_DRIVEN:
                    plate_f += force[i, a]
                elif kind[i] == KIND_FIXED:
                    fixed_f += force[i, a]
            if st[ST_PREV_VALID] > 0.0:
                st[ST_WORK] -= 0.5 * (plate_f + st[ST_PREV_PLATE]) * dgam * lg
            st[ST_PREV_PLATE] = plate_f
            st[ST_PREV_VALID] = 1.0
        # integrate the free spheres
        if sampling:
            for q in range(6):
                kt[q] = 0.0
        kin = 0.0
        damp = 0.0
        unbal = 0.0
        nfree = 0
        spin = 0.5 * gdot * sgn
        for i in range(n):
            if kind[i] != KIND_FREE:
                continue
            nfree += 1
            mi = mass[i]
            ii = inertia[i]
            f2 = 0.0
            for q in range(3):
                f = force[i, q]
                f2 += f * f
                v = vel[i, q]
                vold[q] = v
                vr = v
                if q == a:
                    vr = v - gdot * pos[i, g]
                fd = 0.0
                if vr > 0.0:
                    fd = -alpha * abs(f)
                elif vr < 0.0:
                    fd = alpha * abs(f)
                vn = v + (f + fd) * dt / mi
                damp -= fd * 0.5 * (v + vn) * dt
                vm = 0.5 * (v + vn)  # lab frame: the drive's work is counted in the lab frame
                kin += 0.5 * mi * vm * vm
                vel[i, q] = vn
                # rotation
                tq = torque[i, q]
                w = omg[i, q]
                wr = w
                if q == c3:
                    wr = w - spin
                td = 0.0
                if wr > 0.0:
                    td = -alpha * abs(tq)
                elif wr < 0.0:
                    td = alpha * abs(tq)
                wn = w + (tq + td) * dt / ii
                damp -= td * 0.5 * (w + wn) * dt
                wm = 0.5 * (w + wn)
                kin += 0.5 * ii * wm * wm
                omg[i, q] = wn
            unbal += np.sqrt(f2)
            if sampling:
                # peculiar mid-step velocity for the kinetic part of the stress
                for v6 in range(6):
                    qa = _VOIGT_A[v6]
                    qb = _VOIGT_B[v6]
                    va = 0.5 * (vel[i, qa] + vold[qa])
                    vb = 0.5 * (vel[i, qb] + vold[qb])
                    if qa == a:
                        va -= gdot * pos[i, g]
                    if qb == a:
                        vb -= gdot * pos[i, g]
                    kt[v6] += mi * va * vb
            for q in range(3):
                pos[i, q] += vel[i, q] * dt
        st[ST_DAMP] += damp
        if mode == MODE_RELAX:
            for i in range(n):
                for q in range(3):
                    vel[i, q] = 0.0
                    omg[i, q] = 0.0
        st[ST_STEP] = step + 1
        if sampling:
            row = n_sample
            samples[row, S_TIME] = step * dt
            samples[row, S_STRAIN] = gam
            # contact part plus the kinetic part (peculiar mid-step velocities, translations)
            for v6 in range(6):
                qa = _VOIGT_A[v6]
                qb = _VOIGT_B[v6]
                s = 0.5 * (acc[A_VIRIAL + 3 * qa + qb] + acc[A_VIRIAL + 3 * qb + qa])
                samples[row, S_STRESS + v6] = -(s + kt[v6]) / vol
            samples[row, S_PLATE_STRESS] = 0.5 * (fixed_f - plate_f) / (vol / lg) if mode == MODE_PLATES else 0.0
            samples[row, S_STORED] = acc[A_STORED]
            samples[row, S_KINETIC] = kin
            samples[row, S_WORK] = st[ST_WORK]
            samples[row, S_DAMP] = st[ST_DAMP]
            samples[row, S_SLIP] = st[ST_SLIP]
            samples[row, S_BREAKS] = st[ST_BREAK_TENSION] + st[ST_BREAK_SHEAR]
            samples[row, S_UNBALANCED] = unbal / nfree if nfree > 0 else 0.0
            samples[row, S_CONTACT_FORCE] = acc[A_FORCE_SUM] / acc[A_ACTIVE] if acc[A_ACTIVE] > 0 else 0.0

            n_sample += 1
    return STATUS_DONE, n_steps, n_sample


def warmup():
    """Compile the kernels of this module on a tiny input."""
    pos = np.array([[1.0, 1.0, 1.0], [2.9, 1.1, 1.0]])
    n = 2
    p = np.zeros(N_P)
    p[P_DT] = 1e-3
    p[P_OMEGA] = 2 * np.pi
    p[P_AMPLITUDE] = 1e-3
    p[P_RAMP] = 1.0
    p[P_ALPHA] = 0.9
    p[P_VOLUME] = 1000.0
    p[P_LENGTH] = 10.0
    p[P_AXIS_A] = 0
    p[P_AXIS_G] = 2
    p[P_SAMPLE_EVERY] = 1
    one = np.ones(1)
    run(3, pos, np.zeros((n, 3)), np.zeros((n, 3)), np.ones(n), np.ones(n), np.ones(n) * 0.4,
        np.zeros(n, np.int64), pos.copy(), np.eye(3) * 10.0, np.zeros(1, np.int64), np.ones(1, np.int64),
        np.zeros((1, 3)), one * 100.0, one * 10.0, one * 2.0, one * np.inf, one * np.inf,
        np.ones(1, np.int64), np.zeros((1, 3)), np.zeros(1), p, np.zeros(N_ST), np.zeros((4, N_S)), 0,
        pos.copy(), np.array([0.0, 5.0, 10.0]), np.zeros((4, 2)))
