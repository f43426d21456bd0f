"""Colloidal gels by Brownian dynamics with DLVO forces (§2.2 of 003_873b69fc71c74cf6.txt).

Equal spheres of radius ``a`` in a periodic cube of edge Eq. (5) of
003_873b69fc71c74cf6.txt, ``L = a (4 N π / (3 Φ))^(1/3)``, move by free-draining
overdamped Brownian dynamics (Ermak & McCammon 1978)::

    r(t + Δt) = r(t) + (D0 / kT) F Δt + sqrt(2 D0 Δt) ξ,     D0 = kT / (6 π η a)

with Stokes drag, Brownian displacements and DLVO pair forces
(:mod:`polypack.generate.dlvo`: Hamaker van der Waals + constant-potential double
layer).  The numerical engine is :mod:`polypack._kernels.bd`.

Coagulation rule
----------------
The primary minimum (about -420 kBT deep with the defaults, at the 0.4 nm minimum
separation) cannot be resolved with steps that resolve Brownian motion over a
Debye length, and nothing escapes it.  Pairs that reach it are therefore **bonded
irreversibly**: an unbonded pair whose surface separation falls below
``bond_width`` (default 1 nm, where the well is still more than 150 kBT deep) is
bonded.  Unbonded pairs feel the resolved DLVO force out to the cutoff; on the
steep inner side of the barrier, where one step would carry a pair through contact,
the attraction is capped so that a step closes at most a quarter of the gap.  What
a bond constrains is the bond model ``bonds``:

* ``"rigid"``: bonded spheres can neither roll nor slide on each other
  (the seed's BD structures come from the "coagulation ... to stiff particle
  structures" of Hütter's model, §2.2 of 003_873b69fc71c74cf6.txt).  Every bonded cluster is a
  rigid body and moves by free-draining Brownian cluster dynamics: translation with
  friction ``n ζ`` (``ζ = 6π η a``), rotation about its centre with the friction
  tensor ``Ξ = ζ Σ_i (|u_i|² I - u_i u_iᵀ) + n (8π η a³) I`` (``u_i`` = offsets from
  the centre), drift from the summed DLVO force and torque, Brownian noise of
  covariance ``2 kT Δt`` times the inverse frictions (Ermak–McCammon for a rigid
  body).  Overlaps between clusters are removed by rigid translations weighted by
  the mobilities ``1/n`` (to 1e-10 radii); a cluster bonded to its own periodic
  image wraps the box (percolates) and is immobile.  Distances inside a cluster are
  conserved to round-off, so bonds stay in ``0 <= h <= bond_width`` for good.
* ``"flexible"`` (default): central bonds only.  After every step the centres of bonded pairs
  are projected back into the shell ``0 <= h <= bond_width`` (and any overlap
  removed) by symmetric moves along the line of centres (Heyes & Melrose 1993
  overlap removal plus a tether); bonded spheres roll freely on each other, which
  lets clusters restructure and densify (Babu, Gimel & Nicolai 2008).
* ``"tangential"``: the flexible model plus a resistance to sliding and rolling.  Every
  sphere also diffuses rotationally (free-draining rotational friction ``8π η a³``,
  ``D_r = kT/(8π η a³)``); each bond joins the two surface material points that
  touched at capture by a spring (sliding, stiffness ``sliding_stiffness``) and
  resists the Dominik–Tielens rolling displacement ``ξ = (u + w)/2`` of its two
  anchor directions (``rolling_stiffness``); rolling turns plastic at the critical
  moment ``rolling_moment`` (Dominik & Tielens 1995), whose default is 1/100 of ``a``
  times the adhesion force, the ratio measured for silica microspheres by Heim et
  al. (1999); ``rolling_moment="dlvo"`` takes the adhesion force of the whole DLVO
  potential at contact instead of its van der Waals part, so the moment falls with Ψ0.
  Twisting is free.  Zero stiffnesses give the flexible model exactly;
  infinite ones would give rigid clusters.  The default stiffnesses are numerical
  (the stiffest the time step integrates stably, see :func:`brownian`): real
  solid contacts are stiffer still.  Kernel :func:`polypack._kernels.bd.run_tangential`.

Bond escape
-----------
``bond_escape="none"`` (default): bonds are permanent (the primary minimum is hundreds of
kBT deep at the default 0.4 nm minimum separation).  ``"kramers"``: every bond breaks at the
rate ``1/τ`` of thermal escape out of the primary minimum, ``τ`` the Smoluchowski mean
first-passage time of the isolated pair from the contact (reflecting at ``minimum_separation``)
to the top of the barrier (:func:`bond_escape_time`); a broken pair is put at the barrier top
along its line of centres, from where the dynamics decides whether it leaves or is captured
again.  It matters only where the primary minimum is shallow: a contact separation of a few
nm (surface roughness, hydration or Stern layers; Frens & Overbeek 1972) makes the 15 mV well
about 14 kBT deep against 40 kBT at 0 mV (docs/brownian.md, issue 32 section).  Bonds are
broken between kernel chunks short against ``τ`` (at most ``τ/50``).

Hydrodynamics
-------------
``hydrodynamics="free"`` (default) is the free-draining dynamics above, the seed's
"frictional Stokes' drag force and a random Brownian force" (§2.2 of
003_873b69fc71c74cf6.txt).  ``"lubrication"`` divides the relative normal mobility of
every unbonded pair closer than ``lubrication_range`` by Honig, Roebersen & Wiersema's
``β(u) = (6u² + 13u + 2)/(6u² + 4u)`` (u = gap/a, tapered to 1 at the range): mobility
``M = S²`` with ``S = I - Σ_p k_p b_p b_pᵀ``, ``k_p = (1 - β_p^(-1/2))/2``, Brownian
displacements ``sqrt(2 Δt) S ξ`` (covariance ``2 M Δt``) and the Itô drift ``(∇·M) Δt``
(derivation in docs/brownian.md; kernel :func:`polypack._kernels.bd._translate`).

Stopping rule
-------------
Every ``record_interval`` the coordination (2 bonds / N), the number of clusters and
the largest cluster are recorded.  The run stops when, over the last
``stable_window``, the coordination changed by less than ``coordination_tolerance``
(relative) and the largest-cluster fraction by less than
``cluster_tolerance``, or when ``max_time``/``max_steps`` is used up (then
``meta["brownian"]["converged"]`` is False and a warning is issued).

References
----------
Ermak, D. L. & McCammon, J. A., J. Chem. Phys. 69, 1352 (1978).
Hütter, M., J. Colloid Interface Sci. 231, 337 (2000).
Heyes, D. M. & Melrose, J. R., J. Non-Newtonian Fluid Mech. 46, 1 (1993).
Babu, S., Gimel, J. C. & Nicolai, T., J. Chem. Phys. 128, 204504 (2008) (Brownian
cluster dynamics; rigid and flexible bonds).
Dominik, C. & Tielens, A. G. G. M., Philos. Mag. A 72, 783 (1995) (rolling resistance of
adhesive contacts, critical rolling displacement).
Heim, L.-O., Blum, J., Preuss, M. & Butt, H.-J., Phys. Rev. Lett. 83, 3328 (1999)
(rolling-friction forces about 100 times below the adhesion forces).
Pantina, J. P. & Furst, E. M., Phys. Rev. Lett. 94, 138301 (2005) (bonds between
colloidal particles support bending moments).
Becker, V. & Briesen, H., arXiv:0808.3108 (2008) (a tangential force model for
bonded colloidal particles).
Honig, E. P., Roebersen, G. J. & Wiersema, P. H., J. Colloid Interface Sci. 36, 97 (1971)
(hydrodynamic correction of the relative diffusion of two spheres).
Frens, G. & Overbeek, J. Th. G., J. Colloid Interface Sci. 38, 376 (1972) (repeptization: a
finite primary minimum when the surfaces cannot come closer than a hydration/Stern layer).
Gardiner, C. W., *Handbook of Stochastic Methods* (Springer), §5.2.7 (mean first-passage time).
"""

from __future__ import annotations

import math
import time
import warnings
from types import SimpleNamespace

import numpy as np

