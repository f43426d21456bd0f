"""Dimension-aware core: 2D packings, per-axis periodicity (walls), geometry measures, io."""

import itertools

import numpy as np
import pytest

import polypack as pp
from polypack import geometry
from polypack.neighbors import min_relative_gap, pairs_within


# ---------------------------------------------------------------- geometry
def test_ball_volume_and_shell_measure_analytic():
    r = np.array([0.5, 1.0, 2.0])
    assert np.allclose(geometry.ball_volume(r, 3), 4.0 / 3.0 * np.pi * r**3, rtol=0, atol=0)
    assert np.array_equal(geometry.ball_volume(r, 2), np.pi * r**2)
    assert np.array_equal(geometry.shell_measure(r, 3), 4.0 * np.pi * r**2)
    assert np.array_equal(geometry.shell_measure(r, 2), 2.0 * np.pi * r)
    # the shell measure is the derivative of the ball volume (central difference, O(h^2) error)
    h = 1e-5
    for d in (2, 3):
        deriv = (geometry.ball_volume(r + h, d) - geometry.ball_volume(r - h, d)) / (2 * h)
        assert np.allclose(deriv, geometry.shell_measure(r, d), rtol=1e-8)
        assert np.allclose(geometry.shell_volume(r, r + 0.1, d),
                           geometry.ball_volume(r + 0.1, d) - geometry.ball_volume(r, d), rtol=1e-14)
        assert np.allclose(geometry.radius_of_volume(geometry.ball_volume(r, d), d), r, rtol=1e-14)
    with pytest.raises(pp.InvalidInputError, match="dim=4"):
        geometry.ball_volume(1.0, 4)


def test_minimum_image_only_on_periodic_axes():
    box = np.array([10.0, 10.0])
    d = np.array([[7.0, -6.0], [-4.0, 9.0]])
    assert np.array_equal(geometry.minimum_image(d, box), [[-3.0, 4.0], [-4.0, -1.0]])
    assert np.array_equal(geometry.minimum_image(d, box, (True, False)), [[-3.0, -6.0], [-4.0, 9.0]])
    assert np.array_equal(geometry.minimum_image(d, box, False), d)
    with pytest.raises(pp.InvalidInputError, match="periodic"):
        geometry.minimum_image(d, box, (True,))


# ---------------------------------------------------------------- Packing
def _random_disks(n, box, r, rng):
    return rng.random((n, len(box))) * box, np.full(n, r) * (0.5 + rng.random(n))


def test_packing_2d_basics():
    pos = np.array([[1.0, 1.0], [3.0, 1.0], [11.5, -0.5]])
    pk = pp.Packing(pos, [0.5, 0.5, 1.0], [10.0, 8.0], species=[0, 0, 1])
    assert pk.dim == 2 and pk.box.shape == (2,) and pk.periodic == (True, True)
    assert np.array_equal(pk.positions[2], [1.5, 7.5])  # wrapped on both periodic axes
    area = np.pi * (0.25 + 0.25 + 1.0)
    assert pk.volume_fraction == pytest.approx(area / 80.0, rel=1e-15)
    assert np.allclose(pk.species_fractions, [np.pi * 0.5 / 80.0, np.pi / 80.0], rtol=1e-15)
    assert pk.box_volume == 80.0
    # nearest pair: sphere 2 seen from sphere 0 through the periodic y boundary,
    # separation (0.5, -1.5), contact distance 1.5
    assert pk.min_gap() == pytest.approx(np.sqrt(2.5) / 1.5 - 1.0, rel=1e-14)
    assert pk.closest_pair()[1] == (0, 2)
    assert "dim=2" in repr(pk)
    assert pp.Packing(np.zeros((0, 2)), [], [3.0, 3.0]).dim == 2
    with pytest.raises(pp.InvalidInputError, match="2 lengths"):
        pp.Packing(pos, [0.5, 0.5, 1.0], [10.0, 8.0, 8.0])


