"""Dask distributed as an executor for :func:`polypack.ensemble.run_study` (optional extra).

Install with ``pip install "polypack[dask]"`` (dask and distributed).

Local machine::

    polypack run study.toml --out out/study --dask --workers 2

Existing cluster (the scheduler's address)::

    polypack run study.toml --out out/study --scheduler tcp://10.0.0.5:8786

SLURM with dask-jobqueue (``pip install dask-jobqueue``): start the cluster in Python
and hand its executor to the runner; the realizations are shipped to the batch jobs and
the packs come back to this process, which writes all files (no shared file system
needed for the outputs)::

    from dask.distributed import Client
    from dask_jobqueue import SLURMCluster
    from polypack.ensemble import run_study

    cluster = SLURMCluster(cores=1, processes=1, memory="4GB", walltime="02:00:00",
                           job_extra_directives=["--partition=compute"])
    cluster.scale(jobs=32)                       # 32 single-core workers
    with Client(cluster) as client:
        run_study("study.toml", "out/study", executor=client.get_executor())

or run ``cluster.scheduler_address`` through ``polypack run --scheduler ADDRESS``.
Use one thread per worker (numba kernels are single-threaded; more threads per
worker only contend for the GIL).  Results are identical to a serial run: each
realization depends only on the study and its spawned seed.
"""

from __future__ import annotations

import contextlib

from ..errors import InvalidInputError

__all__ = ["dask_executor"]


@contextlib.contextmanager
def dask_executor(address=None, n_workers=None, timeout="10s"):
    """Yield a :class:`concurrent.futures.Executor` backed by Dask distributed.

    Parameters
    ----------
    address : str, optional
        Scheduler address (``tcp://host:8786``) of an existing cluster.  Default: start a
        ``LocalCluster(n_workers=n_workers, threads_per_worker=1)`` for the duration.
    n_workers : int, optional
        Worker processes of the local cluster (default: the number of cores).
    timeout : str or float, optional
        How long to try to reach ``address`` (default ``"10s"``).

    Raises
    ------
    InvalidInputError
        dask.distributed is not installed, or no scheduler answers at ``address``.
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise InvalidInputError(
            "--dask/--scheduler need dask.distributed: pip install 'polypack[dask]' (dask, distributed)"
        ) from None
    cluster = None
    if address:
        try:
            client = Client(address, timeout=timeout)
        except (OSError, ValueError, TypeError) as exc:  # unreachable, refused, malformed, timed out
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InvalidInputError(
                f"--scheduler {address!r}: cannot connect to a Dask scheduler there ({first[:200]}); "
                "give a running scheduler's address, e.g. tcp://host:8786"
            ) from None
    else:
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    try:
        yield client.get_executor()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
