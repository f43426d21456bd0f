"""Analytic RDFs and contact values compared with measured ones in §5 of
000_2cedc098acbd866b.txt.

Conventions: ``a`` is the sphere radius, ``c`` the volume fraction (packing
fraction ``eta``), ``r`` the centre distance; contact is at ``r = 2a`` (mixtures:
``a_i + a_j``). ``g_c`` functions return ``g(2a+) - 1`` as in Eq. (11) of 000_2cedc098acbd866b.txt to Eq. (13) of 000_2cedc098acbd866b.txt;
``*_contact`` functions return ``g(2a+)`` itself.

Two printed equations are not consistent with the rest of the seed and with the
literature it cites; both variants are available and the choice is documented
where it matters:

* Eq. (13) of 000_2cedc098acbd866b.txt reads ``(2 + c) / (2 (1 - c^2)) - 1`` in the extracted text. The
  Percus-Yevick contact value is ``(1 + c/2) / (1 - c)^2`` (Throop and Bearman
  1965; Eq. (23) of 000_2cedc098acbd866b.txt at ``lambda = 1``); :func:`kanaun_g_c` uses it, and
  ``printed=True`` gives the extracted form.
* Eq. (17) of 000_2cedc098acbd866b.txt divides ``g_c^W(c_2) - 1`` by ``g_c^W(c_1) - 1`` although ``g_c^W`` is
  already ``g(2a+) - 1`` and the text before it assumes the ratio
  ``g_c(c_2) / g_c(c_1)``; :func:`extrapolate_rdf` uses the ratio (consistent with
  the Willis form (11)) unless ``printed=True``.
"""

from __future__ import annotations

import numpy as np

from ..errors import InvalidInputError
from ..geometry import ball_volume

__all__ = [
    "well_stirred",
    "willis_g_c",
    "kanaun_g_c",
    "willis_g_r",
    "willis",
    "percus_yevick_contact",
    "carnahan_starling_contact",
    "percus_yevick_rdf",
    "percus_yevick_mixture_contact",
    "percus_yevick_dilute_contact",
    "well_stirred_partial",
    "willis_partial",
    "extrapolate_rdf",
    "peak_positions_unimodal",
    "peak_positions_bimodal",
    "plot",
]


def _fraction(c, upper=1.0):
    c = np.asarray(c, dtype=np.float64)
    if np.any(~np.isfinite(c)) or np.any(c < 0) or np.any(c >= upper):
        raise InvalidInputError(f"volume fraction c={c!r} must lie in [0, {upper:g})")
    return c


def _radius(a, name="a"):
    a = float(a)
    if not np.isfinite(a) or a <= 0:
        raise InvalidInputError(f"{name}={a!r} must be finite and > 0")
    return a


# ------------------------------------------------------------------ unimodal
def well_stirred(r, a):
    """Well-stirred approximation ``g(r) = H(r - 2a)``, Eq. (10) of 000_2cedc098acbd866b.txt."""
    a = _radius(a)
    return np.where(np.asarray(r, dtype=np.float64) >= 2 * a, 1.0, 0.0)


def willis_g_c(c):
    """Willis' amplitude ``g_c0^W(c) = 0.8006 (8c - 1)/c``, Eq. (12_1) of 000_2cedc098acbd866b.txt; needs ``c >= 1/8``."""
    c = _fraction(c)
    if np.any(c < 0.125):
        raise InvalidInputError(f"c={c!r}: Willis' Eq. (12_1) of 000_2cedc098acbd866b.txt needs c >= 1/8 (else use kanaun_g_c)")
    return 0.8006 * (8.0 * c - 1.0) / c


def kanaun_g_c(c, printed=False):
    """Kanaun's amplitude ``g_c^PY(c) = g_PY(2a+) - 1``, Eq. (13) of 000_2cedc098acbd866b.txt.

    Uses the Percus-Yevick contact value ``(1 + c/2)/(1 - c)^2``; ``printed=True``
    evaluates the extracted Eq. (13) of 000_2cedc098acbd866b.txt, ``(2 + c)/(2 (1 - c^2)) - 1``, instead.
    """
    c = _fraction(c)
    if printed:
        return (2.0 + c) / (2.0 * (1.0 - c**2)) - 1.0
    return percus_yevick_contact(c) - 1.0


def willis_g_r(r, a):
    """Radial factor ``g_r^W(r) = cos(pi r / a) exp(2 (2 - r/a))``, Eq. (12_2) of 000_2cedc098acbd866b.txt."""
    a = _radius(a)
    x = np.asarray(r, dtype=np.float64) / a
    return np.cos(np.pi * x) * np.exp(2.0 * (2.0 - x))


