"""The bonded network of a pack or network file for the mechanics commands (``elastic``, ``shear``).

One meaning for the shared options (issue 31):

``--radius R``
    lengths are rescaled so that the mean radius is ``R`` metres (default 0.25 µm, seed 003
    Table 1; stresses in Pa for stiffnesses in N/m); ``0`` keeps the file's length unit. A
    negative or non-finite value is refused. The first output line states the scale used.
``--bonds``
    ``auto`` (default): the bonds stored in the file (a network file written by
    ``write_network`` / ``convert``) or made by its protocol (Brownian dynamics), else every
    pair closer than ``(1 + epsilon)(r_i + r_j)``; ``protocol`` (``file`` in
    ``export-network`` and the old spelling in ``elastic``/``shear``): only stored/protocol
    bonds (an error if there are none); ``distance``: always the epsilon rule. The line says which.

``elastic`` and ``shear`` take these flags from the ``bonds``, ``epsilon``, ``radius`` ... fields
of their stages' options (:mod:`polypack.mechanics._capabilities`); :data:`NETWORK_ALIASES`
keeps their old spellings ``--kn``/``--ks`` as hidden flags.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidInputError

BOND_CHOICES = ("auto", "file", "protocol", "distance")

#: Hidden old spellings of the stiffness flags of ``elastic`` and ``shear`` (before issue 30).
NETWORK_ALIASES = {"--kn": "normal_stiffness", "--ks": "shear_stiffness"}
#: What the bond options mean for a file on the command line (added to their help).
NETWORK_NOTES = {"bonds": "For a file: the pack's own bonds are also those stored in a network file "
                          "(write_network, export-network); 'file' is the old spelling of 'protocol'."}
#: ``bonds`` field value -> :func:`network_from_file` rule.
FILE_BONDS = {"auto": "auto", "protocol": "protocol", "distance": "distance"}


def cli_bonds(own, flags):
    """``prepare`` hook of ``elastic``/``shear``: the old ``--bonds file`` is ``protocol``."""
    if flags.get("bonds") == "file":
        flags = {**flags, "bonds": "protocol"}
    return flags


def check_radius(radius):
    """``radius`` (m) or None for 0; one-line error for a negative or non-finite value."""
    r = float(radius)
    if not math.isfinite(r) or r < 0:
        raise InvalidInputError(f"--radius {radius!r}: must be a finite length >= 0 in metres "
                                "(0 keeps the file's length unit)")
    return r if r > 0 else None


def network_from_file(path, *, bonds="auto", epsilon=0.01, radius=0.25e-6, fmt=None, rescale=True, **kw):
    """``(packing, network, bonds_note, units_note)`` of a pack or network file.

    ``kw`` go to :class:`~polypack.mechanics.BondNetwork` (stiffnesses, strengths,
    reference). The packing is rescaled (:func:`check_radius`) unless ``rescale=False``
    (the caller rescales, e.g. ``elastic_tensor(radius=...)``; the note says so either way).
    """
    from ..io.bonds import read_maybe_network
    from ..mechanics import BondNetwork
    from ..mechanics.stages import _scaled

    if bonds not in BOND_CHOICES:
        raise InvalidInputError(f"--bonds {bonds!r}: allowed are {', '.join(BOND_CHOICES)}")
    radius = check_radius(radius)
    pk0, _, stored = read_maybe_network(path, fmt)
    pk, s = _scaled(pk0, radius) if rescale else (pk0, float(radius) / float(np.mean(pk0.radii)) if radius else 1.0)
    mean_r = float(np.mean(pk0.radii))
    if radius is None:
        units = (f"lengths in the file's unit (mean radius {mean_r:.4g}); stresses in stiffness units per length "
                 "unit (Pa for N/m and metres)")
    else:
        units = (f"lengths rescaled x{s:.6g} to a mean radius of {radius:.4g} m (file: {mean_r:.4g}; --radius 0 "
                 "keeps the file's unit); stresses in Pa")
    if bonds != "distance" and stored is not None and len(stored["i"]):
        net = BondNetwork.from_pairs(pk, stored["i"], stored["j"], stored["shift"], **kw)
        return pk, net, f"{net.n_bonds} bonds stored in {path} (--bonds distance rebuilds them by epsilon)", units
    if bonds != "distance" and isinstance(pk.meta.get("bonds"), dict):
        from ..generate.brownian import brownian_bonds

        i, j, shift = brownian_bonds(pk)
        net = BondNetwork.from_pairs(pk, i, j, shift, **kw)
        return pk, net, f"{net.n_bonds} bonds made by the protocol (--bonds distance rebuilds them by epsilon)", units
    if bonds in ("file", "protocol"):
        raise InvalidInputError(f"--bonds {bonds}: {path} stores no bonds and its protocol made none; "
                                "use --bonds auto or distance")
    net = BondNetwork.from_packing(pk, epsilon=epsilon, **kw)
    return pk, net, f"{net.n_bonds} bonds by the epsilon rule (pairs closer than (1 + {epsilon:g})(r_i + r_j))", units