def test_walls_are_not_wrapped_and_bound_the_spheres():
    pos = np.array([[0.5, 0.5], [9.0, 4.0]])
    pk = pp.Packing(pos, [0.5, 1.0], [10.0, 10.0], periodic=(True, False))
    assert pk.periodic == (True, False) and not pk.fully_periodic
    assert pk.wall_gap() == pytest.approx(0.0, abs=1e-15)  # sphere 0 rests on the floor
    # across the periodic x axis the two are 1.5 apart in x, 3.5 in y (no image in y)
    assert pk.min_gap() == pytest.approx(np.hypot(1.5, 3.5) / 1.5 - 1.0, rel=1e-14)
    with pytest.raises(pp.InvalidInputError, match="crosses a wall of axis y"):
        pp.Packing([[5.0, 0.4]], [0.5], [10.0, 10.0], periodic=(True, False))
    with pytest.raises(pp.InvalidInputError, match="crosses a wall of axis x"):
        pp.Packing([[9.8, 5.0, 5.0]], [0.5], 10.0, periodic=False)
    # a big sphere is fine along wall axes (no minimum-image limit there)
    pp.Packing([[5.0, 5.0]], [3.0], [10.0, 10.0], periodic=False)
    with pytest.raises(pp.InvalidInputError, match="periodic"):
        pp.Packing(pos, [0.5, 1.0], [10.0, 10.0], periodic=(True, False, True))
    # replace and equality keep the flags
    assert pk.replace(meta={"a": 1}).periodic == (True, False)
    assert pk != pp.Packing(pos, [0.5, 1.0], [10.0, 10.0])


def _brute_pairs(pos, rad, box, periodic, a, b):
    out = set()
    flags = np.array(periodic)
    for i, j in itertools.combinations(range(len(rad)), 2):
        d = pos[j] - pos[i]
        d = np.where(flags, d - box * np.round(d / box), d)
        if np.sqrt(d @ d) <= a * (rad[i] + rad[j]) + b:
            out.add((i, j))
    return out


@pytest.mark.parametrize(
    "box, periodic",
    [
        ([12.0, 9.0], (True, True)),
        ([12.0, 9.0], (True, False)),
        ([12.0, 9.0], (False, False)),
        ([8.0, 9.0, 7.0], (True, True, False)),
        ([8.0, 9.0, 7.0], (False, True, False)),
    ],
)
def test_pairs_and_min_gap_match_a_brute_force_oracle(box, periodic):
    rng = np.random.default_rng(len(box) * 10 + sum(periodic))
    box = np.array(box)
    for trial in range(5):
        n = 60
        pos, rad = _random_disks(n, box, 0.4, rng)
        # keep spheres inside the walls
        for ax in range(len(box)):
            if not periodic[ax]:
                pos[:, ax] = np.clip(pos[:, ax], rad, box[ax] - rad)
        for a, b in ((1.0, 0.0), (1.2, 0.1), (0.0, 1.5)):
            i, j, d = pairs_within(pos, rad, box, a, b, periodic=periodic)
            got = {(min(p, q), max(p, q)) for p, q in zip(i.tolist(), j.tolist())}
            assert got == _brute_pairs(pos, rad, box, periodic, a, b)
            ib, jb, _ = pairs_within(pos, rad, box, a, b, method="brute", periodic=periodic)
            assert {(min(p, q), max(p, q)) for p, q in zip(ib.tolist(), jb.tolist())} == got
        pk = pp.Packing(pos, rad, box, periodic=periodic)
        best = min(
            np.linalg.norm(np.where(np.array(periodic), dv - box * np.round(dv / box), dv)) / (rad[p] + rad[q]) - 1
            for p, q in itertools.combinations(range(n), 2)
            for dv in [pos[q] - pos[p]]
        )
        assert pk.min_gap() == pytest.approx(best, rel=1e-12, abs=1e-14)


def test_min_gap_walls_ignore_far_images():
    # two disks at opposite walls: periodic they would touch through the boundary, with walls they do not
    pos = np.array([[0.5, 5.0], [9.5, 5.0]])
    per = pp.Packing(pos, [0.5, 0.5], [10.0, 10.0])
    wall = pp.Packing(pos, [0.5, 0.5], [10.0, 10.0], periodic=False)
    assert per.min_gap() == pytest.approx(0.0, abs=1e-12)
    assert wall.min_gap() == pytest.approx(8.0, rel=1e-12)
    assert per.min_gap() == min_relative_gap(pos, [0.5, 0.5], [10.0, 10.0])[0]


# ---------------------------------------------------------------- analyses and generators
def _hex_disks():
    """Triangular lattice of touching unit-diameter disks, 8 x 8 (periodic box fits it exactly)."""
    nx, ny = 8, 8
    a = 1.0
    pts = [((i + 0.5 * (j % 2)) * a, j * a * np.sqrt(3) / 2) for j in range(ny) for i in range(nx)]
    return pp.Packing(np.array(pts), np.full(nx * ny, 0.5), [nx * a, ny * a * np.sqrt(3) / 2])


