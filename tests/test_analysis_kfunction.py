"""K function: Poisson K = 4 pi r^3 / 3, lattice neighbour counts, consistency with RDF."""

import numpy as np
import pytest

import polypack as pp
from _analysis_packs import lattice, poisson, rsa
from polypack.errors import InvalidInputError


def test_poisson_K_total_and_partials():
    rng = np.random.default_rng(21)
    pk = poisson(rng, 20000, 20.0, n_species=3)
    k = pp.analysis.KFunction(r_max=4.0, dr=0.5).compute(pk)
    assert np.allclose(k.r, np.arange(1, 9) * 0.5)
    expect = 4 / 3 * np.pi * k.r**3
    n, V = pk.n, pk.box_volume
    # relative Poisson error of the number of unordered pairs within r
    rel = 1 / np.sqrt(0.5 * n * (n - 1) / V * expect)
    assert np.all(np.abs(k.K / expect - 1) < 5 * rel)
    assert np.allclose(k.L, k.r, rtol=5 * rel.max())
    cnt = pk.species_counts
    for a in range(3):
        for b in range(3):
            npairs = cnt[a] * (cnt[b] - (a == b)) / V * expect / (2 if a == b else 1)
            assert np.all(np.abs(k.partial[(a, b)] / expect - 1) < 5 / np.sqrt(npairs)), (a, b)


@pytest.mark.parametrize(
    "kind, radii_counts",
    [
        ("sc", [(1.1, 6), (1.5, 18), (1.8, 26), (2.1, 32)]),
        ("bcc", [(0.9, 8), (1.1, 14), (1.5, 26), (1.7, 50), (1.8, 58)]),
        ("fcc", [(0.8, 12), (1.1, 18), (1.3, 42), (1.5, 54)]),
    ],
)
def test_lattice_neighbour_numbers(kind, radii_counts):
    pk = lattice(kind, 5)
    k = pp.analysis.KFunction(r_max=2.2, dr=0.1).compute(pk)
    neigh = (pk.n - 1) * k.K / pk.box_volume
    for r, count in radii_counts:
        i = int(np.argmin(np.abs(k.r - r)))
        assert neigh[i] == pytest.approx(count, abs=1e-9), (kind, r)
    ks = pp.analysis.KFunction(r_max=2.2, dr=0.1, normalization="seed").compute(pk)
    assert np.allclose(ks.K, k.K * (pk.n - 1) / pk.n)


def test_right_difference_of_K_is_the_rdf():
    pk = rsa(np.random.default_rng(4), 800, 12.0, radii_choices=(0.5, 0.25), weights=(0.3, 0.7))
    k = pp.analysis.KFunction(r_max=4.0, dr=0.05).compute(pk)
    g = pp.analysis.RDF(r_max=4.0, dr=0.05, method="right").compute(pk)
    # Eq. (14_2): g+(r) = (K(r + dr) - K(r)) / (4 pi r^2 dr) at r = dr, 2 dr, ...
    gp = np.diff(k.K) / (4 * np.pi * k.r[:-1] ** 2 * 0.05)
    assert np.allclose(g.r, k.r[:-1])
    assert np.allclose(g.g, gp, rtol=1e-12)
    for key in [(0, 0), (0, 1), (1, 1)]:
        gp = np.diff(k.partial[key]) / (4 * np.pi * k.r[:-1] ** 2 * 0.05)
        assert np.allclose(g.partial[key], gp, rtol=1e-12)


def test_accumulate_plot_dict_and_errors():
    import json

    rng = np.random.default_rng(1)
    k = pp.analysis.KFunction(r_max=3.0, dr=0.5)
    for _ in range(3):
        k.compute(poisson(rng, 2000, 10.0, n_species=2), reset=False)
    assert k.n_realizations == 3 and np.all(k.K_err > 0)
    ax = k.plot()  # L(r) - r, zero for Poisson
    np.testing.assert_allclose(ax.lines[0].get_ydata(), np.cbrt(3 * k.K / (4 * np.pi)) - k.r, rtol=1e-12)
    assert ax.get_ylabel() == "L(r) - r" and ax.get_xlabel() == "r"
    ax = k.plot(centred=False)
    np.testing.assert_allclose(ax.lines[0].get_ydata(), k.K, rtol=1e-12)
    assert any(np.allclose(ln.get_ydata(), 4 / 3 * np.pi * k.r**3) for ln in ax.lines)  # Poisson beside it
    assert {t.get_text() for t in ax.get_legend().get_texts()} >= {"total", "Poisson"}
    d = json.loads(json.dumps(k.to_dict()))
    assert set(d["partial"]) == {"0-0", "0-1", "1-1"}
    with pytest.raises(InvalidInputError, match="half the smallest box"):
        pp.analysis.KFunction(r_max=5.5, dr=0.5).compute(poisson(rng, 50, 10.0))
    with pytest.raises(InvalidInputError, match="unknown species pair"):
        k.partial[(2, 0)]
    with pytest.raises(InvalidInputError, match="dr="):
        pp.analysis.KFunction(r_max=3.0, dr=-1)


def test_contact_scaled_K_of_boolean_model():
    # Poisson centres with two radii: in x = d/(r_i + r_j) every pair has K(x) = 4 pi x^3 / 3
    rng = np.random.default_rng(9)
    n, L = 20000, 20.0
    rad = np.where(rng.random(n) < 0.3, 0.4, 0.1)
    pk = pp.Packing(rng.random((n, 3)) * L, rad, L, species=(rad < 0.2).astype(int))
    k = pp.analysis.KFunction(r_max=4.0, dr=0.5, scale="contact").compute(pk)
    expect = 4 / 3 * np.pi * k.r**3
    cnt = pk.species_counts
    s = {(0, 0): 0.8, (0, 1): 0.5, (1, 0): 0.5, (1, 1): 0.2}
    for key, sij in s.items():
        a, b = key
        npairs = cnt[a] * (cnt[b] - (a == b)) * expect * sij**3 / L**3 / (2 if a == b else 1)
        assert np.all(np.abs(k.partial[key] / expect - 1) < 5 / np.sqrt(npairs)), key
