"""Small shared helpers: seeds, progress bars, atomic file writes."""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from .errors import InvalidInputError

__all__ = ["as_seed_sequence", "rng_from", "seed_record", "progress_bar", "atomic_path", "atomic_open"]


def as_seed_sequence(seed) -> np.random.SeedSequence:
    """Normalise ``seed`` (None, int, SeedSequence or Generator-free entropy) to a SeedSequence."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None:
        return np.random.SeedSequence()
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        if seed < 0:
            raise InvalidInputError(f"seed={seed}: must be a non-negative integer")
        return np.random.SeedSequence(int(seed))
    raise InvalidInputError(f"seed={seed!r}: allowed are None, a non-negative int or numpy.random.SeedSequence")


def rng_from(seed) -> np.random.Generator:
    """A PCG64 generator from ``seed`` (see :func:`as_seed_sequence`)."""
    return np.random.default_rng(as_seed_sequence(seed))


def seed_record(seed) -> dict:
    """JSON-able record of a seed so a realization can be regenerated bit for bit."""
    ss = as_seed_sequence(seed)
    return {"entropy": int(ss.entropy) if not isinstance(ss.entropy, (list, tuple)) else list(ss.entropy),
            "spawn_key": list(ss.spawn_key)}


def seed_from_record(rec: dict) -> np.random.SeedSequence:
    """Inverse of :func:`seed_record`."""
    return np.random.SeedSequence(rec["entropy"], spawn_key=tuple(rec.get("spawn_key", ())))


def progress_bar(total=None, desc="", progress=None, unit="it", **kw):
    """A tqdm bar; ``progress=None`` shows it only when stderr is a terminal.

    ``progress=True`` forces it on, ``False`` off.
    """
    from tqdm.auto import tqdm

    if progress is None:
        disable = not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty())
    else:
        disable = not progress
    return tqdm(total=total, desc=desc, disable=disable, unit=unit, leave=False, dynamic_ncols=True, **kw)


def _umask() -> int:
    """The process umask, read without changing it where the OS allows."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path in the destination folder; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched, so an
    interrupted write leaves the old file or none.
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    os.close(fd)
    try:
        yield Path(tmp)
        # mkstemp makes the file private (0600); give it the mode a plain open() would
        # (the old file's mode when replacing one, else 0666 minus the umask)
        try:
            mode = os.stat(path).st_mode & 0o7777
        except FileNotFoundError:
            mode = 0o666 & ~_umask()
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)
        raise


@contextlib.contextmanager
def atomic_open(path, mode="w", **kw):
    """``open`` a file for writing atomically (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        with open(tmp, mode, **kw) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
