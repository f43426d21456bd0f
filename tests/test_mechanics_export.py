"""Bonded networks out (polypack.mechanics.export): bond forces against the tensor, files back to networks."""

import numpy as np
import pytest

import polypack as pp
from polypack.errors import InvalidInputError
from polypack.mechanics import BondNetwork, elastic_tensor, read_network, static_shear_modulus, write_network
from polypack.mechanics.export import MODES, bond_forces, lammps_bond_coeffs, lammps_snippet

VOIGT = {0: (0, 0), 1: (1, 1), 2: (2, 2), 3: (1, 2), 4: (0, 2), 5: (0, 1)}


@pytest.fixture(scope="module")
def bimodal_net():
    """A bimodal pack whose network has rattlers with one bond (they must relax completely)."""
    sizes = pp.psd.Bimodal(size_ratio=0.6, volume_ratio=0.5, d_large=1.0).sample(n=200, seed=1)
    pk = pp.pack(sizes, volume_fraction="jammed", seed=1)
    net = BondNetwork.from_packing(pk, epsilon=0.02)
    assert np.any(net.bonds_per_particle[net.rattlers] > 0)  # the case this file is about
    return net


def voigt_stress(net, f):
    s = np.einsum("mi,mj->ij", f, net.branch * 1.0) / net.packing.box_volume
    s = 0.5 * (s + s.T)
    return np.array([s[p, q] for p, q in VOIGT.values()])


@pytest.mark.parametrize("rotations", [True, False])
def test_bond_forces_sum_to_the_stress_of_the_tensor(bimodal_net, rotations):
    """sigma = (1/V) sum_c f_c b_c^T must equal C eps column by column. The forces come from
    the non-affine fields, the tensor from the Schur complement: an independent pairing. 1e-9
    of the largest entry is far above the direct solver's 1e-12 residual and far below any
    sign or lever-arm error (which change C at the percent level)."""
    et = elastic_tensor(bimodal_net, rotations=rotations)
    scale = np.abs(et.stiffness).max()
    for mode, col in MODES.items():
        f = bond_forces(bimodal_net, et, mode)
        np.testing.assert_allclose(voigt_stress(bimodal_net, f), et.stiffness[:, col], atol=1e-9 * scale)
    # linear in the strain; zero on bonds of particles that relax completely
    f = bond_forces(bimodal_net, et, "13", strain=1e-3)
    np.testing.assert_allclose(f, 1e-3 * bond_forces(bimodal_net, et, "13"), rtol=1e-15)
    dangling = bimodal_net.rattlers[bimodal_net.i] | bimodal_net.rattlers[bimodal_net.j]
    assert dangling.any() and np.all(f[dangling] == 0)


def test_rattler_bonds_carry_no_stress_in_the_tensor(bimodal_net):
    """Regression: elastic_tensor used to add the affine stiffness of rattler bonds to the
    relaxed tensor. The DEM module's own static solver relaxes every particle: they agree
    (1e-7, its regularised solve) and the rattler bonds' affine share is far larger."""
    et = elastic_tensor(bimodal_net)
    other = [static_shear_modulus(bimodal_net, 2, 1), static_shear_modulus(bimodal_net, 2, 0),
             static_shear_modulus(bimodal_net, 1, 0)]
    np.testing.assert_allclose(et.shear_moduli, other, rtol=1e-7)
    dangling = bimodal_net.rattlers[bimodal_net.i] | bimodal_net.rattlers[bimodal_net.j]
    b, n, kn, ks = (np.asarray(a)[dangling] for a in (bimodal_net.branch, bimodal_net.normal,
                                                        bimodal_net.normal_stiffness, bimodal_net.shear_stiffness))
    d = np.zeros_like(b)
    d[:, 0] = 0.5 * b[:, 2]
    d[:, 2] = 0.5 * b[:, 0]  # eps b for gamma_13 = 1
    dn = np.einsum("ij,ij->i", d, n)[:, None]
    share = np.einsum("ij,ij->", kn[:, None] * dn * n + ks[:, None] * (d - dn * n), d) / bimodal_net.packing.box_volume
    assert share > 1e-4 * et.stiffness[4, 4]


def test_bond_forces_reject_another_network(bimodal_net):
    et = elastic_tensor(bimodal_net)
    other = BondNetwork.from_packing(bimodal_net.packing, epsilon=0.05)
    with pytest.raises(InvalidInputError, match="does not belong"):
        bond_forces(other, et)
    with pytest.raises(InvalidInputError, match="mode"):
        bond_forces(bimodal_net, et, "31")


