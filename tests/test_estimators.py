"""One conformance test over every estimator: the shared protocol of polypack.analysis._base.Estimator.

Before ``compute`` every result raises NotComputedError (never zeros); ``compute`` returns
the estimator; results are computed once and cached until the next ``compute``/``reset``
(array results read-only); parameters are read-only after construction; ``repr`` names the
parameters; ``to_dict`` is plain JSON; ``reset=False`` accumulates realizations.
"""

import importlib
import json
import pkgutil

import numpy as np
import pytest

import polypack as pp
from polypack.analysis._base import Estimator

# how to build each estimator for the test pack (box 4, radii 0.3); a new estimator must be added here
FACTORIES = {
    "RDF": lambda: pp.analysis.RDF(r_max=1.5, dr=0.1),
    "KFunction": lambda: pp.analysis.KFunction(r_max=1.5, dr=0.1),
    "WindowCounts": lambda: pp.analysis.WindowCounts(window_radius=2.0),
    "ShellCount": lambda: pp.analysis.ShellCount(r_max=1.5, dr=0.1),
    "Contacts": lambda: pp.analysis.Contacts(tolerance=0.5),
    "PoreSizes": lambda: pp.analysis.PoreSizes(n_points=500, seed=1),
    "DepositStatistics": lambda: pp.analysis.deposits.DepositStatistics(margin=1.0),
    "ThreePointParameters": lambda: pp.analysis.ThreePointParameters(radial_nodes=3, angular_nodes=4),
}


def _deposit(jitter_seed=0):
    """2D disks on a square grid resting on a floor: x periodic, y walls (a deposit)."""
    g = np.array([(i + 0.5, j + 0.5) for i in range(10) for j in range(12)])
    g = g + np.random.default_rng(jitter_seed).uniform(-0.01, 0.01, g.shape)
    return pp.Packing(g, np.full(len(g), 0.48), [10.0, 12.0], periodic=(True, False))


# the pack an estimator is tested on (default: _pack, 3D periodic)
PACKS = {"DepositStatistics": _deposit}


def _all_estimators():
    import polypack.analysis as pa

    for info in pkgutil.iter_modules(pa.__path__):
        importlib.import_module(f"polypack.analysis.{info.name}")
    # mechanics estimators follow the same protocol; plain imports: an import bug in any
    # module of polypack fails here instead of silently dropping its estimators
    import polypack.mechanics as pm

    for info in pkgutil.iter_modules(pm.__path__):
        importlib.import_module(f"polypack.mechanics.{info.name}")
    out, todo = {}, list(Estimator.__subclasses__())
    while todo:
        cls = todo.pop()
        todo.extend(cls.__subclasses__())
        if "compute" in {k for c in cls.__mro__ for k in c.__dict__} and cls.__module__.startswith("polypack"):
            if cls.__name__ not in ("GridEstimator", "PairCountEstimator"):
                out[cls.__name__] = cls
    return out


ESTIMATORS = _all_estimators()


def _pack(jitter_seed=0):
    g = np.arange(4) + 0.5
    pos = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    pos = pos + np.random.default_rng(jitter_seed).uniform(-0.15, 0.15, pos.shape)
    species = np.arange(len(pos)) % 2
    return pp.Packing(pos, np.where(species == 0, 0.3, 0.2), 4.0, species=species)


def _results(cls):
    return [name for name in dir(cls)
            if isinstance(getattr(cls, name, None), property) and not name.startswith("_")
            and name not in cls._params and name != "n_realizations"]


def test_every_estimator_is_covered():
    assert set(ESTIMATORS) <= set(FACTORIES), f"add a factory for {sorted(set(ESTIMATORS) - set(FACTORIES))}"
    assert set(ESTIMATORS) >= {"RDF", "KFunction", "WindowCounts", "ShellCount", "Contacts", "PoreSizes"}


@pytest.mark.parametrize("name", sorted(FACTORIES))
def test_estimator_protocol(name):
    est = FACTORIES[name]()
    cls = type(est)
    results = _results(cls)
    assert results, f"{name} exposes no result properties"
    # 1. nothing before compute
    for r in results:
        with pytest.raises(pp.NotComputedError, match=f"{name}.{r} is not computed yet"):
            getattr(est, r)
    assert est.n_realizations == 0
    # 2. compute returns the estimator
    make = PACKS.get(name, _pack)
    pk = make()
    assert est.compute(pk) is est and est.n_realizations == 1
    # 3. cached: the same object on a second access, arrays read-only
    values = {}
    for r in results:
        try:
            v = getattr(est, r)
        except pp.InvalidInputError:
            continue  # a result that needs other inputs (e.g. a species pair) is checked by its own tests
        assert getattr(est, r) is v, f"{name}.{r} is recomputed on every access"
        if isinstance(v, np.ndarray):
            assert not v.flags.writeable, f"{name}.{r} returns a writeable array"
        values[r] = v
    assert values
    # 4. a new compute invalidates the cache; reset=False accumulates
    est.compute(make(1))
    assert est.n_realizations == 1
    r0 = next(iter(values))
    assert getattr(est, r0) is not values[r0]
    est.compute(make(2), reset=False)
    assert est.n_realizations == 2
    # 5. parameters are read-only
    for p in cls._params:
        if p in est.__dict__ or isinstance(getattr(cls, p, None), property):
            with pytest.raises(AttributeError, match="read-only"):
                setattr(est, p, getattr(est, p))
    with pytest.raises(AttributeError, match="read-only"):
        est.brand_new_parameter = 1
    # 6. repr shows the parameters
    text = repr(est)
    assert text.startswith(f"{name}(") and "n_realizations=2" in text
    # 7. plain JSON
    json.dumps(est.to_dict(), allow_nan=False)
    # 8. reset forgets everything
    est.reset()
    with pytest.raises(pp.NotComputedError):
        getattr(est, r0)


def test_pore_survival_is_guarded():
    # used to return zeros before compute
    with pytest.raises(pp.NotComputedError):
        pp.analysis.PoreSizes(n_points=100, seed=1).survival
