"""The one ``[psd]`` table: models and size sets from plain parameter dictionaries.

``polypack psd`` (its ``--config`` file and options) and the ``[psd]`` table of a study
(``polypack run``) are read by the same code, :func:`resolve`, against the models
declared in the registry (:mod:`polypack.psd._capabilities`): ``model`` is a registered
name or alias (``"cb"``; hyphens read as underscores), the model's parameters by their
Python names, and the generation keys ``sampling``, ``n``, ``method``, ``seed``
(``polypack psd`` only), ``n_classes``, ``spacing``, ``min_per_class``, ``min_total``,
``max_total``, ``count_basis``.

Rules (the same for both commands): the default model is ``"bimodal"``; ``sampling``
defaults to ``"sample"`` unless size-class keys are given without ``n``; ``"sample"``
draws ``n`` particles (default 2000) from the number law; ``"discretize"`` builds size
classes (§1.2 of 001_ad5bae0acea940c4.txt, ``n_classes`` default 10). Model defaults
are filled into the resolved table (they are what the model uses anyway).
"""

from __future__ import annotations

from .. import registry
from ..errors import InvalidInputError

__all__ = ["MODELS", "GENERATION_KEYS", "CLASS_KEYS", "resolve", "allowed_keys", "model_from_dict",
           "sizeset_from_dict", "make_model", "make_sizes"]


def _generation_specs():
    from ._capabilities import Generation

    return registry.option_specs(Generation)


def _models():
    return registry.capabilities("psd")


class _ModelTable(dict):
    """``{model: parameter names}`` computed from the registry on access."""

    def _fill(self):
        if not dict.__len__(self):
            for name, cap in _models().items():
                dict.__setitem__(self, name, tuple(cap.specs()))

    def __getitem__(self, k):
        self._fill()
        return dict.__getitem__(self, k)

    def __iter__(self):
        self._fill()
        return dict.__iter__(self)

    def __len__(self):
        self._fill()
        return dict.__len__(self)

    def __contains__(self, k):
        self._fill()
        return dict.__contains__(self, k)

    def items(self):
        self._fill()
        return dict.items(self)

    def values(self):
        self._fill()
        return dict.values(self)

    def keys(self):
        self._fill()
        return dict.keys(self)


#: ``{model: parameter names}`` of every registered model.
MODELS = _ModelTable()
CLASS_KEYS = ("n_classes", "spacing", "min_per_class", "min_total", "max_total", "count_basis")
GENERATION_KEYS = ("sampling", "n", "method", "seed") + CLASS_KEYS


def allowed_keys(study: bool = False) -> list[str]:
    """Every key a ``[psd]`` table may hold (``study=True``: without ``seed``)."""
    keys = [k for k, s in _generation_specs().items() if s.study or not study]
    for cap in _models().values():
        for k in cap.specs():
            if k not in keys:
                keys.append(k)
    return keys


def resolve(table: dict, path: str = "psd", *, study: bool = False) -> dict:
    """Validate a ``[psd]`` table and return it resolved (defaults filled).

    Parameters
    ----------
    table : dict
        Parsed table; ``None`` values are treated as absent (CLI options not given).
    path : str
        Key path used in messages (``psd.size_ratio = 3.0: must be in (0, 1]``).
    study : bool
        A study table: ``seed`` is not allowed (the study's seed is used).

    Raises
    ------
    InvalidInputError
        With the key path first; the same message from ``polypack psd`` and ``polypack run``.
    """
    if not isinstance(table, dict):
        raise InvalidInputError(f"{path} = {table!r}: expected a table ([{path}])")
    table = {k: v for k, v in table.items() if v is not None}
    gen_specs = _generation_specs()
    allowed = allowed_keys(study)
    for k in table:
        if k not in allowed:
            if study and k == "seed":
                raise InvalidInputError(f"{path}.seed: not used in a study; the sizes' seed derives from study.seed")
            raise InvalidInputError(f"{path}.{k}: unknown key; allowed: {', '.join(allowed)}")
    cap = registry.get("psd", table.get("model", gen_specs["model"].default), path=f"{path}.model")
    model_specs = cap.specs()
    for k in table:
        if k not in gen_specs and k not in model_specs:
            raise InvalidInputError(
                f'{path}.{k}: not a parameter of model "{cap.name}"; allowed: {", ".join(model_specs)}'
            )
    gen = registry.resolve_table({k: s for k, s in gen_specs.items() if s.study or not study},
                                 {k: v for k, v in table.items() if k in gen_specs}, path)
    gen["model"] = cap.name
    params = registry.resolve_table(model_specs, {k: v for k, v in table.items() if k in model_specs}, path)
    out = {**gen, **params}
    sampling = out.get("sampling")
    if sampling is None:
        sampling = "sample" if "n" in out or not any(k in out for k in CLASS_KEYS) else "discretize"
        out["sampling"] = sampling
    if sampling == "sample":
        out.setdefault("n", 2000)
        for k in CLASS_KEYS:
            if k in out:
                raise InvalidInputError(f'{path}.{k}: only used with {path}.sampling = "discretize"')
    else:
        if "n" in out:
            raise InvalidInputError(
                f'{path}.n: not used with {path}.sampling = "discretize" (the class criteria set N)'
            )
        out.setdefault("n_classes", 10)
    if "d_min" in out and "d_max" in out and not out["d_min"] < out["d_max"]:
        raise InvalidInputError(f"{path}.d_min = {out['d_min']!r}: must be < {path}.d_max = {out['d_max']!r}")
    if "span" in out and "d_min" in out and "d_max" in out:
        raise InvalidInputError(f"{path}.span: give span or d_min, not both with d_max")
    return out


def make_model(resolved: dict):
    """The size-distribution model of a resolved ``[psd]`` table."""
    cap = registry.get("psd", resolved["model"])
    params = {k: resolved[k] for k in cap.specs() if k in resolved}
    return cap.load()(**params)


def make_sizes(resolved: dict, seed=None):
    """A :class:`~polypack.psd.SizeSet` from a resolved ``[psd]`` table.

    ``seed`` overrides the table's ``seed`` (a study passes the realization's child seed).
    Uses ``model.sample(n=, seed=, method=)`` or :func:`polypack.psd.discretize` (§1.2 of
    001_ad5bae0acea940c4.txt).
    """
    from .classes import discretize

    model = make_model(resolved)
    seed = resolved.get("seed") if seed is None else seed
    method = resolved.get("method", "random")
    if resolved["sampling"] == "discretize":
        kw = {k: resolved[k] for k in CLASS_KEYS if k in resolved}
        return discretize(model, seed=seed, method=method, **kw)
    return model.sample(n=resolved["n"], seed=seed, method=method)


def model_from_dict(params: dict):
    """A size-distribution model from ``{"model": name, **parameters}`` (generation keys allowed)."""
    return make_model(resolve(params))


def sizeset_from_dict(params: dict, seed=None):
    """``(model, SizeSet)`` from a ``[psd]`` dictionary (model parameters + generation keys)."""
    res = resolve(params)
    return make_model(res), make_sizes(res, seed)
