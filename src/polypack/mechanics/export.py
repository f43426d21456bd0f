"""Bonded networks out to OVITO, ParaView and LAMMPS: bond lists, bond forces, non-affine fields.

:func:`write_network` writes a :class:`~polypack.mechanics.BondNetwork` (optionally with
the linear response of :func:`~polypack.mechanics.elastic_tensor` under one strain mode)
through :mod:`polypack.io.bonds`: GSD (OVITO draws the bonds), a VTK multiblock
``.vtm`` (particles plus bond lines for ParaView and OVITO) or a LAMMPS data file for
the BPM package (``atom_style bpm/sphere``, ``bond_style bpm/rotational``) whose header
holds a commented input snippet with polypack's contact-bond parameters.
:func:`read_network` reads a GSD or VTK file back into a ``BondNetwork``.

LAMMPS ``bond_style bpm/rotational`` versus polypack's PFC contact bonds
------------------------------------------------------------------------
Coefficients per bond type: ``Kr Ks Kt Kb Fcr Fcs Tct Tcb gn gs gr gt`` (LAMMPS source
``bond_bpm_rotational.cpp``; the manual lists the two critical torques in the other
order, which does not matter here since both are set equal). The mapping is
``Kr = k_n``, ``Ks = k_s`` (force per length, ``normalize no``; the network's
*per-contact* values, so a network built with ``stiffness="particle"`` writes the series
combination, ``k/2`` for equal balls, never the per-ball input), ``Kt = Kb = 0`` (a
contact bond has no moment resistance), ``Fcr`` = normal (tensile) strength, ``Fcs`` =
shear strength, ``Tct = Tcb = 1`` (any positive value: the torques are zero, the
criterion divides by them), damping ``gn gs`` as chosen, ``gr = gt = 0``, and
``bond_style bpm/rotational smooth no`` (the default ``smooth yes`` multiplies every
force by ``1 - B^4``). With these settings the two models agree to first order in the
displacements, for equal spheres exactly; where they differ:

- **Reference state.** LAMMPS stores each bond's reference (length and direction) at
  the first ``run``: the network always starts stress-free, as polypack's
  ``reference="stress-free"``. A ``"zero-gap"`` network (prestressed, ``k_n g`` across a
  gap ``g``) cannot be expressed.
- **Contact point.** The tangential spring of ``bpm/rotational`` acts at the bond's
  midpoint (lever arm ``|b|/2`` on each side); PFC's contact point is
  ``x_i + (r_i - U_n/2) n``. They coincide for equal radii; for unequal radii the
  coupling of shear to particle rotation differs (not the translational response).
- **Shear displacement.** LAMMPS measures the total tangential displacement from the
  rotation of the bond relative to the particles' orientations (Wang 2009); PFC updates
  the shear force incrementally and rotates it with the contact plane. Same at small
  strain, different at large rotations.
- **Breakage.** ``bpm/rotational`` breaks a bond when
  ``Fr/Fcr + |Fs|/Fcs (+ torque terms) >= 1`` (tension only); a PFC contact bond breaks
  when the tension reaches the normal strength *or* the shear force reaches the shear
  strength, so under combined load LAMMPS breaks earlier. Unbreakable bonds
  (``np.inf``) become ``break no`` with a large finite strength.
- **Damping.** Seed 003's local (Cundall) damping, Eq. (3) of 003_873b69fc71c74cf6.txt,
  does not exist in LAMMPS; ``bpm/rotational`` damps relative normal and sliding
  velocities viscously (``gn``, ``gs``). A damping ratio ``D`` of a bond between two
  masses ``m`` is ``gn = 2 D sqrt(k_n m / 2)``; local damping ``alpha`` dissipates like
  ``D = alpha / pi`` per cycle (REFERENCES). Damping does not enter the static
  (low-frequency) storage modulus.
- **Unbonded contacts.** polypack's DEM applies the linear contact law of Eq. (1) of
  003_873b69fc71c74cf6.txt to touching unbonded spheres; the snippet uses
  ``pair_style granular`` with ``hooke k_n 0`` and frictionless tangential springs
  (``special_bonds lj 0 1 1`` switches it off between bonded spheres).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import InvalidInputError

__all__ = ["write_network", "read_network", "bond_forces", "lammps_bond_coeffs", "lammps_snippet",
           "lammps_shear_input", "fit_lammps_shear", "MODES"]

#: (gradient axis, flow axis) -> LAMMPS tilt factor (x displaced along z is "xz", ...)
_TILTS = {(1, 0): ("xy", "ly", 4), (2, 0): ("xz", "lz", 5), (2, 1): ("yz", "lz", 6)}

#: Voigt strain modes (engineering shears): name -> column of the 6x6 tensors.
MODES = {"11": 0, "22": 1, "33": 2, "23": 3, "13": 4, "12": 5}


def _mode(mode) -> int:
    key = str(mode)
    if key not in MODES:
        raise InvalidInputError(f"mode={mode!r}: allowed are {', '.join(MODES)} (Voigt, engineering shear)")
    return MODES[key]


def _length_scale(network, elastic) -> float:
    rad = np.asarray(network.packing.radii, dtype=np.float64)
    return float(elastic.length_scale) / (2.0 * float(rad.mean()))


def bond_forces(network, elastic, mode="13", strain: float = 1.0) -> np.ndarray:
    """Force on particle ``i`` from ``j`` in every bond under a homogeneous strain.

    Evaluates the relaxed linear response of :func:`~polypack.mechanics.elastic_tensor`:
    the relative displacement of the contact point
    ``delta = (u_j + theta_j x a_j) - (u_i + theta_i x a_i) + eps b`` and the spring
    force ``f = K delta`` with ``K = k_n n n^T + k_s (I - n n^T)`` (Eq. (1) of
    003_873b69fc71c74cf6.txt and Eq. (2) of 003_873b69fc71c74cf6.txt). Bonds of rattlers
    and of clusters that do not wrap the box carry no force (they relax completely).
    Summed as ``(1/V) sum_c f_c b_c^T`` the forces give the stress ``C eps``.

    Parameters
    ----------
    network : BondNetwork
    elastic : ElasticTensor
        ``elastic_tensor(network)`` (with or without rotations).
    mode : {"11", "22", "33", "23", "13", "12"}
        Voigt strain mode (``"13"``: shear along x with gradient along z, the seed's
        plate test; engineering shear strain ``gamma_13 = strain``).
    strain : float
        Strain amplitude (the response is linear).

    Returns
    -------
    (M, 3) ndarray
        Force vectors (tension pulls ``i`` towards ``j``: ``f . n > 0``), in stiffness
        times length units (N for N/m and the tensor's lengths, metres when built with
        ``radius=``).
    """
    k = _mode(mode)
    disp = np.asarray(elastic.nonaffine_displacements)[k]
    n_all = network.n
    if disp.shape != (n_all, 3) or int(elastic.n_bonds) != network.n_bonds:
        raise InvalidInputError("elastic does not belong to this network (particle or bond counts differ)")
    rot = elastic.nonaffine_rotations
    scale = _length_scale(network, elastic)
    i, j = network.i, network.j
    b = np.asarray(network.branch) * scale
    arm_i = np.asarray(network.lever_arm_i) * scale
    arm_j = np.asarray(network.lever_arm_j) * scale
    ui, uj = disp[i], disp[j]
    if rot is not None:
        ti, tj = np.asarray(rot)[k][i], np.asarray(rot)[k][j]
        ui = ui + np.cross(ti, arm_i)
        uj = uj + np.cross(tj, arm_j)
    eps = np.zeros((3, 3))
    p, q = {0: (0, 0), 1: (1, 1), 2: (2, 2), 3: (1, 2), 4: (0, 2), 5: (0, 1)}[k]
    if p == q:
        eps[p, p] = 1.0
    else:
        eps[p, q] = eps[q, p] = 0.5
    delta = uj - ui + b @ eps.T
    nrm = np.asarray(network.normal)
    kn = np.asarray(network.normal_stiffness)[:, None]
    ks = np.asarray(network.shear_stiffness)[:, None]
    dn = np.einsum("ij,ij->i", delta, nrm)[:, None]
    f = kn * dn * nrm + ks * (delta - dn * nrm)
    f[~np.all(np.isfinite(f), axis=1)] = 0.0  # a rattler end: undetermined motion, no force
    return float(strain) * f


def lammps_bond_coeffs(network, damping=(0.0, 0.0)):
    """Bond types and ``bond_style bpm/rotational`` coefficient rows for a network.

    One bond type per distinct ``(k_n, k_s, normal_strength, shear_strength)``.

    Parameters
    ----------
    network : BondNetwork
    damping : (float, float)
        ``(gn, gs)``, viscous damping of relative normal and sliding velocities (force
        per velocity); 0 by default.

    Returns
    -------
    types : (M,) int64
        1-based bond type of each bond.
    coeffs : (T, 12) ndarray
        ``Kr Ks Kt Kb Fcr Fcs Tct Tcb gn gs gr gt`` per type (see the module notes).
    breakable : bool
        False when every strength is infinite (write ``break no``; the critical forces
        are then ``k`` times the mean diameter, never reached at small strain); infinite
        strengths of other bonds are replaced by 1e300.
    """
    gn, gs = (float(x) for x in damping)
    if not (np.isfinite(gn) and np.isfinite(gs) and gn >= 0 and gs >= 0):
        raise InvalidInputError(f"damping={damping!r}: need two finite values >= 0")
    key = np.column_stack([network.normal_stiffness, network.shear_stiffness,
                           network.normal_strength, network.shear_strength])
    rows, types = np.unique(key, axis=0, return_inverse=True)
    strengths = rows[:, 2:4]
    breakable = bool(np.isfinite(strengths).any())
    if breakable:
        strengths = np.where(np.isfinite(strengths), strengths, 1e300)
    else:  # break no: a bond stretched by a mean diameter would still stop LAMMPS with an error
        d = 2.0 * float(np.mean(network.packing.radii))
        strengths = np.ones_like(strengths) * rows[:, :1] * d
    coeffs = np.column_stack([
        rows[:, 0], rows[:, 1], np.zeros(len(rows)), np.zeros(len(rows)), strengths[:, 0], strengths[:, 1],
        np.ones(len(rows)), np.ones(len(rows)), np.full(len(rows), gn), np.full(len(rows), gs),
        np.zeros(len(rows)), np.zeros(len(rows)),
    ])
    return types.reshape(-1).astype(np.int64) + 1, coeffs, breakable


def lammps_snippet(network, data_file="network.data", damping=(0.0, 0.0), timestep=None) -> list[str]:
    """Input-script lines (LAMMPS BPM package) that set up a data file from :func:`write_network`.

    Returned as plain lines; :func:`write_network` puts them, commented, in the header
    of the data file. ``bond_style`` and ``bond_coeff`` follow ``read_data`` (a BPM bond
    style needs the box). Units are whatever the pack and stiffnesses use (SI for SI
    input: ``units si``). Floats are written exactly (shortest round-trip decimal).
    """
    from ..io._common import num

    types, coeffs, breakable = lammps_bond_coeffs(network, damping)
    rad = np.asarray(network.packing.radii)
    gap = max(float(np.max(network.relative_gap)), 0.0)
    cut = 2.0 * float(rad.max()) * (1.0 + gap) * 1.1
    kn = float(np.max(network.normal_stiffness))
    periodic = getattr(network.packing, "periodic", (True,) * 3)
    boundary = " ".join("p" if p else "f" for p in periodic)
    lines = [
        "units           si        # or lj: lengths and stiffnesses are used as polypack has them",
        "dimension       3",
        f"boundary        {boundary}",
        "atom_style      bpm/sphere",
        "special_bonds   lj 0 1 1 coul 1 1 1   # no pair force between bonded spheres",
        "newton          on off",
        f"comm_modify     vel yes cutoff {cut:.6g}",
        f"read_data       {data_file}",
        f"bond_style      bpm/rotational smooth no break {'yes' if breakable else 'no'}",
        "#               type Kr=kn Ks=ks Kt Kb Fcr=normal_strength Fcs=shear_strength Tct Tcb gn gs gr gt",
    ]
    for t, row in enumerate(coeffs, start=1):
        lines.append(f"bond_coeff      {t} " + " ".join(num(v) for v in row))
    lines += [
        "pair_style      granular  # unbonded contacts: linear normal spring, frictionless",
        f"pair_coeff      * * hooke {num(kn)} 0.0 tangential linear_history 0.0 0.0 0.0",
        "fix             integrate all nve/bpm/sphere",
        f"timestep        {'<dt, below the critical step 2/omega_max>' if timestep is None else num(timestep)}",
    ]
    return lines


def lammps_shear_input(network, data_file="network.data", *, frequency: float, amplitude: float = 1e-3,
                       cycles: int = 10, steps_per_cycle: int = 4000, samples_per_cycle: int = 100,
                       direction=(2, 0), damping=(0.0, 0.0), output="shear.txt") -> str:
    """A complete LAMMPS input that reruns the oscillatory shear test on an exported network.

    The set-up of :func:`lammps_snippet` followed by a sinusoidal simple shear of the
    periodic cell: ``fix deform ... wiggle`` of one tilt factor with ``remap x`` (every
    position follows the homogeneous strain; the counterpart of polypack's
    ``oscillatory_shear(boundary="lees-edwards")``; the seed's plates are not
    reproduced), strain ``gamma = amplitude sin(2 pi f t)`` from the first step (no
    ramp), the time step ``1 / (f S)``. Every ``S / samples_per_cycle`` steps the time,
    the strain and the shear stress (the virial of bonds and contacts, ``-P_ag``) go to
    ``output``; :func:`fit_lammps_shear` turns that file into ``G'`` and ``G''``.

    Parameters
    ----------
    network : BondNetwork
    data_file : str
        Name of the data file written by :func:`write_network` (masses follow its
        density column: scale it as ``oscillatory_shear`` scales masses).
    frequency, amplitude, cycles, steps_per_cycle, samples_per_cycle
        As in :func:`polypack.mechanics.oscillatory_shear`.
    direction : (gradient axis, flow axis)
        ``(2, 0)`` (shear along x, gradient z: the Voigt C55), ``(1, 0)`` or ``(2, 1)``:
        the tilts LAMMPS has (xz, xy, yz).
    damping : (gn, gs)
        Bond damping (viscous; polypack's local damping has no LAMMPS counterpart).

    Returns
    -------
    str
        The input script (run ``lmp -in shear.in``).
    """
    from ..io._common import num

    key = tuple(int(a) for a in direction)
    if key not in _TILTS:
        raise InvalidInputError(f"direction={direction!r}: LAMMPS tilts give (2, 0) xz, (1, 0) xy or (2, 1) yz")
    for name, v in (("frequency", frequency), ("amplitude", amplitude)):
        if not (np.isfinite(v) and v > 0):
            raise InvalidInputError(f"{name}={v!r}: must be finite and > 0")
    for name, v in (("cycles", cycles), ("steps_per_cycle", steps_per_cycle), ("samples_per_cycle", samples_per_cycle)):
        if int(v) != v or v < 1:
            raise InvalidInputError(f"{name}={v!r}: must be a positive integer")
    every = max(1, int(steps_per_cycle) // int(samples_per_cycle))
    tilt, length, col = _TILTS[key]
    period = 1.0 / float(frequency)
    dt = period / int(steps_per_cycle)
    lines = [line for line in lammps_snippet(network, data_file, damping, timestep=dt)]
    lines += [
        "change_box      all triclinic",
        f"variable        amp equal {num(amplitude)}*{length}",
        f"fix             shear all deform 1 {tilt} wiggle ${{amp}} {num(period)} remap x units box",
        "compute         stress all pressure NULL virial   # bonds and contacts; stress = -pressure",
        "variable        t equal time",
        f"variable        gamma equal {tilt}/{length}",
        f"variable        sigma equal -c_stress[{col}]",
        f'fix             out all print {every} "${{t}} ${{gamma}} ${{sigma}}" file {output} screen no '
        'title "# time strain stress"',
        f"thermo          {every * int(samples_per_cycle)}",
        f"run             {int(cycles) * int(steps_per_cycle)}",
    ]
    head = [
        f"# polypack: oscillatory simple shear ({tilt}) of {data_file}: f = {num(frequency)}, amplitude "
        f"{num(amplitude)}, {int(cycles)} cycles of {int(steps_per_cycle)} steps",
    ]
    return "\n".join(head + lines) + "\n"


def fit_lammps_shear(path, frequency: float, discard_cycles: int = 1) -> dict:
    """``G'`` and ``G''`` from the output of :func:`lammps_shear_input`.

    Least squares ``sigma = G' gamma + (G''/omega) gamma_dot + c0 + c1 t`` over the whole
    cycles after the first ``discard_cycles``, with ``gamma = A sin(omega t)`` (the fit
    of :func:`polypack.mechanics.oscillatory_shear`).

    Returns
    -------
    dict
        ``storage_modulus``, ``loss_modulus``, ``amplitude`` (the fitted strain
        amplitude), ``cycles`` (used).
    """
    data = np.loadtxt(path, comments="#", ndmin=2)
    t, gamma, sigma = data[:, 0], data[:, 1], data[:, 2]
    period = 1.0 / float(frequency)
    omega = 2.0 * np.pi * float(frequency)
    n_cycles = int(np.floor(t.max() / period + 1e-9))
    keep = (t >= discard_cycles * period) & (t <= n_cycles * period + 1e-9 * period)
    if n_cycles - discard_cycles < 1 or keep.sum() < 8:
        raise InvalidInputError(f"{path}: {n_cycles} whole cycle(s) recorded, need more than discard_cycles="
                                f"{discard_cycles}")
    t, gamma, sigma = t[keep], gamma[keep], sigma[keep]
    amp = float(np.sqrt(2.0 * np.mean(gamma ** 2)))
    x = np.column_stack([gamma, amp * np.cos(omega * t), np.ones_like(t), t - t.mean()])
    coef, *_ = np.linalg.lstsq(x, sigma, rcond=None)
    return {"storage_modulus": float(coef[0]), "loss_modulus": float(coef[1]), "amplitude": amp,
            "cycles": n_cycles - discard_cycles}


def _fields(network, elastic, mode, strain):
    bdata = {
        "rest_length": np.asarray(network.rest_length),
        "length": np.asarray(network.length),
        "normal_stiffness": np.asarray(network.normal_stiffness),
        "shear_stiffness": np.asarray(network.shear_stiffness),
        "normal_strength": np.asarray(network.normal_strength),
        "shear_strength": np.asarray(network.shear_strength),
    }
    pdata = {
        "bonds": np.asarray(network.bonds_per_particle, dtype=np.int64),
        "rattler": np.asarray(network.rattlers, dtype=bool),
    }
    if elastic is not None:
        k = _mode(mode)
        f = bond_forces(network, elastic, mode, strain)
        nrm = np.asarray(network.normal)
        fn = np.einsum("ij,ij->i", f, nrm)
        bdata["force"] = f
        bdata["normal_force"] = -fn  # > 0 in compression, as BondNetwork.normal_force
        bdata["shear_force"] = np.linalg.norm(f - fn[:, None] * nrm, axis=1)
        pdata["nonaffine_displacement"] = float(strain) * np.asarray(elastic.nonaffine_displacements)[k]
        if elastic.nonaffine_rotations is not None:
            pdata["nonaffine_rotation"] = float(strain) * np.asarray(elastic.nonaffine_rotations)[k]
    return bdata, pdata


def write_network(path, network, elastic=None, *, mode="13", strain: float = 1.0, density=1.0,
                  damping=(0.0, 0.0), format: str | None = None):
    """Write a bonded network for OVITO, ParaView or LAMMPS (atomically).

    Parameters
    ----------
    path : str or os.PathLike
        ``.gsd`` (OVITO, HOOMD, freud), ``.vtm`` (ParaView and OVITO: writes
        ``<stem>_particles.vtp`` and ``<stem>_bonds.vtp`` next to it) or ``.data``/``.lmp``
        (LAMMPS BPM package, 3D).
    network : BondNetwork
    elastic : ElasticTensor, optional
        With it, the per-bond fields ``force`` (vector on ``i`` from ``j``),
        ``normal_force`` (> 0 compression) and ``shear_force`` (magnitude) and the
        per-particle fields ``nonaffine_displacement`` (and ``nonaffine_rotation``) of
        the relaxed response to ``strain`` in ``mode`` (see :func:`bond_forces`).
        Always written: ``rest_length``, ``length``, stiffnesses, strengths per bond;
        ``bonds`` (count) and ``rattler`` per particle (GSD and VTK only).
    mode : {"11", "22", "33", "23", "13", "12"}, default "13"
    strain : float, default 1
        Strain of the response fields (per unit strain by default).
    density : float or (N,) array, default 1
        LAMMPS density column (mass = density times the sphere volume).
    damping : (gn, gs), default (0, 0)
        LAMMPS bond damping coefficients (see the module notes).
    format : {"gsd", "vtm", "lammps"}, optional

    Returns
    -------
    list of Path

    Raises
    ------
    InvalidInputError
        Not a BondNetwork; a format without bonds (``.xyz``, ``.csv``, ``.vtp``: use
        ``.vtm``); a 2D network to LAMMPS; an ``elastic`` of another network.
    """
    from ..io import bonds as iob
    from .network import BondNetwork

    if not isinstance(network, BondNetwork):
        raise InvalidInputError(f"network must be a BondNetwork, got {type(network).__name__}")
    fmt = iob.bond_format_for(path, format)
    pk = network.packing
    meta = {"reference": network.reference, "epsilon": network.epsilon, "n_bonds": network.n_bonds,
            "coordination": network.coordination}
    if fmt == "lammps":
        if pk.dim != 3:
            raise InvalidInputError(
                f"LAMMPS data files hold 3D packings only; this network is {pk.dim}D (use .gsd or .vtm)")
        types, coeffs, _ = lammps_bond_coeffs(network, damping)
        notes = ["LAMMPS input (BPM package) reproducing polypack's contact bonds (polypack.mechanics.export):"]
        notes += ["  " + line for line in lammps_snippet(network, Path(path).name, damping)]
        if network.reference != "stress-free":
            notes.append(f"  NOTE: reference={network.reference!r}; LAMMPS bonds start stress-free at the first run")
        return iob.write_network(path, pk, network.i, network.j, network.shift, bond_types=types,
                                 network_meta=meta, format=fmt,
                                 lammps={"bond_types": len(coeffs), "density": density, "comments": notes})
    bdata, pdata = _fields(network, elastic, mode, strain)
    if elastic is not None:
        meta.update(mode=str(mode), strain=float(strain), units=str(elastic.units),
                    fields="force on i from j at the given strain (relaxed linear response); "
                           "nonaffine_displacement beyond the affine one, NaN for rattlers")
    return iob.write_network(path, pk, network.i, network.j, network.shift, bond_data=bdata, particle_data=pdata,
                             network_meta=meta, format=fmt)


def read_network(path, format: str | None = None):
    """A :class:`BondNetwork` from a file written by :func:`write_network`.

    Bonds (ends and periodic images) and the packing are exact; per-bond stiffnesses
    and strengths come from the file's fields (GSD, VTK) or the ``Bond Coeffs`` of a
    LAMMPS file; the reference follows the stored network record.
    """
    from ..io import bonds as iob
    from .network import BondNetwork

    pk, b = iob.read_network(path, format)
    if b["i"].size == 0:
        raise InvalidInputError(f"{path}: the file has no bonds")
    meta = b["network_meta"]
    data = b["bond_data"]
    kw = {}
    for name in ("normal_stiffness", "shear_stiffness", "normal_strength", "shear_strength"):
        if name in data:
            kw[name] = np.asarray(data[name], dtype=np.float64).reshape(-1)
    if b["info"].get("format") == "lammps":
        kw.update(_lammps_coeffs(path, b["bond_types"]))
    return BondNetwork.from_pairs(pk, b["i"], b["j"], b["shift"], reference=meta.get("reference", "stress-free"),
                                  **kw)


def _lammps_coeffs(path, types):
    """Stiffnesses and strengths per bond from the commented ``bond_coeff`` lines of a data file."""
    from ..io._common import read_text

    rows, breakable = {}, True
    for line in read_text(path).split("\n"):
        tok = line.lstrip("# ").split("#", 1)[0].split()
        if not line.startswith("#") or not tok:
            continue
        if tok[0] == "bond_coeff" and len(tok) == 14:
            rows[int(tok[1])] = [float(t) for t in tok[2:]]
        elif tok[0] == "bond_style":
            breakable = "no" not in tok[tok.index("break") + 1 :][:1] if "break" in tok else True
    if not rows or any(int(t) not in rows for t in np.unique(types)):
        return {}
    table = np.array([rows[int(t)] for t in types])
    out = {"normal_stiffness": table[:, 0], "shear_stiffness": table[:, 1]}
    if breakable:
        out["normal_strength"] = np.where(table[:, 4] >= 1e300, np.inf, table[:, 4])
        out["shear_strength"] = np.where(table[:, 5] >= 1e300, np.inf, table[:, 5])
    else:
        out["normal_strength"] = out["shear_strength"] = np.full(len(types), np.inf)
    return out