def willis(r, a, c, amplitude="kanaun"):
    """Willis approximation ``H(r - 2a) [1 + g_c(c) g_r(r)]``, Eq. (11) of 000_2cedc098acbd866b.txt.

    ``amplitude="kanaun"`` (the seed's default, Eq. (13) of 000_2cedc098acbd866b.txt) or ``"willis"`` (Eq. (12_1) of 000_2cedc098acbd866b.txt).
    """
    if amplitude == "kanaun":
        gc = kanaun_g_c(c)
    elif amplitude == "willis":
        gc = willis_g_c(c)
    else:
        raise InvalidInputError(f"amplitude={amplitude!r}: allowed are 'kanaun' and 'willis'")
    return well_stirred(r, a) * (1.0 + gc * willis_g_r(r, a))


def percus_yevick_contact(c):
    """Percus-Yevick contact value ``g(2a+) = (1 + c/2) / (1 - c)^2`` of hard spheres."""
    c = _fraction(c)
    return (1.0 + 0.5 * c) / (1.0 - c) ** 2


def carnahan_starling_contact(c):
    """Carnahan-Starling contact value ``g(2a+) = (1 - c/2) / (1 - c)^3``."""
    c = _fraction(c)
    return (1.0 - 0.5 * c) / (1.0 - c) ** 3


def _py_c_hat(k, eta):
    """3-D Fourier transform of the PY direct correlation function (sigma = 1)."""
    l1 = (1 + 2 * eta) ** 2 / (1 - eta) ** 4
    l2 = -((1 + 0.5 * eta) ** 2) / (1 - eta) ** 4
    s, co = np.sin(k), np.cos(k)
    # I_n = int_0^1 r^n sin(kr) dr, J_n = int_0^1 r^n cos(kr) dr (recursions)
    j0 = s / k
    i1 = (s - k * co) / k**2
    j1 = (k * s + co - 1) / k**2
    i2 = -co / k + 2 / k * j1
    j2 = s / k - 2 / k * i1
    i3 = -co / k + 3 / k * j2
    j3 = s / k - 3 / k * i2
    i4 = -co / k + 4 / k * j3
    del j0, i3
    # c(r) = -l1 - 6 eta l2 r - eta l1 r^3 / 2 for r < 1: c_hat = 4 pi / k int r c(r) sin(kr)
    return 4 * np.pi / k * (-l1 * i1 - 6 * eta * l2 * i2 - 0.5 * eta * l1 * i4)


def percus_yevick_rdf(r, a, c, dr=None, r_cut=None):
    """Percus-Yevick g(r) of hard spheres of radius ``a`` at volume fraction ``c``.

    Wertheim's closed-form PY direct correlation function is transformed
    analytically; the Ornstein-Zernike relation gives the indirect part
    ``gamma = h - c`` (continuous at contact, so its sine transform converges fast),
    which is inverted numerically by a discrete sine transform on a fine grid.
    Outside the core ``g = 1 + gamma``; inside ``g = 0``. Accuracy: contact value
    within 1e-3 of ``(1 + c/2)/(1 - c)^2`` with the default grid.

    Parameters
    ----------
    r : array_like
        Distances (same unit as ``a``).
    a : float
        Sphere radius.
    c : float
        Volume fraction, ``0 <= c < 0.74``.
    dr : float, optional
        Grid step in units of the diameter (default 1e-3).
    r_cut : float, optional
        Grid length in diameters (default 64).
    """
    from scipy.fft import dst

    a = _radius(a)
    eta = float(_fraction(c, upper=0.74))
    dr = 1e-3 if dr is None else float(dr)
    r_cut = 64.0 if r_cut is None else float(r_cut)
    x = np.asarray(r, dtype=np.float64) / (2 * a)
    if eta == 0:
        return np.where(x >= 1, 1.0, 0.0)
    n = int(round(r_cut / dr))
    dk = np.pi / (n * dr)
    j = np.arange(1, n)
    k = j * dk
    rho = 6 * eta / np.pi
    ch = _py_c_hat(k, eta)
    gh = rho * ch**2 / (1 - rho * ch)
    # gamma(r_i) = 1/(2 pi^2 r_i) sum_j dk k_j gh_j sin(k_j r_i); DST-I gives 2 sum sin(pi i j / n)
    ri = j * dr
    gamma = dst(k * gh, type=1) / 2 * dk / (2 * np.pi**2 * ri)
    gam = np.interp(x, np.concatenate([[0.0], ri]), np.concatenate([[gamma[0]], gamma]), right=0.0)
    return np.where(x >= 1, 1.0 + gam, 0.0)