def test_contacts_support_2d_and_walls():
    pk = _hex_disks()
    c = pp.analysis.Contacts(tolerance=1e-9).compute(pk)
    assert c.coordination == pytest.approx(6.0, abs=1e-12)  # triangular lattice: 6 neighbours
    # the same disks on a square grid in a walled box: 4 neighbours inside, fewer at the walls
    g = np.array([(i + 0.5, j + 0.5) for i in range(5) for j in range(5)])
    sq = pp.Packing(g, np.full(25, 0.5), [5.0, 5.0], periodic=False)
    c = pp.analysis.Contacts(tolerance=1e-9).compute(sq)
    assert c.coordination == pytest.approx(2 * 40 / 25, abs=1e-12)  # 2 * 5 * 4 bonds per axis


@pytest.mark.parametrize(
    "make, two_d",
    [
        (lambda: pp.analysis.RDF(r_max=2.0, dr=0.1), True),
        (lambda: pp.analysis.KFunction(r_max=2.0, dr=0.1), True),
        (lambda: pp.analysis.WindowCounts(window_radius=2.5), True),
        (lambda: pp.analysis.PoreSizes(n_points=100, seed=1), False),
    ],
)
def test_periodic_only_analyses_reject_walls_and_3d_only_reject_2d(make, two_d):
    if two_d:  # 2D support: tests/test_analysis_2d.py
        assert make().compute(_hex_disks()).n_realizations == 1
    else:
        with pytest.raises(pp.InvalidInputError, match="3D packings only; got a 2D"):
            make().compute(_hex_disks())
    walls = pp.Packing(np.array([[2.0, 2.0, 2.0], [5.0, 5.0, 5.0]]), [0.5, 0.5], 10.0, periodic=(True, True, False))
    with pytest.raises(pp.InvalidInputError, match="periodic on every axis"):
        make().compute(walls)


def test_generators_reject_2d():
    with pytest.raises(pp.InvalidInputError, match="2D packing"):
        pp.shake(_hex_disks(), global_shakes=1, seed=1)
    # pp.pack grows 2D packs (tests/test_pack2d.py); a 2D size set cannot be forced into 3D
    sizes = pp.psd.SizeSet(np.full(20, 0.5), dim=2)
    with pytest.raises(pp.InvalidInputError, match="dim=3 but the size set is 2D"):
        pp.pack(sizes, volume_fraction=0.5, seed=1, dim=3)


# ---------------------------------------------------------------- io
@pytest.mark.parametrize("ext", [".gsd", ".xyz", ".csv"])
@pytest.mark.parametrize("periodic", [(True, True), (True, False), (False, False)])
def test_io_round_trip_2d(tmp_path, ext, periodic):
    rng = np.random.default_rng(3)
    box = np.array([9.0, 7.0])
    pos, rad = _random_disks(30, box, 0.3, rng)
    for ax in range(2):
        if not periodic[ax]:
            pos[:, ax] = np.clip(pos[:, ax], rad, box[ax] - rad)
    pk = pp.Packing(pos, rad, box, species=rng.integers(0, 3, 30), meta={"seed": 4}, periodic=periodic)
    path = tmp_path / f"disks{ext}"
    pp.io.write(path, pk)
    back = pp.io.read(path)
    assert back == pk and back.dim == 2 and back.periodic == periodic
    assert np.array_equal(back.positions, pk.positions)  # bitwise


@pytest.mark.parametrize("ext", [".gsd", ".xyz", ".csv"])
def test_io_round_trip_3d_walls(tmp_path, ext):
    rng = np.random.default_rng(5)
    box = np.array([6.0, 6.0, 9.0])
    pos, rad = _random_disks(20, box, 0.3, rng)
    pos[:, 2] = np.clip(pos[:, 2], rad, box[2] - rad)
    pk = pp.Packing(pos, rad, box, periodic=(True, True, False))
    pp.io.write(tmp_path / f"w{ext}", pk)
    assert pp.io.read(tmp_path / f"w{ext}") == pk


def test_gsd_2d_frame_is_a_hoomd_2d_frame(tmp_path):
    import gsd.hoomd

    pp.io.write(tmp_path / "d.gsd", _hex_disks())
    with gsd.hoomd.open(str(tmp_path / "d.gsd"), "r") as traj:
        f = traj[0]
        assert f.configuration.dimensions == 2
        assert f.configuration.box[2] == 0
        assert np.all(f.particles.position[:, 2] == 0)


def test_xyz_2d_pbc_flags(tmp_path):
    pk = pp.Packing([[1.0, 1.0]], [0.5], [4.0, 4.0], periodic=(True, False))
    pp.io.write(tmp_path / "d.xyz", pk)
    assert 'pbc="T F F"' in (tmp_path / "d.xyz").read_text()


def test_lammps_rejects_2d(tmp_path):
    with pytest.raises(pp.InvalidInputError, match="3D packings only"):
        pp.io.write(tmp_path / "d.data", _hex_disks())
