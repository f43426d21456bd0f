"""Physics validation of shaking: the Metropolis variant samples the equilibrium hard-sphere
fluid (Carnahan–Starling contact value), and the findings of §5.1 of 000_2cedc098acbd866b.txt
(shaking lowers the contact peak g(2a+) of CRM packs markedly at c = 0.575, less at 0.6,
little at 0.63; window counts p(n_h) narrow, Fig. 4).  Also SCRM end to end."""

import math

import numpy as np
import pytest

import polypack as pp
from polypack.analysis import RDF, contact_value
from polypack.generate.shake import scrm, shake


def simple_cubic(phi, n1):
    spacing = (4.0 / 3.0 * math.pi / phi) ** (1.0 / 3.0)
    g = (np.arange(n1) + 0.5) * spacing
    pos = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    return pp.Packing(pos, np.ones(len(pos)), spacing * n1)


def carnahan_starling_contact(eta):
    """g(sigma+) = (1 - eta/2) / (1 - eta)^3, from Z = 1 + 4 eta g(sigma+) with the CS equation of state."""
    return (1.0 - 0.5 * eta) / (1.0 - eta) ** 3


def extrapolate_to_contact(rdf, width=0.1, degree=2):
    """g(x -> 1+) from a pooled contact-scaled histogram RDF: weighted quadratic fit in x - 1
    over the bins in (1, 1 + width), evaluated at x = 1.  On the right of contact g is smooth
    in the fluid, so the extrapolation bias is O(width^3 g''') (well below 0.5 % here)."""
    r, g = rdf.r, rdf.g
    sel = (r > 1.0) & (r < 1.0 + width)
    return float(np.polyfit(r[sel] - 1.0, g[sel], degree)[-1])


@pytest.mark.slow
@pytest.mark.parametrize("phi", [0.30, 0.40])
def test_metropolis_samples_carnahan_starling(phi):
    """Equilibrium hard-sphere fluid from a simple cubic lattice: melt/equilibrate with an adaptive
    step, then sample with the step fixed (detailed balance) every 4 global shakes (N = 1000, 250 samples in 5 blocks); the pooled
    contact value matches Carnahan–Starling within 2 % (CS itself is within ~0.3 % of exact
    simulation data at these densities)."""
    pk = simple_cubic(phi, 10)  # N = 1000
    eq = shake(pk, global_shakes=120, method="metropolis", adaptive=True, adapt_shakes=60,
               target_acceptance=0.4, seed=10, monitor_every=0)
    step = eq.meta["shake"]["final_shake_radius"]
    blocks = [RDF(r_max=1.1, dr=0.005, scale="contact") for _ in range(5)]
    n_sweeps, every = 1000, 4

    def sample(m, p):
        if m % every == 0:
            blocks[(m - 1) * len(blocks) // n_sweeps].compute(p, reset=False)

    out = shake(eq, global_shakes=n_sweeps, method="metropolis", shake_radius=step, seed=11, monitor_every=0,
                callback=sample)
    assert out.meta["shake"]["final_shake_radius"] == step  # fixed while sampling
    vals = np.array([extrapolate_to_contact(b) for b in blocks])
    est = vals.mean()
    sem = vals.std(ddof=1) / math.sqrt(len(vals))
    cs = carnahan_starling_contact(phi)
    assert abs(est / cs - 1.0) < 0.02, (est, sem, cs)
    assert sem / cs < 0.01  # the sampling noise is small enough for the 2 % test to mean something


def first_bin_contact(pk):
    """The seed's g(2a+): the histogram g in [2a, 2a + 0.01a) (Delta r = 0.01a, §5.1)."""
    return contact_value(pk, width=0.005, n_bins=1, degree=0)[(0, 0)]


@pytest.mark.slow
def test_seed_findings_shaking_lowers_contact_peak():
    """§5.1 of 000_2cedc098acbd866b.txt: shaking (R_sh = 0.02, N_sh = 150, M = 60) lowers g(2a+) of
    CRM packs (N = 2000) by 43 %, 21 %, 4 % at c = 0.575, 0.6, 0.63.  Our CRM (Lubachevsky–Stillinger,
    default growth rate) gives about 25 %, 20 %, 5 %: a marked drop well away from jamming and very
    little close to it."""
    red = {}
    for c in (0.575, 0.6, 0.63):
        crm = pp.pack(np.ones(2000), volume_fraction=c, seed=3)
        assert crm.volume_fraction == pytest.approx(c, rel=0.01)  # target, or jammed just below it
        sh = shake(crm, global_shakes=60, shake_radius=0.02, max_trials=150, method="paper", seed=2,
                   monitor_every=0)
        assert sh.min_gap() >= 0.0
        g0, g1 = first_bin_contact(crm), first_bin_contact(sh)
        red[c] = 1.0 - g1 / g0
    assert red[0.575] > 0.15, red
    assert red[0.6] > 0.10, red
    assert red[0.63] < 0.10, red
    assert red[0.575] > red[0.63] + 0.10, red
    assert red[0.6] > red[0.63] + 0.05, red


@pytest.mark.slow
def test_seed_findings_window_counts_narrow():
    """Fig. 4 of 000_2cedc098acbd866b.txt (c = 0.6, R_h = 2.5): shaking removes windows with
    few and with many spheres, so p(n_h) narrows.  Visible for rapidly grown (locked) CRM packs
    (growth_rate=1; pooled over two realizations); a slowly grown LS pack is already about as
    homogeneous as shaking makes it."""
    from polypack.analysis import WindowCounts

    before, after = WindowCounts(window_radius=2.5), WindowCounts(window_radius=2.5)
    for seed in (4, 5):
        crm = pp.pack(np.ones(2000), volume_fraction=0.6, seed=seed, growth_rate=1.0)
        sh = shake(crm, global_shakes=200, seed=2, monitor_every=0)
        before.compute(crm, reset=False)
        after.compute(sh, reset=False)
    assert after.variance < 0.95 * before.variance, (before.variance, after.variance)


def test_scrm_end_to_end():
    radii = np.ones(300)
    pk = scrm(radii, volume_fraction=0.5, seed=1, growth_steps=3, start_fraction=0.4, stage_shakes=2,
              global_shakes=5, monitor_every=0)
    assert pk.volume_fraction == pytest.approx(0.5, rel=1e-9)
    assert pk.min_gap() >= 0.0
    rec = pk.meta["scrm"]
    assert rec["schedule"] == pytest.approx([0.4, 0.45, 0.5])
    assert [s["shakes"] for s in rec["stages"]] == [2, 2, 2]
    assert [s["reached"] for s in rec["stages"]] == pytest.approx([0.4, 0.45, 0.5], rel=1e-9)
    assert pk.meta["shake"]["global_shakes"] == 5
    gens = [h.get("generator") for h in pk.meta["history"]]
    assert gens.count("polypack.shake") == 4 and gens.count("polypack.pack") >= 3
    again = scrm(radii, volume_fraction=0.5, seed=1, growth_steps=3, start_fraction=0.4, stage_shakes=2,
                 global_shakes=5, monitor_every=0)
    assert np.array_equal(again.positions, pk.positions)
    with pytest.raises(pp.InvalidInputError, match="schedule"):
        scrm(radii, volume_fraction=0.5, schedule=[0.3, 0.2, 0.5])