from .. import registry as _registry
from .._util import as_seed_sequence, progress_bar, seed_record
from ..errors import InfeasibleError, InvalidInputError, OverlapError
from ..packing import Packing
from ._capabilities import ROLLING_MOMENT_RULES, BrownianOptions
from .dlvo import DLVOParameters, _terms, adhesion_force, dlvo_extrema, dlvo_parameters

__all__ = ["brownian", "BrownianSimulation", "brownian_bonds", "BOND_MODELS", "HYDRODYNAMICS", "BOND_ESCAPE",
           "MAX_STEP_FRACTION", "OVERLAP_TOLERANCE", "relative_mobility", "bond_escape_time"]

#: Bond models: ``"rigid"`` (bonded spheres form rigid clusters: Brownian cluster
#: dynamics, no rolling or sliding) and ``"flexible"`` (central bonds: free rolling).
BOND_MODELS = ("rigid", "flexible", "tangential")

#: Hydrodynamic models: ``"free"`` (free draining, Ermak–McCammon with Stokes drag: each
#: sphere has mobility 1/(6πηa), no hydrodynamic interaction) and ``"lubrication"``
#: (free draining plus the Honig, Roebersen & Wiersema (1971) correction of the relative
#: normal mobility of every unbonded close pair; see :func:`relative_mobility`).
HYDRODYNAMICS = ("free", "lubrication")

#: Bond escape models: ``"none"`` (bonds are permanent) and ``"kramers"`` (bonds break at the
#: rate 1/τ of thermal escape out of the primary minimum, :func:`bond_escape_time`).
BOND_ESCAPE = ("none", "kramers")
#: Without a barrier beyond the contact, a pair has escaped where its energy rises above this (kBT).
ESCAPE_EXIT_ENERGY = -1.0
#: Bonds are broken between kernel chunks of at most this fraction of the escape time τ.
ESCAPE_CHUNK = 0.02

#: Ratio of the critical rolling moment to ``a`` times the adhesion force in the default of
#: ``bonds="tangential"``: rolling-friction forces between silica microspheres are about 100
#: times lower than their adhesion (pull-off) forces (Heim, Blum, Preuss & Butt 1999).
ROLLING_TO_ADHESION = 0.01
#: Per-bond relaxation number ``k_s * mobility * dt`` of the default (numerical) sliding
#: stiffness of ``bonds="tangential"``: a sphere with 10 bonds stays below the explicit
#: Euler stability limit 2.
TANGENTIAL_STEP_STIFFNESS = 0.1
_SLIDE_MOBILITY = 2.0 + 2.0 * 0.75  # relative mobility of the anchor separation d (reduced)
_ROLL_MOBILITY = 0.25 * 0.75 * 2.0  # relative mobility of the rolling displacement xi (reduced)

#: Largest allowed rms Brownian step per coordinate, ``sqrt(2 D0 Δt)``, in Debye lengths.
MAX_STEP_FRACTION = 0.5
#: Per-step overlap tolerance (radii) of the rigid model's cluster translations.
RIGID_OVERLAP_TOLERANCE = 1e-10
#: Default rms step per coordinate in Debye lengths.
DEFAULT_STEP_FRACTION = 0.2
#: Largest relative overlap ``1 - d_ij / (2a)`` tolerated in a returned gel (checked before it is returned).
OVERLAP_TOLERANCE = 1e-6
#: The final overlap removal stops when no correction exceeds this many radii: far below the
#: estimators' 1e-9 (``polypack.analysis._base.OVERLAP_TOLERANCE``), so a finished gel reads as a
#: hard-sphere pack (at 1e-6 the N = 8000 gels kept overlaps of 2-3e-8 and every estimator warned).
FINAL_OVERLAP_TOLERANCE = 1e-10


def relative_mobility(h, radius=None, lubrication_range=None):
    """Relative normal mobility of an isolated pair under ``hydrodynamics="lubrication"``, in units of 2 D0.

    ``1 / β_eff(h / a)`` with ``β(u) = (6u² + 13u + 2) / (6u² + 4u)`` (Honig, Roebersen &
    Wiersema, J. Colloid Interface Sci. 36, 97 (1971); ``u`` = surface gap / radius),
    ``β - 1`` tapered smoothly to 0 between half the range and the range
    (:func:`polypack._kernels.bd.lubrication_beta`).  The free-draining value is 1.

    Parameters
    ----------
    h : float or array_like
        Surface separations (m).
    radius : float, optional
        Sphere radius (m); default the DLVO default 0.25 µm.
    lubrication_range : float, optional
        Gap (m) beyond which the pair is free draining; default ``cutoff - 2a`` with the
        default DLVO cutoff 2.5 a, i.e. ``a / 2``; ``inf``: Honig's β at every gap.

    Returns
    -------
    numpy.ndarray
        ``1 / β_eff`` (the relative normal diffusion coefficient is ``2 D0 / β_eff``).
    """
    from .._kernels import bd

    a = dlvo_parameters(0.0).radius if radius is None else _check_positive("radius", radius)
    if lubrication_range is None:
        uc = 0.5
    elif lubrication_range == math.inf:
        uc = math.inf
    else:
        uc = _check_positive("lubrication_range", lubrication_range) / a
    u = np.asarray(h, dtype=np.float64) / a
    out = np.empty(u.shape)
    for k, x in enumerate(u.flat):
        out.flat[k] = 1.0 / bd.lubrication_beta(float(x), uc if math.isfinite(uc) else 1e300)[0]
    return out


def _check_positive(name, value, allow_zero=False):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={value!r}: must be a number") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise InvalidInputError(f"{name}={value!r}: must be finite and {'>= 0' if allow_zero else '> 0'}")
    return v


def bond_escape_time(surface_potential=0.0, exit_separation=None, **parameters):
    """Mean time (s) for a bonded pair to leave the primary minimum, and the exit separation (m).

    Smoluchowski first passage of the centre distance ``r`` of an isolated pair (relative
    diffusion ``D = 2 D0``, free draining) in the DLVO potential ``V(r)``, reflecting at the
    contact ``r0 = 2a + h_min`` (``minimum_separation``), absorbing at ``r_x = 2a + h_x``
    (Gardiner, §5.2.7; radial form in three dimensions)::

        τ = ∫_{r0}^{r_x} dr  exp(V(r)/kT) / (D r²)  ∫_{r0}^{r} r'² exp(-V(r')/kT) dr'

    With a barrier beyond the contact, ``h_x`` is its top (:func:`~polypack.generate.dlvo.dlvo_extrema`);
    otherwise the first separation where ``V >= ESCAPE_EXIT_ENERGY`` (-1 kBT).  For a deep
    well (``ΔV = V(r_x) - V(r0) >> kT``, the force at the contact ``F0 = -V'(r0) < 0``) it
    tends to Kramers' cusp-well form ``τ ≈ (r0/r_x)² exp(ΔV/kT) sqrt(2π kT/|V''(r_x)|) kT / (D |F0|)``.

    Parameters
    ----------
    surface_potential : float or DLVOParameters
        Ψ0 in volts, or a parameter object (:func:`~polypack.generate.dlvo.dlvo_parameters`).
    exit_separation : float, optional
        ``h_x`` in metres instead of the rule above (must exceed ``minimum_separation``).
    **parameters
        DLVO keywords (``minimum_separation``, ``hamaker``, ...), as :func:`~polypack.generate.dlvo.dlvo_potential`.

    Returns
    -------
    (float, float)
        ``τ`` in seconds (``inf`` when ``ΔV`` exceeds 700 kBT) and ``h_x`` in metres.
    """
    from scipy.integrate import cumulative_trapezoid

    from .dlvo import _resolve, dlvo_potential

    p = _resolve(surface_potential, parameters)
    a, kT, h0 = p.radius, p.kT, p.minimum_separation
    if exit_separation is None:
        ex = dlvo_extrema(p)
        if ex.has_secondary_minimum and ex.barrier_separation > h0:
            hx = ex.barrier_separation
        else:
            hh = h0 + np.geomspace(1e-6 * a, 2.0 * a, 20000)
            above = np.nonzero(dlvo_potential(2.0 * a + hh, p) / kT >= ESCAPE_EXIT_ENERGY)[0]
            if above.size == 0:
                raise InvalidInputError(f"bond_escape_time: V stays below {ESCAPE_EXIT_ENERGY} kT out to 2a")
            hx = float(hh[above[0]])
    else:
        hx = _check_positive("exit_separation", exit_separation)
        if hx <= h0:
            raise InvalidInputError(f"exit_separation={hx!r} m must exceed minimum_separation={h0!r} m")
    # grid dense at the contact, where exp(-V) is concentrated (the well is a cusp)
    r = 2.0 + (h0 + (hx - h0) * np.concatenate(([0.0], np.geomspace(1e-9, 1.0, 40000)))) / a
    v = dlvo_potential(r * a, p) / kT
    dv = v.max() - v.min()
    if dv > 700.0:
        return math.inf, hx
    inner = cumulative_trapezoid(r * r * np.exp(v.min() - v), r, initial=0.0)
    outer = np.exp(v - v.max()) * inner / (2.0 * r * r)
    tau = float(np.trapezoid(outer, r)) * math.exp(dv)
    return tau * p.brownian_time, hx


