"""DLVO pair potential of equal spheres in an electrolyte (van der Waals + double layer).

The Brownian-dynamics gels of §2.2 of 003_873b69fc71c74cf6.txt are made of
electrostatically stabilised colloids whose pair potential is the sum of a van der
Waals attraction and an electric double-layer repulsion (DLVO theory).  The seed
fixes two facts about the potential of its structure set (radius r0 = 0.25 µm): a
secondary minimum exists for surface potentials Ψ0 >= 12 mV, and at Ψ0 = 15 mV the
barrier between the local maximum and the secondary minimum is 5.65 kBT.

Model (all inputs SI)
---------------------
* **van der Waals**, exact Hamaker sphere-sphere form for equal spheres of radius
  ``a`` at centre distance ``r``::

      V_A = -(A/6) [2a²/(r²-4a²) + 2a²/r² + ln((r²-4a²)/r²)]

  It diverges at contact, so surface separations below ``minimum_separation``
  (default 0.4 nm, the usual closest approach of hydrated surfaces) are evaluated at
  that separation: the energy is flat and the force zero inside it, and the
  primary minimum is ``V(h_min)``.
* **Double layer at constant surface potential**, symmetric 1:1 electrolyte:
  for ``κa >= 5`` (``model="auto"``) the Hogg-Healy-Fuerstenau/Derjaguin form::

      V_R = 2π ε a Ψ0² ln(1 + exp(-κh))

  otherwise the linear-superposition approximation (LSA) for spheres::

      V_R = 4π ε a² Y² exp(-κh) / r,   Y = (4kT/e) tanh(eΨ0 / 4kT)

  with ``ε = ε_r ε_0``, ``h = r - 2a`` and the Debye length ``1/κ`` from the ionic
  strength ``I`` (mol/m³ = mmol/L): ``κ² = 2 N_A e² I / (ε k T)``.

Default parameters and how they were chosen
-------------------------------------------
Radius 0.25 µm (Table 1 of the seed); water at 20 °C: ``T = 293.15 K``,
``ε_r = 80.1``, viscosity 1.002 mPa s; Hamaker constant of alumina across water
``A = 3.67e-20 J`` (Bergström 1997, the seed's experimental powder is alumina);
minimum separation 0.4 nm.  The one free parameter, the ionic strength, was then
solved so that the barrier at Ψ0 = 15 mV is 5.65 kBT: ``I = 0.9877 mol/m³``
(≈ 1 mM of a 1:1 salt, Debye length 9.70 nm, κa = 25.8, so the HHF form applies).
With these values (barrier 5.6498 kBT) the onset of the secondary minimum falls at
Ψ0 = 11.10 mV: none at 11 mV, one at 12 mV, as the seed states.  The onset hardly
depends on ``A`` once the barrier is fixed (11.09-11.23 mV for A = 0.5-3.7e-20 J at
20 °C): in the Derjaguin limit the reduced potential depends on ``A κ / (ε Ψ0²)``
only, so the two statements of the seed are nearly one condition and check each
other.  "Barrier" is ``V_max - V_secondary`` (the seed: "an energy barrier between
the local maximum and the secondary minimum"); taking instead the height of the
maximum above the dispersed state, ``V_max``, as 5.65 kBT would move the onset to
about 10.5 mV, against the seed.  ``V_max`` is reported too (4.37 kBT at 15 mV).
Barriers at 12, 13, 14 mV: 0.56, 1.79, 3.50 kBT; secondary minima 1.3-1.7 kBT deep
at 32-43 nm; primary minimum about -420 kBT.

References
----------
Hamaker, H. C., Physica 4, 1058 (1937).
Hogg, R., Healy, T. W. & Fuerstenau, D. W., Trans. Faraday Soc. 62, 1638 (1966).
Bell, G. M., Levine, S. & McCartney, L. N., J. Colloid Interface Sci. 33, 335 (1970).
Bergström, L., Adv. Colloid Interface Sci. 70, 125 (1997).
Russel, W. B., Saville, D. A. & Schowalter, W. R., *Colloidal Dispersions* (1989).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InvalidInputError

__all__ = [
    "BOLTZMANN",
    "DLVO_DEFAULTS",
    "DLVOParameters",
    "DLVOExtrema",
    "dlvo_parameters",
    "dlvo_potential",
    "dlvo_force",
    "adhesion_force",
    "dlvo_extrema",
    "secondary_minimum_onset",
    "plot_dlvo",
]

BOLTZMANN = 1.380649e-23  # J/K
ELEMENTARY_CHARGE = 1.602176634e-19  # C
AVOGADRO = 6.02214076e23  # 1/mol
VACUUM_PERMITTIVITY = 8.8541878128e-12  # F/m

#: Default physical parameters (SI) shared by :func:`dlvo_potential` and
#: :func:`polypack.brownian`; see the module docstring for how they were chosen.
DLVO_DEFAULTS = {
    "radius": 0.25e-6,
    "temperature": 293.15,
    "viscosity": 1.002e-3,
    "relative_permittivity": 80.1,
    "hamaker": 3.67e-20,
    "ionic_strength": 0.9877,
    "minimum_separation": 0.4e-9,
}

#: ``model="auto"`` uses HHF when ``κa`` is at least this, else LSA.
HHF_MIN_KAPPA_A = 5.0
MODELS = ("auto", "hhf", "lsa")


@dataclass(frozen=True)
class DLVOParameters:
    """Validated DLVO parameters (SI) with derived quantities.

    Build with :func:`dlvo_parameters`.  ``model`` is the resolved double-layer form
    (``"hhf"`` or ``"lsa"``); ``debye_length`` is ``1/κ`` in metres.
    """

    surface_potential: float
    radius: float
    temperature: float
    viscosity: float
    relative_permittivity: float
    hamaker: float
    ionic_strength: float
    debye_length: float
    minimum_separation: float
    model: str

    @property
    def kT(self) -> float:
        """Thermal energy k_B T in joules."""
        return BOLTZMANN * self.temperature

    @property
    def kappa(self) -> float:
        """Inverse Debye length in 1/m."""
        return 1.0 / self.debye_length

    @property
    def diffusion_coefficient(self) -> float:
        """Stokes-Einstein ``D0 = kT / (6 π η a)`` in m²/s."""
        return self.kT / (6.0 * math.pi * self.viscosity * self.radius)

    @property
    def brownian_time(self) -> float:
        """``a² / D0`` in seconds."""
        return self.radius**2 / self.diffusion_coefficient

    def to_dict(self) -> dict:
        d = asdict(self)
        d["kappa_a"] = self.radius / self.debye_length
        return d


def _positive(name, value, allow_zero=False):
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={value!r}: must be a number") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        allowed = ">= 0" if allow_zero else "> 0"
        raise InvalidInputError(f"{name}={value!r}: must be finite and {allowed}")
    return v


def debye_length_from_ionic_strength(ionic_strength, temperature, relative_permittivity):
    """Debye length ``1/κ`` (m) of a 1:1 electrolyte of ionic strength ``I`` (mol/m³)."""
    eps = relative_permittivity * VACUUM_PERMITTIVITY
    kappa2 = 2.0 * AVOGADRO * ELEMENTARY_CHARGE**2 * ionic_strength / (eps * BOLTZMANN * temperature)
    return 1.0 / math.sqrt(kappa2)


def dlvo_parameters(
    surface_potential=0.0,
    *,
    radius=None,
    temperature=None,
    viscosity=None,
    relative_permittivity=None,
    hamaker=None,
    ionic_strength=None,
    debye_length=None,
    minimum_separation=None,
    model="auto",
) -> DLVOParameters:
    """Validate DLVO inputs (SI) and resolve defaults, the Debye length and the model.

    Parameters
    ----------
    surface_potential : float
        Ψ0 in volts (0.015 for 15 mV); its sign does not matter (equal spheres).
    radius, temperature, viscosity, relative_permittivity, hamaker : float, optional
        Sphere radius (m), temperature (K), solvent viscosity (Pa s), relative
        permittivity of the solvent, Hamaker constant (J, >= 0).  Defaults in
        :data:`DLVO_DEFAULTS`.
    ionic_strength : float, optional
        1:1 electrolyte concentration in mol/m³ (= mmol/L); default 0.9877.
    debye_length : float, optional
        ``1/κ`` in metres, instead of ``ionic_strength`` (which is then derived); giving both
        is an error.
    minimum_separation : float, optional
        Closest surface separation of the van der Waals term (m), default 0.4 nm.
    model : {"auto", "hhf", "lsa"}
        Double-layer form; ``"auto"`` is HHF for ``κa >= 5``, LSA otherwise.

    Raises
    ------
    InvalidInputError
        Negative or zero radius, temperature, viscosity, permittivity, Debye length
        or ionic strength; negative Hamaker constant or minimum separation; an
        unknown model.
    """
    d = DLVO_DEFAULTS
    psi = float(surface_potential) if np.isscalar(surface_potential) else None
    if psi is None or not math.isfinite(psi):
        raise InvalidInputError(f"surface_potential={surface_potential!r}: must be a finite number in volts")
    if abs(psi) > 1.0:
        raise InvalidInputError(
            f"surface_potential={surface_potential!r} V: |Ψ0| <= 1 V allowed; give volts (0.015 for 15 mV), the unit "
            "of the API, the study file and the CLI alike"
        )
    a = _positive("radius", d["radius"] if radius is None else radius)
    T = _positive("temperature", d["temperature"] if temperature is None else temperature)
    eta = _positive("viscosity", d["viscosity"] if viscosity is None else viscosity)
    er = _positive("relative_permittivity", d["relative_permittivity"] if relative_permittivity is None
                   else relative_permittivity)
    A = _positive("hamaker", d["hamaker"] if hamaker is None else hamaker, allow_zero=True)
    h0 = _positive("minimum_separation", d["minimum_separation"] if minimum_separation is None
                   else minimum_separation, allow_zero=True)
    if h0 >= a:
        raise InvalidInputError(f"minimum_separation={h0!r} m must be smaller than the radius {a!r} m")
    if debye_length is not None and ionic_strength is not None:
        raise InvalidInputError(f"ionic_strength={ionic_strength!r}, debye_length={debye_length!r}: give one of "
                                "them (the Debye length follows from the ionic strength)")
    if debye_length is not None:
        lam = _positive("debye_length", debye_length)
        eps = er * VACUUM_PERMITTIVITY
        ion = eps * BOLTZMANN * T / (2.0 * AVOGADRO * ELEMENTARY_CHARGE**2 * lam**2)
    else:
        ion = _positive("ionic_strength", d["ionic_strength"] if ionic_strength is None else ionic_strength)
        lam = debye_length_from_ionic_strength(ion, T, er)
    if model not in MODELS:
        raise InvalidInputError(f"model={model!r}: allowed are {', '.join(repr(m) for m in MODELS)}")
    if model == "auto":
        model = "hhf" if a / lam >= HHF_MIN_KAPPA_A else "lsa"
    return DLVOParameters(abs(psi), a, T, eta, er, A, ion, lam, h0, model)


def _resolve(surface_potential, kw) -> DLVOParameters:
    if isinstance(surface_potential, DLVOParameters):
        if kw:
            raise InvalidInputError("give either a DLVOParameters object or keyword parameters, not both")
        return surface_potential
    return dlvo_parameters(surface_potential, **kw)


def _terms(r, p: DLVOParameters):
    """Energy (J) and force (N, positive = repulsive) at centre distances ``r``."""
    r = np.asarray(r, dtype=np.float64)
    a = p.radius
    h = r - 2.0 * a
    inside = h < p.minimum_separation
    # van der Waals, evaluated at max(h, h_min)
    rv = np.where(inside, 2.0 * a + p.minimum_separation, r)
    v_vdw, dv_vdw = _vdw(rv, p)
    dv_vdw = np.where(inside, 0.0, dv_vdw)
    v_el, dv_el = _double_layer(r, h, p)
    return v_vdw + v_el, -(dv_vdw + dv_el)


def _vdw(rv, p: DLVOParameters):
    """Exact Hamaker energy (J) of equal spheres and its derivative dV/dr (N) at centre distances ``rv``."""
    a, A = p.radius, p.hamaker
    r2 = rv * rv
    s2 = r2 - 4.0 * a * a
    a2 = a * a
    v_vdw = -(A / 6.0) * (2.0 * a2 / s2 + 2.0 * a2 / r2 + np.log(s2 / r2))
    dv_vdw = -(A / 6.0) * (-4.0 * a2 * rv / (s2 * s2) - 4.0 * a2 / (r2 * rv) + 2.0 * rv / s2 - 2.0 / rv)
    return v_vdw, dv_vdw


def _double_layer(r, h, p: DLVOParameters):
    """Double-layer energy (J) and its derivative dV/dr (N) at centre distances ``r`` (gaps ``h``)."""
    a = p.radius
    eps = p.relative_permittivity * VACUUM_PERMITTIVITY
    kappa = p.kappa
    psi = p.surface_potential
    if psi == 0.0:
        v_el = np.zeros_like(r)
        dv_el = np.zeros_like(r)
    elif p.model == "hhf":
        pref = 2.0 * math.pi * eps * a * psi * psi
        x = kappa * h
        v_el = pref * np.log1p(np.exp(-x))
        dv_el = -pref * kappa / (np.exp(np.minimum(x, 700.0)) + 1.0)
    else:  # lsa
        y = 4.0 * p.kT / ELEMENTARY_CHARGE * math.tanh(ELEMENTARY_CHARGE * psi / (4.0 * p.kT))
        pref = 4.0 * math.pi * eps * a * a * y * y
        ex = np.exp(-kappa * h)
        v_el = pref * ex / r
        dv_el = pref * ex * (-kappa / r - 1.0 / (r * r))
    return v_el, dv_el


def dlvo_potential(r, surface_potential=0.0, **parameters):
    """DLVO pair energy (J) of two equal spheres at centre distance ``r`` (m).

    Parameters
    ----------
    r : float or array_like
        Centre distances in metres (surface separation ``h = r - 2a``).
    surface_potential : float or DLVOParameters
        Ψ0 in volts, or a parameter object from :func:`dlvo_parameters`.
    **parameters
        Keyword parameters of :func:`dlvo_parameters` (radius, temperature,
        hamaker, ionic_strength or debye_length, relative_permittivity,
        minimum_separation, model).

    Returns
    -------
    float or numpy.ndarray
        ``V_A + V_R`` in joules (divide by ``k_B T`` for kBT units); for
        ``h < minimum_separation`` the van der Waals term is held at its value at
        the minimum separation.

    Notes
    -----
    The model and its defaults are described in :mod:`polypack.generate.dlvo`
    (§2.2 of 003_873b69fc71c74cf6.txt).
    """
    p = _resolve(surface_potential, parameters)
    v, _ = _terms(r, p)
    return v if np.ndim(r) else float(v)


def dlvo_force(r, surface_potential=0.0, **parameters):
    """Central DLVO force ``-dV/dr`` (N; positive = repulsive) at centre distance ``r`` (m).

    Same parameters as :func:`dlvo_potential`.
    """
    p = _resolve(surface_potential, parameters)
    _, f = _terms(r, p)
    return f if np.ndim(r) else float(f)


def adhesion_force(surface_potential=0.0, **parameters) -> float:
    """Pull-off force (N, positive = attractive) of a pair held at the closest approach.

    The attractive DLVO force of the whole potential (van der Waals and double layer) at the
    surface separation ``h_c = minimum_separation``, ``F_adh = dV/dh`` at ``h_c``
    (:func:`dlvo_force` is ``-dV/dr``; here it is evaluated from the outside, where the van
    der Waals term is not clamped).  In the Derjaguin approximation the force between equal
    spheres is ``π a W(h)``, ``W`` the interaction energy per unit area of two flat plates, so
    ``F_adh = π a w = 2π R* w`` with ``R* = a/2`` and ``w = -W(h_c)`` the work of adhesion of
    the surfaces at contact: the Derjaguin-Muller-Toporov pull-off force of rigid spheres.
    With the Hamaker term alone it tends to ``A a / (12 h_c²)`` for ``h_c << a``; with the
    HHF double layer (``model="hhf"``, or ``"auto"`` at ``κa >= 5``) it is lower by
    ``2π ε a Ψ0² κ / (1 + exp(κ h_c))``; the LSA form lowers it by a different amount.

    Parameters
    ----------
    surface_potential : float or DLVOParameters
        Ψ0 in volts, or a parameter object from :func:`dlvo_parameters`.
    **parameters
        Keyword parameters of :func:`dlvo_parameters`.

    Returns
    -------
    float
        ``F_adh`` in newtons; zero or negative when the double layer outweighs the van der
        Waals attraction at contact (no adhesive primary minimum at ``h_c``).

    Raises
    ------
    InvalidInputError
        If ``minimum_separation`` is 0 (the van der Waals force diverges at contact).

    References
    ----------
    Derjaguin, B. V., Muller, V. M. & Toporov, Yu. P., J. Colloid Interface Sci. 53, 314 (1975);
    Israelachvili, J. N., *Intermolecular and Surface Forces*, 3rd ed. (2011), §11.6 and §13.6.
    DLVO model: §2.2 of 003_873b69fc71c74cf6.txt.
    """
    p = _resolve(surface_potential, parameters)
    hc = p.minimum_separation
    if not hc > 0.0:
        raise InvalidInputError(
            f"minimum_separation={hc!r}: the adhesion force needs a closest approach > 0 "
            "(the van der Waals force diverges at contact)")
    rc = np.array([2.0 * p.radius + hc])
    _, dv_vdw = _vdw(rc, p)
    _, dv_el = _double_layer(rc, np.array([hc]), p)
    return float(dv_vdw[0] + dv_el[0])


@dataclass(frozen=True)
class DLVOExtrema:
    """Extrema of a DLVO potential; separations in metres, energies in kBT.

    ``has_secondary_minimum`` is True when the potential has a local maximum
    (``barrier_separation``, ``maximum_energy``) followed outwards by a local
    minimum (``secondary_separation``, ``secondary_energy``); ``barrier`` is
    ``maximum_energy - secondary_energy`` (NaN without a secondary minimum).
    ``primary_energy`` is ``V(h_min)`` in kBT.
    """

    surface_potential: float
    has_secondary_minimum: bool
    barrier_separation: float
    maximum_energy: float
    secondary_separation: float
    secondary_energy: float
    barrier: float
    primary_energy: float

    def to_dict(self) -> dict:
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in asdict(self).items()}


def _grid(p: DLVOParameters, n=4000):
    lo = max(p.minimum_separation, 1e-3 * p.debye_length)
    hi = max(40.0 * p.debye_length, 0.5 * p.radius)
    return np.geomspace(lo, hi, n)


def dlvo_extrema(surface_potential=0.0, **parameters) -> DLVOExtrema:
    """Barrier (local maximum) and secondary minimum of the DLVO potential.

    The extrema are bracketed on a logarithmic grid of surface separations from
    the minimum separation to ``max(40/κ, a/2)`` and refined with Brent's method on
    the force (relative tolerance 1e-12).

    Parameters
    ----------
    surface_potential : float or DLVOParameters
        Ψ0 in volts or a parameter object.
    **parameters
        As :func:`dlvo_potential`.
    """
    from scipy.optimize import brentq

    p = _resolve(surface_potential, parameters)
    a, kT = p.radius, p.kT
    h = _grid(p)
    _, f = _terms(2.0 * a + h, p)
    # force > 0 repulsive: a maximum of V where f goes + -> - outwards... V' = -f;
    # a maximum of V is where V' goes + -> -, i.e. f goes - -> +.
    sgn = np.sign(f)
    changes = np.nonzero(sgn[:-1] * sgn[1:] < 0)[0]
    h_max = h_sec = float("nan")

    def root(k):
        g = lambda x: float(_terms(np.array([2.0 * a + x]), p)[1][0])  # noqa: E731
        return brentq(g, h[k], h[k + 1], xtol=1e-14 * a, rtol=1e-12)

    for k in changes:
        if sgn[k] < 0 < sgn[k + 1] and math.isnan(h_max):
            h_max = root(k)
        elif sgn[k] > 0 > sgn[k + 1] and not math.isnan(h_max):
            h_sec = root(k)
            break
    v0 = float(_terms(np.array([2.0 * a + p.minimum_separation]), p)[0][0]) / kT
    if math.isnan(h_max) or math.isnan(h_sec):
        nan = float("nan")
        return DLVOExtrema(p.surface_potential, False, nan, nan, nan, nan, nan, v0)
    vm = float(_terms(np.array([2.0 * a + h_max]), p)[0][0]) / kT
    vs = float(_terms(np.array([2.0 * a + h_sec]), p)[0][0]) / kT
    return DLVOExtrema(p.surface_potential, True, h_max, vm, h_sec, vs, vm - vs, v0)


def secondary_minimum_onset(low=0.0, high=0.1, tol=1e-7, **parameters) -> float:
    """Smallest surface potential (V) at which a secondary minimum exists (bisection).

    Returns NaN if there is none up to ``high`` volts.
    """
    has = lambda psi: dlvo_extrema(psi, **parameters).has_secondary_minimum  # noqa: E731
    if not has(high):
        return float("nan")
    if has(low):
        return float(low)
    while high - low > tol:
        mid = 0.5 * (low + high)
        if has(mid):
            high = mid
        else:
            low = mid
    return high


def plot_dlvo(surface_potentials=(0.0, 0.012, 0.013, 0.014, 0.015), ax=None, max_separation=None,
              **parameters):
    """Plot the DLVO energy in kBT against the surface separation in nm.

    One curve per surface potential, with its barrier and secondary minimum marked
    (Ψ0 = 0, 12-15 mV are the BD set of §2.2 of 003_873b69fc71c74cf6.txt).

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.0))
    p0 = dlvo_parameters(0.0, **parameters)
    hmax = max_separation if max_separation is not None else 8.0 * p0.debye_length
    h = np.linspace(p0.minimum_separation, hmax, 2000)
    lo = 0.0
    for psi in np.atleast_1d(surface_potentials):
        p = dlvo_parameters(float(psi), **parameters)
        v = dlvo_potential(2.0 * p.radius + h, p) / p.kT
        (line,) = ax.plot(h * 1e9, v, label=f"Ψ0 = {1e3 * psi:g} mV")
        ex = dlvo_extrema(p)
        if ex.has_secondary_minimum:
            ax.plot([ex.barrier_separation * 1e9], [ex.maximum_energy], "^", color=line.get_color())
            ax.plot([ex.secondary_separation * 1e9], [ex.secondary_energy], "v", color=line.get_color())
            ax.annotate(f"{ex.barrier:.2f} kBT", (ex.barrier_separation * 1e9, ex.maximum_energy),
                        textcoords="offset points", xytext=(4, 4), fontsize=8)
        lo = min(lo, float(np.nanmin(v[h > 2 * p.debye_length])) if np.any(h > 2 * p.debye_length) else lo)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_ylim(min(-5.0, 1.5 * lo), 10.0)
    ax.set_xlabel("surface separation h = r − 2a (nm)")
    ax.set_ylabel("pair energy V / kBT")
    ax.set_title(f"DLVO, a = {p0.radius * 1e6:g} µm, 1/κ = {p0.debye_length * 1e9:.2f} nm, "
                 f"A = {p0.hamaker:.3g} J")
    ax.legend(title="surface potential (▲ barrier, ▼ secondary min.)", fontsize=8)
    return ax
