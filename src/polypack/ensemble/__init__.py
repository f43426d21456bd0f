"""Ensembles of seeded realizations of a study on any :class:`concurrent.futures.Executor`.

``polypack run study.toml --out DIR`` (or :func:`run_study`) takes a study file
(:mod:`polypack.study`) through size distribution -> packing protocol -> analyses for P
realizations, seeded by ``numpy.random.SeedSequence(seed).spawn(P)``, and writes one GSD
and one record per realization, ensemble-averaged curves with 95 % bands, a summary
table and plots.  Reruns resume (see :mod:`polypack.ensemble.runner`).

Executors: in-process (``workers=1``), a process pool (``workers=K``), or Dask
distributed (:func:`dask_executor`: a local cluster, or an existing scheduler address,
e.g. one started by dask-jobqueue on SLURM).
"""

from __future__ import annotations

from .dask_helpers import dask_executor
from .runner import (
    EnsembleResult,
    aggregate,
    ensemble_curves,
    regenerate,
    run_realization,
    run_study,
    verify_realization,
)
from .stages import child_seed_records, make_packing, make_sizes, realize, run_analyses

__all__ = [
    "run_study",
    "regenerate",
    "EnsembleResult",
    "dask_executor",
    "aggregate",
    "ensemble_curves",
    "run_realization",
    "verify_realization",
    "realize",
    "make_sizes",
    "make_packing",
    "run_analyses",
    "child_seed_records",
]