def _check_int(name, value, minimum):
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise InvalidInputError(f"{name}={value!r}: must be an integer >= {minimum}")
    return int(value)


class BrownianSimulation:
    """State of a Brownian-dynamics run of equal spheres (SI in, SI out).

    Parameters
    ----------
    positions : (N, 3) array_like
        Initial centres (m).
    box : float or (3,) array_like
        Periodic box lengths (m).
    parameters : DLVOParameters
        From :func:`polypack.generate.dlvo_parameters` (radius, temperature,
        viscosity, Hamaker constant, Debye length, model).
    time_step : float, optional
        Δt in seconds; default: the rms step per coordinate ``sqrt(2 D0 Δt)`` is
        0.2 Debye lengths.  Larger than 0.5 Debye lengths is refused.
    bond_width : float or None
        Capture separation and shell width of bonds (m), default 1 nm; None: no
        bonds and no overlap projection (purely soft DLVO forces, e.g. a stable
        repulsive suspension).
    drift_cap : float
        Largest fraction of a pair's gap its attraction may close in one step
        (0 = no cap).
    cutoff : float, optional
        Centre-distance cutoff of the DLVO force (m), default ``2.5 a``.
    skin : float, optional
        Verlet-list skin in units of ``a``; default ``max(0.4, min(30 rms / a, L/2a - cutoff/a))``
        with ``rms`` the rms step per coordinate (large steps rebuild the list every ~10 steps at
        0.4).  Trajectories do not depend on it (:func:`polypack._kernels.bd._verlet_pairs`).
    trap_stiffness : float
        Stiffness (N/m) of an optional harmonic trap holding each sphere near the box
        centre (validation; 0 = none).
    seed : int or SeedSequence
    max_bonds_per_particle : int
    bonds : {"rigid", "flexible", "tangential"}
        Bond model (see :func:`brownian`); ignored when ``bond_width`` is None.
    sliding_stiffness, rolling_stiffness, rolling_moment
        Tangential bond springs of ``bonds="tangential"`` (see :func:`brownian`).
    hydrodynamics : {"free", "lubrication"}
        Pair mobility (see :func:`brownian`); ``"lubrication"`` is refused with
        ``bonds="rigid"``.
    lubrication_range : float, optional
        Gap (m) out to which ``"lubrication"`` corrects a pair; default and maximum
        ``cutoff - 2a``.
    """

    def __init__(self, positions, box, parameters: DLVOParameters, *, time_step=None, bond_width=1e-9,
                 drift_cap=0.25, cutoff=None, skin=None, trap_stiffness=0.0, seed=None,
                 max_bonds_per_particle=24, table_points=8192, max_sweeps=4, projection_tolerance=1e-7,
                 bonds="flexible", sliding_stiffness=None, rolling_stiffness=None, rolling_moment=None,
                 hydrodynamics="free", lubrication_range=None):
        from .._kernels import bd
        from ..neighbors import choose_cells

        self._bd = bd
        p = parameters
        if not isinstance(p, DLVOParameters):
            raise InvalidInputError("parameters must be a DLVOParameters (polypack.generate.dlvo_parameters)")
        self.parameters = p
        a = p.radius
        pos = np.array(positions, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < 1:
            raise InvalidInputError(f"positions must have shape (N, 3) with N >= 1, got {pos.shape}")
        if not np.all(np.isfinite(pos)):
            raise InvalidInputError("positions must be finite")
        bx = np.array(box, dtype=np.float64)
        if bx.ndim == 0:
            bx = np.full(3, float(bx))
        if bx.shape != (3,) or not np.all(np.isfinite(bx)) or np.any(bx <= 0):
            raise InvalidInputError(f"box={box!r}: must be a positive scalar or 3 positive lengths")
        D0 = p.diffusion_coefficient
        lam = p.debye_length
        if time_step is None:
            time_step = (DEFAULT_STEP_FRACTION * lam) ** 2 / (2.0 * D0)
        dt = _check_positive("time_step", time_step)
        rms = math.sqrt(2.0 * D0 * dt)
        if rms > MAX_STEP_FRACTION * lam:
            raise InvalidInputError(
                f"time_step={dt:g} s gives an rms Brownian step sqrt(2 D0 dt) = {rms:.3g} m = "
                f"{rms / lam:.3g} Debye lengths; at most {MAX_STEP_FRACTION} allowed "
                f"(time_step <= {(MAX_STEP_FRACTION * lam) ** 2 / (2 * D0):.3g} s)"
            )
        self.time_step = dt
        self.rms_step = rms
        if cutoff is None:
            cutoff = 2.5 * a
        rc = _check_positive("cutoff", cutoff) / a
        if rc <= 2.0:
            raise InvalidInputError(f"cutoff={cutoff!r} m must exceed the contact distance 2a = {2 * a:g} m")
        if skin is None:  # speed only: the trajectory is the same for any skin
            skin = max(0.4, min(30.0 * rms / a, 0.5 * bx.min() / a - rc))
        skin = _check_positive("skin", skin)
        independent = p.hamaker == 0.0 and p.surface_potential == 0.0 and bond_width is None
        if rc + skin > 0.5 * bx.min() / a and not independent:
            raise InvalidInputError(
                f"cutoff + skin = {(rc + skin) * a:g} m exceeds half the box {0.5 * bx.min():g} m; "
                "use more spheres or a smaller cutoff"
            )
        if bond_width is None:
            width = None
        else:
            width = _check_positive("bond_width", bond_width)
            if width >= a:
                raise InvalidInputError(f"bond_width={bond_width!r} m must be smaller than the radius {a!r} m")
        self.bond_width = width
        if bonds not in BOND_MODELS:
            raise InvalidInputError(f"bonds={bonds!r}: must be one of {', '.join(map(repr, BOND_MODELS))}")
        self.bond_model = bonds
        if hydrodynamics not in HYDRODYNAMICS:
            raise InvalidInputError(
                f"hydrodynamics={hydrodynamics!r}: must be one of {', '.join(map(repr, HYDRODYNAMICS))}")
        if hydrodynamics == "lubrication" and bonds == "rigid" and bond_width is not None:
            raise InvalidInputError('hydrodynamics="lubrication" is not implemented for bonds="rigid"; '
                                    'use bonds="flexible" or "tangential"')
        self.hydrodynamics = hydrodynamics
        self.lubrication_range = None
        if hydrodynamics == "lubrication":
            lr = (rc - 2.0) * a if lubrication_range is None else _check_positive("lubrication_range",
                                                                                  lubrication_range)
            if lr > (rc - 2.0) * a * (1 + 1e-12):
                raise InvalidInputError(
                    f"lubrication_range={lr:g} m exceeds cutoff - 2a = {(rc - 2.0) * a:g} m; raise cutoff")
            self.lubrication_range = lr
        elif lubrication_range is not None:
            raise InvalidInputError('lubrication_range is only used with hydrodynamics="lubrication"')
        cap = _check_positive("drift_cap", drift_cap, allow_zero=True)
        if cap >= 1.0:
            raise InvalidInputError(f"drift_cap={drift_cap!r}: must be in [0, 1)")
        dt_r = dt / p.brownian_time
        params = np.zeros(bd.N_PARAMS)
        params[bd.P_DT] = dt_r
        params[bd.P_NOISE] = math.sqrt(2.0 * dt_r)
        params[bd.P_R_CUT] = rc
        params[bd.P_SKIN] = skin
        params[bd.P_BOND_WIDTH] = (width / a) if width is not None else -1.0
        params[bd.P_CAP_DRIFT] = cap
        params[bd.P_SWEEPS] = _check_int("max_sweeps", max_sweeps, 1)
        params[bd.P_PROJ_TOL] = _check_positive("projection_tolerance", projection_tolerance)
        params[bd.P_LUB_RANGE] = self.lubrication_range / a if self.lubrication_range is not None else 0.0
        if bonds == "rigid":
            # rigid translations remove an overlap in one move: resolve to round-off level, since an
            # overlap left at capture is frozen into the rigid cluster for good
            params[bd.P_PROJ_TOL] = min(params[bd.P_PROJ_TOL], RIGID_OVERLAP_TOLERANCE)
            params[bd.P_SWEEPS] = max(params[bd.P_SWEEPS], 50)
        self.tangential = None
        if bonds == "tangential":
            self.tangential = self._tangential_params(params, p, dt_r, sliding_stiffness, rolling_stiffness,
                                                      rolling_moment)
        k_trap = _check_positive("trap_stiffness", trap_stiffness, allow_zero=True)
        params[bd.P_TRAP_K] = k_trap * a * a / p.kT
        # force table from a small overlap (or the bond width) to the cutoff
        lo = (width / a) if width is not None else -0.1
        hi = rc - 2.0
        npts = _check_int("table_points", table_points, 16)
        hgrid = np.linspace(lo, hi, npts)
        _, f = _terms(a * (2.0 + hgrid), p)
        self._table = np.ascontiguousarray(f * a / p.kT)
        params[bd.P_TAB_LO] = lo
        params[bd.P_TAB_DH] = (hi - lo) / (npts - 1)
        self._params = params
        self._pos = np.ascontiguousarray(pos / a)
        self._box = np.ascontiguousarray(bx / a)
        n = pos.shape[0]
        self._state = np.zeros(bd.N_STATE)
        self._istate = np.zeros(bd.N_ISTATE, np.int64)
        maxb = _check_int("max_bonds_per_particle", max_bonds_per_particle, 1)
        self._bonds = np.zeros((max(16, (n * maxb) // 2 + 1), 2), np.int64)
        self._adj = np.zeros((n, maxb), np.int64)
        self._deg = np.zeros(n, np.int64)
        # cluster bookkeeping of the rigid model (labels, member lists, sizes, wrapping flags)
        self._lab = np.zeros(n, np.int64)
        self._nxt = np.zeros(n, np.int64)
        self._head = np.zeros(n, np.int64)
        self._tail = np.zeros(n, np.int64)
        self._csize = np.zeros(n, np.int64)
        self._frozen = np.zeros(n, np.uint8)
        bd.init_clusters(n, self._lab, self._nxt, self._head, self._tail, self._csize, self._frozen)
        # tangential model: two anchor unit vectors per bond row, one body-fixed unit vector per sphere
        self._anchors = np.zeros((self._bonds.shape[0], 6)) if bonds == "tangential" else np.zeros((1, 6))
        self._orient = np.zeros((n, 3))
        self._orient[:, 2] = 1.0
        if p.hamaker == 0.0 and p.surface_potential == 0.0 and width is None and hydrodynamics == "free":
            params[bd.P_R_CUT] = 0.0  # independent spheres: no neighbour list
        self._ncell = choose_cells(self._box, n, rc + skin)
        self._seed = as_seed_sequence(seed)
        self._rng = self._seed.generate_state(4, np.uint64)
        if not np.any(self._rng):
            self._rng[0] = np.uint64(1)

    @staticmethod
    def _tangential_params(params, p, dt_r, sliding_stiffness, rolling_stiffness, rolling_moment):
        """Fill the tangential-spring slots (reduced units); returns their SI record."""
        from .._kernels import bd

        a, kT = p.radius, p.kT
        if sliding_stiffness is None:
            ks = TANGENTIAL_STEP_STIFFNESS / (_SLIDE_MOBILITY * dt_r)
        else:
            ks = _check_positive("sliding_stiffness", sliding_stiffness, allow_zero=True) * a * a / kT
        if rolling_stiffness is None:
            kr = 4.0 * ks  # orbital motion of a bonded sphere costs the same by pure sliding or pure rolling
        else:
            kr = _check_positive("rolling_stiffness", rolling_stiffness, allow_zero=True) / kT
        for name, k, mob in (("sliding_stiffness", ks, _SLIDE_MOBILITY), ("rolling_stiffness", kr, _ROLL_MOBILITY)):
            if k * mob * dt_r > 0.5:
                raise InvalidInputError(
                    f"{name}: {k:.3g} (reduced) times its mobility {mob:g} and the step {dt_r:.3g} is "
                    f"{k * mob * dt_r:.3g} > 0.5 (explicit steps unstable); use a smaller stiffness or time step")
        # adhesion force of the model: its van der Waals force at the minimum separation (Derjaguin,
        # equal spheres: A a / (12 h_min^2))
        f_adh = p.hamaker * a / (12.0 * p.minimum_separation ** 2) if p.minimum_separation > 0 else math.inf
        if rolling_moment is None:
            mc = ROLLING_TO_ADHESION * a * f_adh
        elif isinstance(rolling_moment, str):
            if rolling_moment not in ROLLING_MOMENT_RULES:
                raise InvalidInputError(f"rolling_moment={rolling_moment!r}: must be a number (N m), inf or "
                                        + ", ".join(map(repr, ROLLING_MOMENT_RULES)))
            # "dlvo": the pull-off force of the whole DLVO potential at contact (Derjaguin/DMT), double layer included
            f_adh = adhesion_force(p)
            if not f_adh > 0.0:
                raise InvalidInputError(
                    f"rolling_moment={rolling_moment!r}: the DLVO force at minimum_separation = {p.minimum_separation:g} m "
                    f"is not attractive ({f_adh:.3g} N, pull-off must be > 0) at surface_potential = {p.surface_potential:g} V: no adhesion to "
                    "roll against; give a number")
            mc = ROLLING_TO_ADHESION * a * f_adh
        else:
            try:
                mc = float(rolling_moment)
            except (TypeError, ValueError):
                raise InvalidInputError(f"rolling_moment={rolling_moment!r}: must be a number (N m) or inf") from None
            if not (mc > 0):
                raise InvalidInputError(f"rolling_moment={rolling_moment!r}: must be > 0 (N m; inf = no yield)")
        m = mc / kT / kr if kr > 0 else math.inf  # moment / k_r; the elastic moment is (k_r/2) x sqrt(1 - x^2)
        m2 = 2.0 * m
        xmax = math.sqrt(0.5 * (1.0 - math.sqrt(1.0 - m2 * m2))) if m2 < 1.0 else math.inf
        params[bd.P_K_SLIDE] = ks
        params[bd.P_K_ROLL] = kr
        params[bd.P_ROLL_MAX] = xmax
        return {"sliding_stiffness": ks * kT / (a * a), "rolling_stiffness": kr * kT, "rolling_moment": mc,
                "rolling_moment_kT": mc / kT, "rolling_yield_displacement": xmax * a if math.isfinite(xmax) else math.inf,
                "sliding_stiffness_reduced": ks, "rolling_stiffness_reduced": kr,
                "adhesion_force": f_adh, "default_moment": rolling_moment is None,
                "moment_rule": ("van_der_waals" if rolling_moment is None else
                                rolling_moment if isinstance(rolling_moment, str) else "given")}

    # ------------------------------------------------------------------ running
    @property
    def n(self) -> int:
        return self._pos.shape[0]

    def run(self, steps, noise=True, _params=None):
        """Advance ``steps`` Brownian time steps (``noise=False``: noise-free steps)."""
        steps = _check_int("steps", steps, 0)
        bd = self._bd
        params = self._params if _params is None else _params
        if not noise:
            params = params.copy()
            params[bd.P_NOISE] = 0.0
        status = self._kernel(params, steps)
        if status != bd.Status.OK:  # the bond arrays hold N * max_bonds_per_particle / 2: only the per-sphere limit
            raise InfeasibleError(
                f"a sphere reached max_bonds_per_particle={self._adj.shape[1]} bonds; raise the limit"
            )

    def _kernel(self, params, steps):
        bd = self._bd
        if self.bond_model == "rigid" and self.bond_width is not None:
            return bd.run_rigid(self._pos, self._box, params, self._state, self._istate, self._table, self._bonds,
                                self._adj, self._deg, self._ncell, self._rng, steps, self._lab, self._nxt,
                                self._head, self._tail, self._csize, self._frozen)
        if self.bond_model == "tangential" and self.bond_width is not None:
            return bd.run_tangential(self._pos, self._box, params, self._state, self._istate, self._table,
                                     self._bonds, self._adj, self._deg, self._ncell, self._rng, steps, self._anchors,
                                     self._orient)
        return bd.run(self._pos, self._box, params, self._state, self._istate, self._table, self._bonds,
                      self._adj, self._deg, self._ncell, self._rng, steps)

    @property
    def orientations(self) -> np.ndarray:
        """(N, 3) body-fixed unit vector of each sphere (rotated only by ``bonds="tangential"``; a copy)."""
        return self._orient.copy()

    @property
    def frozen_clusters(self) -> int:
        """Number of rigid clusters that wrap the box (bonded to their own image: immobile)."""
        return int(np.count_nonzero(self._frozen)) if self.bond_model == "rigid" else 0

    @property
    def time(self) -> float:
        """Simulated time in seconds."""
        return float(self._state[self._bd.S_TIME]) * self.parameters.brownian_time

    @property
    def steps(self) -> int:
        return int(self._istate[self._bd.I_STEPS])

    @property
    def rebuilds(self) -> int:
        return int(self._istate[self._bd.I_REBUILDS])

    @property
    def positions(self) -> np.ndarray:
        """Unwrapped centres (m) (a copy)."""
        return self._pos * self.parameters.radius

    @property
    def box(self) -> np.ndarray:
        return self._box * self.parameters.radius

    @property
    def n_bonds(self) -> int:
        return int(self._istate[self._bd.I_NBONDS])

    @property
    def bonds(self) -> np.ndarray:
        """(M, 2) int64 bonded pairs (a copy)."""
        return self._bonds[: self.n_bonds].copy()

    @property
    def coordination(self) -> float:
        """Mean bonds per sphere, 2 M / N."""
        return 2.0 * self.n_bonds / self.n

    def clusters(self):
        """``(labels, sizes)`` of the bond graph's connected components."""
        return self._bd.cluster_labels(self.n, self._bonds, self.n_bonds)

    def wrapping_axes(self):
        """(3,) bool: axes along which a bonded cluster wraps the periodic box (percolation)."""
        return self._bd.wrapping_axes(self._pos, self._box, self._bonds, self.n_bonds)

    def break_bonds(self, rows, gap):
        """Remove the bonds in ``rows`` (indices into :attr:`bonds`) and move each pair apart to ``gap`` (m).

        The two spheres move symmetrically along their line of centres (minimum image) until
        their surface separation is ``gap``; other spheres are not moved (the next step's
        projections remove any overlap this makes).  The bond list, the partner lists and, for
        ``bonds="tangential"``, the anchors stay consistent (the last bond row fills each hole).
        """
        if self.bond_model == "rigid":
            raise InvalidInputError('break_bonds: rigid clusters cannot split (bonds="rigid")')
        g = _check_positive("gap", gap) / self.parameters.radius
        nb = self.n_bonds
        rows = np.unique(np.asarray(rows, dtype=np.int64))
        if rows.size and (rows[0] < 0 or rows[-1] >= nb):
            raise InvalidInputError(f"break_bonds: rows must lie in [0, {nb}), got {rows.min()}..{rows.max()}")
        for k in rows[::-1]:
            last = nb - 1
            i, j = (int(x) for x in self._bonds[k])
            self._bonds[k] = self._bonds[last]
            if self.bond_model == "tangential":
                self._anchors[k] = self._anchors[last]
            nb = last
            for x, y in ((i, j), (j, i)):
                d = int(self._deg[x])
                q = int(np.nonzero(self._adj[x, :d] == y)[0][0])
                self._adj[x, q] = self._adj[x, d - 1]
                self._deg[x] = d - 1
            dv = self._pos[j] - self._pos[i]
            dv -= self._box * np.round(dv / self._box)
            r = float(np.linalg.norm(dv))
            s = 0.5 * (2.0 + g - r) / max(r, 1e-12)
            self._pos[i] -= s * dv
            self._pos[j] += s * dv
        self._istate[self._bd.I_NBONDS] = nb

    def _sweep(self, max_sweeps, overlap_only, tolerance=None):
        bd = self._bd
        q = self._params.copy()
        if tolerance is not None:
            q[bd.P_PROJ_TOL] = tolerance
        q[bd.P_SWEEPS] = _check_int("max_sweeps", max_sweeps, 1)
        q[bd.P_NOISE] = 0.0
        q[bd.P_DT] = 0.0
        q[bd.P_OVERLAP_ONLY] = 1.0 if overlap_only else 0.0
        t, steps = self._state[bd.S_TIME], self._istate[bd.I_STEPS]
        self._state[bd.S_MAX_RESIDUAL] = 0.0
        status = self._kernel(q, 1)
        self._state[bd.S_TIME], self._istate[bd.I_STEPS] = t, steps
        if status != bd.Status.OK:
            raise InfeasibleError(f"a sphere reached max_bonds_per_particle={self._adj.shape[1]} bonds")
        return self.max_residual

    def relax_constraints(self, max_sweeps=2000):
        """Noise-free projections (no forces, no time) that finish a gel.

        First up to ``max_sweeps`` sweeps of the full bond constraints (capture,
        shells), then overlap removal alone until no overlap exceeds the projection
        tolerance: where the bond shells of an over-constrained cluster cannot all
        hold, the bond is left stretched (reported by :meth:`bond_gaps`) rather than
        a sphere overlapping.  Returns the largest overlap correction of the last
        sweep (m).
        """
        if self.bond_width is None:
            return 0.0
        if self.bond_model == "rigid":  # bonds never stretch; one overlap removal and capture pass
            return self._sweep(max_sweeps, False, tolerance=FINAL_OVERLAP_TOLERANCE)
        self._sweep(max_sweeps, False)
        return self._sweep(20 * max_sweeps, True, tolerance=FINAL_OVERLAP_TOLERANCE)

    def bond_gaps(self) -> np.ndarray:
        """Surface separations (m) of the bonded pairs (minimum image)."""
        b = self.bonds
        d = self._pos[b[:, 1]] - self._pos[b[:, 0]]
        d -= self._box * np.round(d / self._box)
        return (np.linalg.norm(d, axis=1) - 2.0) * self.parameters.radius

    @property
    def max_residual(self) -> float:
        """Largest constraint violation (m) left after the projection sweeps of any step."""
        return float(self._state[self._bd.S_MAX_RESIDUAL]) * self.parameters.radius

    def mean_virial(self) -> float:
        """Time average of ``sum_pairs r F`` (J) over all steps run so far."""
        s = self._state
        steps = s[self._bd.S_VIRIAL_STEPS]
        return float(s[self._bd.S_VIRIAL] / steps) * self.parameters.kT if steps else float("nan")

    def reset_virial(self):
        self._state[self._bd.S_VIRIAL] = 0.0
        self._state[self._bd.S_VIRIAL_STEPS] = 0.0


#: Options that only act with one value of another option: ``{option: (switch, value)}``.
ONLY_WITH = {"sliding_stiffness": ("bonds", "tangential"), "rolling_stiffness": ("bonds", "tangential"),
             "rolling_moment": ("bonds", "tangential"), "lubrication_range": ("hydrodynamics", "lubrication")}


def check_used(options: dict, sep: str = "=", prefix: str = "") -> None:
    """Raise if an option is given that the chosen model ignores (never silently dropped).

    ``options`` holds the keywords of :func:`brownian` (unset ones ``None`` or absent);
    ``bonds`` and ``hydrodynamics`` default to ``"flexible"`` and ``"free"``.
    """
    chosen = {"bonds": options.get("bonds") or "flexible", "hydrodynamics": options.get("hydrodynamics") or "free"}
    for key, (switch, value) in ONLY_WITH.items():
        if options.get(key) is not None and chosen[switch] != value:
            raise InvalidInputError(f"{prefix}{key}{sep}{options[key]!r}: only used with {switch} = {value!r}, "
                                    f"not with {switch} = {chosen[switch]!r}")
    escape = options.get("bond_escape") or "none"
    if escape != "none":
        for switch, bad in (("bonds", "rigid"), ("hydrodynamics", "lubrication")):
            if chosen[switch] == bad:
                raise InvalidInputError(f"{prefix}bond_escape{sep}{escape!r}: not with {switch} = {bad!r} (the escape "
                                        "rate is the free-draining pair's; rigid clusters cannot split)")


def brownian_bonds(packing: Packing):
    """Bond arrays ``(i, j, shift)`` stored by :func:`brownian` in ``packing.meta["bonds"]``.

    ``shift`` (M, 3) int64 is the periodic image of ``j`` seen from ``i``: the bond
    vector is ``x[j] + shift * box - x[i]`` (the BondNetwork convention), ready for
    ``BondNetwork.from_pairs(packing, i, j, shift)``.
    """
    rec = packing.meta.get("bonds")
    if rec is None:
        raise InvalidInputError("packing.meta has no 'bonds' (not made by polypack.brownian)")
    i = np.asarray(rec["i"], dtype=np.int64)
    j = np.asarray(rec["j"], dtype=np.int64)
    shift = np.asarray(rec["shift"], dtype=np.int64).reshape(-1, 3)
    return i, j, shift


class _Escape:
    """Bond breaking of ``bond_escape="kramers"`` between kernel chunks (see :func:`brownian`)."""

    def __init__(self, sim, p, seed):
        width = sim.bond_width
        if width is None or width < p.minimum_separation * (1 - 1e-12):
            raise InvalidInputError(
                f'bond_escape="kramers": bond_width={width!r} m must be at least minimum_separation='
                f"{p.minimum_separation!r} m (the pair is bonded at the contact it escapes from)")
        self.tau, self.exit_gap = bond_escape_time(p)
        if self.exit_gap <= width:
            raise InvalidInputError(
                f'bond_escape="kramers": the escape exit at {self.exit_gap:.3g} m lies inside the bond shell '
                f"(bond_width={width!r} m); use a smaller bond_width")
        self.sim = sim
        self.rng = np.random.default_rng(seed)
        dt = sim.time_step
        self.chunk = max(1, int(ESCAPE_CHUNK * self.tau / dt)) if math.isfinite(self.tau) else None
        self.broken = 0
        self.bond_time = 0.0  # integral of the bond count over time (s): broken / (bond_time / tau) ~ 1

    def run(self, steps):
        sim = self.sim
        if self.chunk is None:
            sim.run(steps)
            return
        done = 0
        while done < steps:
            m = min(self.chunk, steps - done)
            sim.run(m)
            done += m
            nb = sim.n_bonds
            h = m * sim.time_step
            self.bond_time += nb * h
            if nb:
                rows = np.nonzero(self.rng.random(nb) < -math.expm1(-h / self.tau))[0]
                if rows.size:
                    sim.break_bonds(rows, self.exit_gap)
                    self.broken += int(rows.size)

    def record(self):
        tb = self.sim.parameters.brownian_time
        return {"escape_time": self.tau, "escape_time_reduced": self.tau / tb, "exit_separation": self.exit_gap,
                "bonds_broken": self.broken, "bond_time": self.bond_time,
                "chunk_steps": self.chunk}


def _initial_positions(n, a, box_len, min_gap, seed):
    """A hard-sphere fluid at Φ with every surface gap >= ``min_gap`` (Lubachevsky–Stillinger)."""
    from .lubachevsky import pack

    a_eff = a + 0.5 * min_gap
    phi_eff = n * 4.0 / 3.0 * math.pi * a_eff**3 / box_len**3
    pk = pack(np.full(n, a_eff), volume_fraction=phi_eff, seed=seed, progress=False)
    scale = box_len / float(pk.box[0])
    return np.asarray(pk.positions) * scale


#: Defaults of :func:`brownian`: those declared by :class:`polypack.generate._capabilities.BrownianOptions`
#: (one declaration for the API, the study's ``[protocol] kind = "brownian"`` and ``polypack brownian``).
_DEFAULTS = _registry.defaults(BrownianOptions)


def brownian(
    n,
    volume_fraction=_DEFAULTS["volume_fraction"],
    surface_potential=_DEFAULTS["surface_potential"],
    *,
    seed=None,
    radius=None,
    temperature=None,
    viscosity=None,
    relative_permittivity=None,
    hamaker=None,
    ionic_strength=None,
    debye_length=None,
    minimum_separation=None,
    model=_DEFAULTS["model"],
    time_step=None,
    bond_width=_DEFAULTS["bond_width"],
    cutoff=None,
    record_interval=None,
    stable_window=None,
    coordination_tolerance=_DEFAULTS["coordination_tolerance"],
    cluster_tolerance=_DEFAULTS["cluster_tolerance"],
    min_time=None,
    max_time=None,
    max_steps=None,
    progress=None,
    bonds=_DEFAULTS["bonds"],
    sliding_stiffness=None,
    rolling_stiffness=None,
    rolling_moment=None,
    hydrodynamics=_DEFAULTS["hydrodynamics"],
    lubrication_range=None,
    bond_escape=_DEFAULTS["bond_escape"],
) -> Packing:
    """Coagulated colloidal gel by Brownian dynamics with DLVO forces.

    The Brownian-dynamics structure set of §2.2 of 003_873b69fc71c74cf6.txt: ``n``
    equal spheres start as a stable hard-sphere fluid at ``volume_fraction`` in the
    periodic cube of Eq. (5) of 003_873b69fc71c74cf6.txt and coagulate under
    Brownian motion, Stokes drag and DLVO forces until the bond network stops
    evolving.  The rule and the stopping criterion are in the module docstring of
    :mod:`polypack.generate.brownian`.

    Parameters
    ----------
    n : int
        Number of spheres (>= 16).
    volume_fraction : float
        Φ in (0, 0.55]; the seed uses 0.4.
    surface_potential : float
        Ψ0 in volts (seed: 0, 0.012 ... 0.015).  0 gives pure van der Waals
        attraction (fast, diffusion-limited coagulation); higher Ψ0 a secondary
        minimum and a barrier (slower, reaction-limited).
    seed : int or numpy.random.SeedSequence, optional
        Seeds the initial fluid and the Brownian noise; recorded in meta.
    radius, temperature, viscosity, relative_permittivity, hamaker, ionic_strength, debye_length, minimum_separation, model
        Physical parameters (SI), as :func:`polypack.generate.dlvo_parameters`;
        defaults in :data:`polypack.generate.dlvo.DLVO_DEFAULTS`.
    time_step : float, optional
        Δt (s); default: rms step per coordinate ``sqrt(2 D0 Δt)`` = 0.2 Debye
        lengths; an rms step above 0.5 Debye lengths is refused.
    bond_width : float
        Capture separation and bond shell width (m), default 1 nm (coagulation
        rule in the module docstring).
    bonds : {"rigid", "flexible", "tangential"}
        Bond model (module docstring): ``"rigid"``: bonded clusters move as rigid
        bodies (no rolling or sliding, Brownian cluster dynamics); ``"flexible"``
        (default): central bonds, bonded spheres roll freely.  At Φ = 0.4 neither
        reproduces Table 2 of 003_873b69fc71c74cf6.txt (C = 4.5-5.1): rigid gels
        are loop-poor (C ≈ 2), flexible ones too dense (C ≈ 6); see docs/brownian.md.
        ``"tangential"``: central bonds plus elastic-plastic sliding and rolling
        springs between material points of the two spheres (rotational Brownian
        motion of every sphere; rolling yields at ``rolling_moment``), between the
        two limits (C ≈ 4.0 at 0 mV falling to 3.3 at 15 mV with the default
        stiffness; measured against Table 2 in docs/brownian.md).
    sliding_stiffness : float, optional
        ``bonds="tangential"``: stiffness (N/m) of the spring between the two
        surface points that touched at capture (resists sliding).  Default: the
        stiffest the time step integrates accurately,
        ``TANGENTIAL_STEP_STIFFNESS / (3.5 Δt D0/a²)`` in kT/a² (a numerical
        stiffness: real contacts are far stiffer, see docs/brownian.md).
    rolling_stiffness : float, optional
        ``bonds="tangential"``: rolling stiffness (J; energy ``k_r |ξ|²/2`` with ξ
        the Dominik–Tielens rolling displacement in radii); default ``4 k_s a²``,
        so that moving a bonded sphere around its partner costs the same by pure
        sliding or pure rolling.
    rolling_moment : float or "dlvo", optional
        ``bonds="tangential"``: critical rolling moment (N m) beyond which rolling is
        plastic (``inf``: elastic only).  Default ``a F_adh / 100`` (Heim et al.
        1999) with ``F_adh = A a / (12 h_min²)`` the model's van der Waals force at
        its minimum separation.  ``"dlvo"``: the same ratio with ``F_adh`` the
        pull-off force of the whole DLVO potential at ``h_min``, double layer
        included (:func:`polypack.generate.dlvo.adhesion_force`, the Derjaguin /
        DMT force ``π a w``), so the moment falls with Ψ0 (docs/brownian.md, sixth
        pass).
    hydrodynamics : {"free", "lubrication"}
        ``"free"`` (default): free-draining Ermak–McCammon dynamics with Stokes drag,
        the seed's model ("the frictional Stokes' drag force and a random Brownian
        force", §2.2 of 003_873b69fc71c74cf6.txt).  ``"lubrication"``: the relative
        normal mobility of every unbonded pair closer than ``lubrication_range`` is
        divided by Honig's ``β(h/a)`` (:func:`relative_mobility`), with noise and Itô
        drift consistent with it (mobility ``M = S²``; docs/brownian.md).  Not with
        ``bonds="rigid"``.
    lubrication_range : float, optional
        ``"lubrication"``: gap (m) beyond which pairs are free draining; default and
        maximum ``cutoff - 2a`` (``a/2`` with the default cutoff).
    bond_escape : {"none", "kramers"}
        ``"none"`` (default): bonds are permanent.  ``"kramers"``: each bond breaks at the
        rate ``1/τ`` of :func:`bond_escape_time` (thermal escape over the barrier; the pair
        is put at the barrier top).  Only a shallow primary minimum makes ``τ`` finite on
        the run's time scale: give ``minimum_separation`` of a few nm and ``bond_width`` at
        least as large (capture at the contact).  Not with ``bonds="rigid"`` or
        ``hydrodynamics="lubrication"``.  With reversible bonds the structure keeps
        coarsening after the coordination has settled, so the structural stopping rule
        fires early; ``min_time = max_time`` runs for a fixed time (docs/brownian.md).
    cutoff : float, optional
        Centre-distance cutoff of the DLVO force (m), default 2.5 a.
    record_interval : float, optional
        Seconds between records of the time series (default 0.05 a²/D0).
    stable_window : float, optional
        Seconds over which the structure must be stable (default 2 a²/D0).
    coordination_tolerance, cluster_tolerance : float
        Relative change of the coordination and absolute change of the
        largest-cluster fraction allowed over ``stable_window``.
    min_time, max_time : float, optional
        Simulated-time bounds (s): defaults ``stable_window`` and 60 a²/D0.
    max_steps : int, optional
        Step budget (default unlimited up to ``max_time``).
    progress : bool, optional
        Progress bar (simulated time, clusters, coordination); default when stderr
        is a terminal.

    Returns
    -------
    Packing
        Positions (m, folded into the box), radii ``a`` (m), box ``L`` (m).
        ``meta["bonds"]``: ``{"i": [...], "j": [...], "shift": [[sx, sy, sz], ...]}``
        plain lists (read them with :func:`brownian_bonds`; bond vector
        ``x[j] + shift * box - x[i]``).  ``meta["brownian"]``: parameters, time
        step, bond width, steps, simulated and wall time, ``converged``,
        ``percolating`` (per axis), and the time series ``series`` with keys
        ``time`` (s), ``coordination``, ``clusters``, ``largest_cluster`` (spheres)
        and ``largest_fraction``.

    Raises
    ------
    InvalidInputError
        Bad ``n``, ``volume_fraction``, negative radius/viscosity/temperature, an
        unknown electrostatic ``model``, a time step whose rms displacement exceeds
        0.5 Debye lengths, ...
    OverlapError
        If the final gel has a relative overlap beyond :data:`OVERLAP_TOLERANCE`.
    KeyboardInterrupt
        Propagates (as :class:`polypack.errors.Interrupted` when Ctrl-C arrives inside
        the run, raised at the next safe point between kernel chunks); no partial result
        is returned.
    """
    n = _check_int("n", n, 16)
    # one declaration: every given option is checked by its field of BrownianOptions (as in a study and the CLI)
    given = dict(volume_fraction=volume_fraction, surface_potential=surface_potential, radius=radius,
                 temperature=temperature, viscosity=viscosity, relative_permittivity=relative_permittivity,
                 hamaker=hamaker, ionic_strength=ionic_strength, debye_length=debye_length,
                 minimum_separation=minimum_separation, model=model, time_step=time_step, bond_width=bond_width,
                 cutoff=cutoff, record_interval=record_interval, stable_window=stable_window,
                 coordination_tolerance=coordination_tolerance, cluster_tolerance=cluster_tolerance,
                 min_time=min_time, max_time=max_time, max_steps=max_steps, bonds=bonds,
                 sliding_stiffness=sliding_stiffness, rolling_stiffness=rolling_stiffness,
                 rolling_moment=rolling_moment, hydrodynamics=hydrodynamics, lubrication_range=lubrication_range,
                 bond_escape=bond_escape)
    c = _check_brownian_args(n, given)
    ss = as_seed_sequence(seed)
    s_init, s_noise, s_escape = ss.spawn(3)  # the first two as spawn(2): runs without escape unchanged

    t_wall = time.perf_counter()
    # initial fluid: a stable suspension with every surface gap at least two Debye lengths
    pos0 = _initial_positions(n, c.a, c.box_len, 2.0 * c.p.debye_length, s_init)
    sim = BrownianSimulation(pos0, c.box_len, c.p, time_step=time_step, bond_width=bond_width, cutoff=cutoff,
                             seed=s_noise, bonds=bonds, sliding_stiffness=sliding_stiffness,
                             rolling_stiffness=rolling_stiffness, rolling_moment=rolling_moment,
                             hydrodynamics=hydrodynamics, lubrication_range=lubrication_range)
    escape = None
    if bond_escape == "kramers":
        escape = _Escape(sim, c.p, s_escape)
    series, converged, residual = _run_until_stable(sim, escape, c, progress)
    wall = time.perf_counter() - t_wall
    if not converged:
        warnings.warn(
            f"brownian: structure not stable within the budget (t = {sim.time:.3g} s, {sim.steps} steps); "
            "meta['brownian']['converged'] is False", RuntimeWarning, stacklevel=2)
    wrapped, bx, meta = _gel_record(sim, escape, c, ss, series, converged, residual, wall, cutoff, bond_escape)
    out = Packing(wrapped, np.full(n, c.a), bx, meta=meta)
    gap = out.min_gap()
    out.meta["min_gap"] = float(gap)
    if gap < -OVERLAP_TOLERANCE:
        raise OverlapError(
            f"brownian gel has a relative overlap {-gap:.3g} > tolerance {OVERLAP_TOLERANCE:g}"
        )
    return out


def _check_brownian_args(n, given):
    """Check the options ``given`` to :func:`brownian` (its keywords by name); the checked values as a namespace.

    ``n``, ``phi``, the DLVO parameters ``p``, the radius ``a``, the Brownian time ``tau``,
    the box edge ``box_len`` and the stopping-rule settings with their defaults filled in.
    """
    _registry.check_call(BrownianOptions, {k: x for k, x in given.items() if x is not None})
    bonds = given["bonds"]
    if bonds not in BOND_MODELS:
        raise InvalidInputError(f"bonds={bonds!r}: must be one of {', '.join(map(repr, BOND_MODELS))}")
    check_used({k: given[k] for k in ("bonds", "hydrodynamics", "sliding_stiffness", "rolling_stiffness",
                                      "rolling_moment", "lubrication_range", "bond_escape")})
    volume_fraction = given["volume_fraction"]
    phi = float(volume_fraction)
    if not (0.0 < phi <= 0.55):
        raise InvalidInputError(f"volume_fraction={volume_fraction!r}: must be in (0, 0.55]")
    p = dlvo_parameters(given["surface_potential"], **{k: given[k] for k in (
        "radius", "temperature", "viscosity", "relative_permittivity", "hamaker", "ionic_strength", "debye_length",
        "minimum_separation", "model")})
    a = p.radius
    tau = p.brownian_time
    box_len = a * (4.0 * n * math.pi / (3.0 * phi)) ** (1.0 / 3.0)  # Eq. (5) of 003_873b69fc71c74cf6.txt
    record_interval, stable_window = given["record_interval"], given["stable_window"]
    min_time, max_time, max_steps = given["min_time"], given["max_time"], given["max_steps"]
    record_interval = 0.05 * tau if record_interval is None else _check_positive("record_interval", record_interval)
    stable_window = 2.0 * tau if stable_window is None else _check_positive("stable_window", stable_window)
    min_time = stable_window if min_time is None else _check_positive("min_time", min_time, allow_zero=True)
    max_time = 60.0 * tau if max_time is None else _check_positive("max_time", max_time)
    if max_steps is not None:
        max_steps = _check_int("max_steps", max_steps, 1)
    coordination_tolerance = _check_positive("coordination_tolerance", given["coordination_tolerance"])
    cluster_tolerance = _check_positive("cluster_tolerance", given["cluster_tolerance"])
    return SimpleNamespace(n=n, phi=phi, p=p, a=a, tau=tau, box_len=box_len, record_interval=record_interval,
                           stable_window=stable_window, min_time=min_time, max_time=max_time, max_steps=max_steps,
                           coordination_tolerance=coordination_tolerance, cluster_tolerance=cluster_tolerance)


def _run_until_stable(sim, escape, c, progress):
    """Run ``sim`` record by record until the structure is stable or a budget is spent.

    Returns ``(series, converged, residual)``: the time series, whether the stopping
    rule fired, and the overlap residual after the final constraint relaxation.
    Ctrl-C raises :class:`polypack.errors.Interrupted` at the next safe point.
    """
    n, tau, max_steps = c.n, c.tau, c.max_steps
    dt = sim.time_step
    steps_per_record = max(1, int(round(c.record_interval / dt)))
    window_records = max(1, int(round(c.stable_window / (steps_per_record * dt))))
    series = {"time": [0.0], "coordination": [0.0], "clusters": [n], "largest_cluster": [1],
              "largest_fraction": [1.0 / n]}
    converged = False
    from .. import _interrupt

    bar = progress_bar(total=None, desc=f"brownian Ψ0={1e3 * c.p.surface_potential:g} mV", progress=progress,
                       unit="record")
    # Ctrl-C is deferred to the safe points between kernel chunks, where it raises
    # polypack.errors.Interrupted (a KeyboardInterrupt); an interrupted gel is never returned.
    with _interrupt.deferred():
        try:
            while True:
                _interrupt.check(f"brownian interrupted at t = {sim.time:.3g} s after {sim.steps} steps")
                if sim.time >= c.max_time * (1 - 1e-12) or (max_steps is not None and sim.steps >= max_steps):
                    break
                k = steps_per_record if max_steps is None else min(steps_per_record, max_steps - sim.steps)
                if escape is None:
                    sim.run(k)
                else:
                    escape.run(k)
                _, sizes = sim.clusters()
                largest = int(sizes.max())
                series["time"].append(sim.time)
                series["coordination"].append(sim.coordination)
                series["clusters"].append(int(sizes.size))
                series["largest_cluster"].append(largest)
                series["largest_fraction"].append(largest / n)
                bar.update(1)
                bar.set_postfix_str(f"t={sim.time * 1e3:.2f} ms ({sim.time / tau:.2f} a²/D0), "
                                    f"clusters={sizes.size}, largest={largest}, C={sim.coordination:.3f}")
                m = len(series["time"]) - 1
                if sim.time >= c.min_time and m >= window_records:
                    c_now, c_then = series["coordination"][m], series["coordination"][m - window_records]
                    f_now, f_then = series["largest_fraction"][m], series["largest_fraction"][m - window_records]
                    if (c_now > 0 and abs(c_now - c_then) <= c.coordination_tolerance * c_now
                            and abs(f_now - f_then) <= c.cluster_tolerance):
                        converged = True
                        break
            _interrupt.check(f"brownian interrupted at t = {sim.time:.3g} s after {sim.steps} steps")
            residual = sim.relax_constraints()
        finally:
            bar.close()
    return series, converged, residual


def _gel_record(sim, escape, c, ss, series, converged, residual, wall, cutoff, bond_escape):
    """Folded positions, box and ``meta`` (the run record and the bond arrays) of the finished gel."""
    p, a, tau = c.p, c.a, c.tau
    dt = sim.time_step
    gaps = sim.bond_gaps()
    pos = sim.positions
    bx = sim.box
    wrapped = np.mod(pos, bx)
    bonds = sim.bonds
    bi, bj = bonds[:, 0], bonds[:, 1]
    raw = wrapped[bj] - wrapped[bi]
    shift = -np.round(raw / bx).astype(np.int64)
    _, sizes = sim.clusters()
    perc = sim.wrapping_axes()
    meta = {
        "generator": "brownian",
        "seed": seed_record(ss),
        "brownian": {
            "parameters": p.to_dict(),
            "volume_fraction": c.phi,
            "time_step": dt,
            "rms_step": sim.rms_step,
            "rms_step_debye": sim.rms_step / p.debye_length,
            "bond_width": sim.bond_width,
            "bonds": sim.bond_model,
            "hydrodynamics": sim.hydrodynamics,
            "lubrication_range": sim.lubrication_range,
            "frozen_clusters": sim.frozen_clusters,
            "bond_escape": bond_escape,
            "escape": None if escape is None else escape.record(),
            "tangential": sim.tangential,
            "final_overlap_residual": residual,
            "bond_gap_max": float(gaps.max()) if gaps.size else 0.0,
            "bond_gap_mean": float(gaps.mean()) if gaps.size else 0.0,
            "bonds_beyond_width": int(np.count_nonzero(gaps > sim.bond_width * (1 + 1e-6))) if gaps.size else 0,
            "cutoff": (cutoff if cutoff is not None else 2.5 * a),
            "diffusion_coefficient": p.diffusion_coefficient,
            "brownian_time": tau,
            "steps": sim.steps,
            "neighbour_rebuilds": sim.rebuilds,
            "simulated_time": sim.time,
            "wall_time": wall,
            "converged": converged,
            "coordination": sim.coordination,
            "n_bonds": int(bonds.shape[0]),
            "clusters": int(sizes.size),
            "largest_cluster": int(sizes.max()),
            "percolating": [bool(x) for x in perc],
            "stable_window": c.stable_window,
            "coordination_tolerance": c.coordination_tolerance,
            "cluster_tolerance": c.cluster_tolerance,
            "series": series,
        },
        "bonds": {"i": bi.tolist(), "j": bj.tolist(), "shift": shift.tolist()},
    }
    return wrapped, bx, meta