@pytest.mark.parametrize("ext", [".gsd", ".vtm", ".data"])
def test_write_read_network_round_trip(tmp_path, bimodal_net, ext):
    net = bimodal_net
    et = elastic_tensor(net)
    files = write_network(tmp_path / f"n{ext}", net, et)
    back = read_network(files[0])
    assert back.packing == net.packing
    for name in ("i", "j", "shift", "normal_stiffness", "shear_stiffness", "normal_strength", "shear_strength",
                 "rest_length"):
        assert np.array_equal(getattr(back, name), getattr(net, name)), name
    assert back.reference == net.reference


def test_fields_in_gsd_are_the_response(tmp_path, bimodal_net):
    import gsd.hoomd

    net = bimodal_net
    et = elastic_tensor(net)
    write_network(tmp_path / "n.gsd", net, et, mode="23", strain=1e-3)
    with gsd.hoomd.open(str(tmp_path / "n.gsd")) as t:
        log = t[0].log
    f = bond_forces(net, et, "23", 1e-3)
    assert np.array_equal(log["bonds/force"], f)
    assert np.array_equal(log["bonds/normal_force"], -np.einsum("ij,ij->i", f, net.normal))
    u = np.asarray(log["particles/nonaffine_displacement"])
    assert np.array_equal(u, 1e-3 * et.nonaffine_displacements[3], equal_nan=True)
    assert np.all(np.isnan(u[net.rattlers]))
    assert np.array_equal(log["particles/bonds"], net.bonds_per_particle)


def test_zero_gap_and_unbreakable_networks(tmp_path, bimodal_net):
    pk = bimodal_net.packing
    net = BondNetwork.from_packing(pk, epsilon=0.02, reference="zero-gap", normal_strength=np.inf,
                                   shear_strength=np.inf)
    for ext in (".gsd", ".data"):
        write_network(tmp_path / f"z{ext}", net)
        back = read_network(tmp_path / f"z{ext}")
        assert back.reference == "zero-gap" and np.array_equal(back.rest_length, net.rest_length)
        assert np.all(np.isinf(back.normal_strength)) and np.all(np.isinf(back.shear_strength))
    text = (tmp_path / "z.data").read_text()
    assert "break no" in text and "start stress-free" in text


def test_lammps_coefficients_per_species_pair(bimodal_net):
    pk = bimodal_net.packing
    kn = np.array([[100.0, 150.0], [150.0, 200.0]])
    net = BondNetwork.from_packing(pk, epsilon=0.02, normal_stiffness=kn, shear_stiffness=kn / 10,
                                   normal_strength=1e-4, shear_strength=np.inf)
    types, coeffs, breakable = lammps_bond_coeffs(net, damping=(0.5, 0.25))
    assert breakable and coeffs.shape == (len(np.unique(net.normal_stiffness)), 12)
    np.testing.assert_array_equal(coeffs[types - 1, 0], net.normal_stiffness)  # Kr = kn
    np.testing.assert_array_equal(coeffs[types - 1, 1], net.shear_stiffness)  # Ks = ks
    assert np.all(coeffs[:, 2:4] == 0) and np.all(coeffs[:, 6:8] > 0)  # no moments; critical torques > 0
    assert np.all(coeffs[:, 4] == 1e-4) and np.all(coeffs[:, 5] == 1e300)
    assert np.all(coeffs[:, 8] == 0.5) and np.all(coeffs[:, 9] == 0.25) and np.all(coeffs[:, 10:] == 0)
    lines = lammps_snippet(net, "n.data")
    assert sum(line.startswith("bond_coeff") for line in lines) == coeffs.shape[0]
    order = [line.split()[0] for line in lines]
    assert order.index("read_data") < order.index("bond_style") < order.index("bond_coeff")  # BPM needs the box
    assert "bpm/rotational smooth no" in " ".join(lines)


def test_bad_input(tmp_path, bimodal_net):
    with pytest.raises(InvalidInputError, match="BondNetwork"):
        write_network(tmp_path / "n.gsd", bimodal_net.packing)
    with pytest.raises(InvalidInputError, match=r"\.vtm"):
        write_network(tmp_path / "n.vtp", bimodal_net)
    with pytest.raises(InvalidInputError, match="damping"):
        write_network(tmp_path / "n.data", bimodal_net, damping=(-1.0, 0.0))
    assert not list(tmp_path.iterdir())