# ------------------------------------------------------------------ mixtures
def percus_yevick_mixture_contact(radii, volume_fractions):
    """PY contact values ``g_ij(a_i + a_j)`` of a hard-sphere mixture, Eq. (21) of 000_2cedc098acbd866b.txt to Eq. (22) of 000_2cedc098acbd866b.txt.

    ``g_ii = (1 - zeta_3 + 3 a_i zeta_2) / (1 - zeta_3)^2`` (the extracted Eq. (22) of 000_2cedc098acbd866b.txt
    lacks the division), ``g_ij = (a_j g_ii + a_i g_jj) / (a_i + a_j)``, with
    ``zeta_alpha = (pi 2^(alpha-1) / 3) sum_k n_k a_k^alpha`` and number densities
    ``n_k = c_k / (4/3 pi a_k^3)``.

    Returns
    -------
    (K, K) ndarray
    """
    a = np.asarray(radii, dtype=np.float64)
    cf = np.asarray(volume_fractions, dtype=np.float64)
    if a.shape != cf.shape or a.ndim != 1 or a.size == 0:
        raise InvalidInputError("radii and volume_fractions must be 1-D arrays of the same length")
    if np.any(a <= 0) or np.any(cf < 0) or cf.sum() >= 1:
        raise InvalidInputError(f"radii {a.tolist()} must be > 0 and fractions {cf.tolist()} >= 0 with sum < 1")
    n = cf / ball_volume(a, 3)
    z2 = np.pi * 2.0 / 3.0 * np.sum(n * a**2)
    z3 = np.pi * 4.0 / 3.0 * np.sum(n * a**3)
    gii = (1 - z3 + 3 * a * z2) / (1 - z3) ** 2
    return (a[None, :] * gii[:, None] + a[:, None] * gii[None, :]) / (a[:, None] + a[None, :])


def percus_yevick_dilute_contact(c1, size_ratio):
    """``g_12(a_1 + a_2)`` for a vanishing amount of species 2, Eq. (23) of 000_2cedc098acbd866b.txt.

    ``[1 + c1 (2 lambda - 1)/(lambda + 1)] / (1 - c1)^2`` with ``lambda = a_2/a_1``;
    equals :func:`percus_yevick_contact` at ``lambda = 1``.
    """
    c1 = _fraction(c1)
    lam = float(size_ratio)
    if not lam > 0:
        raise InvalidInputError(f"size_ratio={size_ratio!r} must be > 0")
    return (1 + c1 * (2 * lam - 1) / (lam + 1)) / (1 - c1) ** 2


def well_stirred_partial(r, a_i, a_j):
    """``g_ij = H(R_ij - 2)``, Eq. (19) of 000_2cedc098acbd866b.txt, ``R_ij = (r - a_i)/a_j + 1``."""
    R = (np.asarray(r, dtype=np.float64) - _radius(a_i, "a_i")) / _radius(a_j, "a_j") + 1
    return np.where(R >= 2, 1.0, 0.0)


def willis_partial(r, a_i, a_j, contact_value):
    """``H(R - 2) [1 + (g^c_ij - 1) cos(pi R) exp(2 (2 - R))]``, Eq. (20) of 000_2cedc098acbd866b.txt.

    ``contact_value`` is ``g^c_ij``, e.g. from :func:`percus_yevick_mixture_contact`.
    """
    R = (np.asarray(r, dtype=np.float64) - _radius(a_i, "a_i")) / _radius(a_j, "a_j") + 1
    return np.where(R >= 2, 1.0 + (float(contact_value) - 1.0) * np.cos(np.pi * R) * np.exp(2 * (2 - R)), 0.0)


