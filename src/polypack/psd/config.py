"""Models and size sets from plain parameter dictionaries (TOML ``[psd]`` sections, the CLI).

The vocabulary matches :mod:`polypack.study`: ``model`` is one of :data:`MODELS` (hyphens
and the alias ``"cb"`` are accepted), the model's parameters by their Python names, and the
generation keys ``sampling`` ("sample": ``n`` particles from the number law; "discretize":
size classes of §1.2 of 001_ad5bae0acea940c4.txt), ``n``, ``method``, ``seed``,
``n_classes``, ``spacing``, ``min_per_class``, ``min_total``, ``max_total``, ``count_basis``.
"""

from __future__ import annotations

from ..errors import InvalidInputError
from . import models as _m

__all__ = ["MODELS", "GENERATION_KEYS", "model_from_dict", "sizeset_from_dict"]

MODELS = {
    "cumulative_beta": ("a", "b", "span", "d_min", "d_max", "dim"),
    "uniform_volume": ("d_min", "d_max", "span", "dim"),
    "uniform_size": ("d_min", "d_max", "span", "dim"),
    "lognormal": ("median", "sigma", "d_min", "d_max", "basis", "dim"),
    "normal": ("mean", "std", "d_min", "d_max", "basis", "dim"),
    "monodisperse": ("d", "dim"),
    "bimodal": ("size_ratio", "volume_ratio", "d_large", "spread", "dim"),
    "mixture": ("sizes", "volume_fractions", "spread", "dim"),
    "sieve": ("sieve", "percent", "dim"),
}
_ALIASES = {"cb": "cumulative_beta", "beta": "cumulative_beta", "sieve_table": "sieve"}
CLASS_KEYS = ("n_classes", "spacing", "min_per_class", "min_total", "max_total", "count_basis")
GENERATION_KEYS = ("sampling", "n", "method", "seed") + CLASS_KEYS


def _model_name(name):
    if not isinstance(name, str):
        raise InvalidInputError(f"model={name!r}: allowed are {', '.join(MODELS)}")
    key = name.strip().lower().replace("-", "_")
    key = _ALIASES.get(key, key)
    if key not in MODELS:
        raise InvalidInputError(f"model={name!r}: unknown; allowed are {', '.join(MODELS)} (alias cb)")
    return key


def _floats(name, v):
    if isinstance(v, str):
        v = [x for x in v.replace(";", ",").split(",") if x.strip()]
    try:
        return [float(x) for x in (v if isinstance(v, (list, tuple)) else [v])]
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name}={v!r}: expected a number or a comma-separated list of numbers") from None


def model_from_dict(params: dict):
    """A size-distribution model from ``{"model": name, **parameters}``.

    Unknown models and parameters that do not belong to the model raise
    :class:`~polypack.InvalidInputError` naming them and the allowed ones.
    """
    params = {k: v for k, v in params.items() if v is not None}
    name = _model_name(params.pop("model", "cumulative_beta"))
    allowed = MODELS[name]
    for k in params:
        if k not in allowed:
            raise InvalidInputError(f"{k}: not a parameter of model {name!r}; allowed: {', '.join(allowed)}")
    p = dict(params)
    simple = {"cumulative_beta": _m.CumulativeBeta, "uniform_volume": _m.UniformVolume,
              "uniform_size": _m.UniformSize, "lognormal": _m.LogNormal, "normal": _m.Normal}
    if name in simple:
        return simple[name](**p)
    if name == "monodisperse":
        return _m.Mixture([_m.Monodisperse(p.get("d", 1.0), p.get("dim", 3))], [1.0], dim=p.get("dim", 3))
    if name == "bimodal":
        if "spread" in p:
            sp = _floats("spread", p["spread"])
            p["spread"] = sp[0] if len(sp) == 1 else sp
        return _m.Bimodal(**p)
    if name == "mixture":
        if "sizes" not in p or "volume_fractions" not in p:
            raise InvalidInputError("model 'mixture' needs sizes and volume_fractions (one per mode)")
        sp = _floats("spread", p["spread"]) if "spread" in p else None
        return _m.Mixture.from_modes(_floats("sizes", p["sizes"]), _floats("volume_fractions", p["volume_fractions"]),
                                     spread=(sp[0] if sp and len(sp) == 1 else sp), dim=p.get("dim", 3))
    if "sieve" not in p:
        raise InvalidInputError("model 'sieve' needs sieve = path of a CSV with columns size, passing")
    return _m.SieveTable.from_csv(p["sieve"], percent=p.get("percent"), dim=p.get("dim", 3))


def sizeset_from_dict(params: dict):
    """``(model, SizeSet)`` from a ``[psd]`` dictionary (model parameters + generation keys).

    ``sampling`` defaults to ``"sample"`` when ``n`` is given and ``"discretize"`` otherwise.
    """
    from .classes import discretize

    params = {k: v for k, v in params.items() if v is not None}
    gen = {k: params.pop(k) for k in list(params) if k in GENERATION_KEYS}
    model = model_from_dict(params)
    sampling = gen.pop("sampling", "sample" if "n" in gen else "discretize")
    if sampling not in ("sample", "discretize"):
        raise InvalidInputError(f"sampling={sampling!r}: allowed are 'sample' and 'discretize'")
    seed = gen.pop("seed", None)
    method = gen.pop("method", "random")
    if sampling == "sample":
        extra = [k for k in gen if k != "n"]
        if extra:
            raise InvalidInputError(f"{extra[0]}: only used with sampling = 'discretize' (got sampling = 'sample')")
        return model, model.sample(gen.get("n", 2000), seed=seed, method=method)
    if "n" in gen:
        raise InvalidInputError("n: not used with sampling = 'discretize' (the class criteria set the number)")
    return model, discretize(model, seed=seed, method=method, **gen)