def extrapolate_rdf(r, g, a, c1, c2, amplitude="kanaun", printed=False):
    """Rescale a measured RDF from volume fraction ``c1`` to ``c2``, Eq. (17) of 000_2cedc098acbd866b.txt.

    Outside the core ``g(r, c2) - 1 = [g(r, c1) - 1] * q``; inside it stays 0.
    ``q = g_c(c2)/g_c(c1)`` (the assumption stated before Eq. (17) of 000_2cedc098acbd866b.txt) or, with
    ``printed=True``, ``(g_c(c2) - 1)/(g_c(c1) - 1)`` as Eq. (17) of 000_2cedc098acbd866b.txt is printed.
    """
    fn = {"kanaun": kanaun_g_c, "willis": willis_g_c}.get(amplitude)
    if fn is None:
        raise InvalidInputError(f"amplitude={amplitude!r}: allowed are 'kanaun' and 'willis'")
    g1, g2 = float(fn(c1)), float(fn(c2))
    q = (g2 - 1) / (g1 - 1) if printed else g2 / g1
    r = np.asarray(r, dtype=np.float64)
    g = np.asarray(g, dtype=np.float64)
    return np.where(r >= 2 * _radius(a), 1 + (g - 1) * q, 0.0)


# ------------------------------------------------------------- peak positions
def peak_positions_unimodal():
    """Peak and gap positions of a dense unimodal pack in ``R = r/a`` (§5.1).

    First peak (contact) 2, second ``2 sqrt 3`` (split second shell, configuration
    of Fig. 3A), third 4 (three spheres in a row, Fig. 3B); first gap
    ``2 + sqrt(3)/2`` between first and second neighbours.
    """
    return {"contact": 2.0, "second": 2 * np.sqrt(3.0), "third": 4.0, "gap": 2 + np.sqrt(3.0) / 2}


def peak_positions_bimodal(a_k, a_m, a_other=None):
    """Expected peaks of ``g_km`` in the scaled coordinate ``R_km`` (§5.3).

    ``lambda_km = a_k / a_m``. Returns a dict of named positions:

    * ``contact``: 2 (``r = a_k + a_m``);
    * ``row_m``: 4, configuration ``v_k - (v_m) - v_m`` (``r = a_k + 3 a_m``);
    * ``row_k``: ``2 (1 + lambda_km)``, configuration ``v_k - (v_k) - v_m``;
    * ``second_kkm``: ``(sqrt 3 - 1) lambda + sqrt(1 + 2 lambda) + 1``;
    * ``second_kmm``: ``sqrt 3 - lambda + sqrt(lambda^2 + 2 lambda) + 1``;
    * ``row_via_other``: ``v_k - (v_o) - v_m`` with a middle sphere of radius
      ``a_other`` (e.g. ``R_11 = 2 + 2 lambda`` for a small sphere between two large).
    """
    ak, am = _radius(a_k, "a_k"), _radius(a_m, "a_m")
    lam = ak / am
    out = {
        "contact": 2.0,
        "row_m": 4.0,
        "row_k": 2 * (1 + lam),
        "second_kkm": (np.sqrt(3) - 1) * lam + np.sqrt(1 + 2 * lam) + 1,
        "second_kmm": np.sqrt(3) - lam + np.sqrt(lam**2 + 2 * lam) + 1,
    }
    if a_other is not None:
        ao = _radius(a_other, "a_other")
        out["row_via_other"] = (ak + 2 * ao + am - ak) / am + 1
    return out


# ------------------------------------------------------------------ plotting
def plot(a, c, measured=None, models=("well_stirred", "willis", "percus_yevick"), r_max=None, ax=None):
    """Plot theory curves vs ``r/a`` (Figs. 1-2 style), optionally over a measured RDF.

    Parameters
    ----------
    a, c : float
        Radius and volume fraction.
    measured : RDF or (r, g) tuple, optional
    models : iterable of {"well_stirred", "willis", "willis_original", "percus_yevick"}
    r_max : float, optional
        Largest r (default: the measured range or 5a).

    Returns
    -------
    matplotlib.axes.Axes
    """
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots()
    if measured is not None:
        rm, gm = (measured.r, measured.g) if hasattr(measured, "g") else measured
        ax.plot(np.asarray(rm) / a, gm, color="k", lw=1.5, label="measured")
        r_max = r_max or float(np.max(rm))
    r_max = r_max or 5 * a
    r = np.linspace(0, r_max, 2000)
    fns = {
        "well_stirred": lambda: well_stirred(r, a),
        "willis": lambda: willis(r, a, c),
        "willis_original": lambda: willis(r, a, c, amplitude="willis"),
        "percus_yevick": lambda: percus_yevick_rdf(r, a, c),
    }
    for m in models:
        if m not in fns:
            raise InvalidInputError(f"model {m!r}: allowed are {', '.join(fns)}")
        ax.plot(r / a, fns[m](), lw=1.0, label=m.replace("_", " "))
    ax.set_xlabel("r / a")
    ax.set_ylabel("g(r)")
    ax.legend()
    return ax
