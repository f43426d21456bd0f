"""Small shared helpers: seeds, progress bars, atomic file writes."""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import sys
import tempfile
from pathlib import Path

import numpy as np

from .errors import InvalidInputError, OutputError

__all__ = ["as_seed_sequence", "rng_from", "seed_record", "progress_bar", "atomic_path", "atomic_open",
           "output_path", "check_output_folder", "written_files"]

#: Files completed by :func:`atomic_path` in this process (newest last); the CLI names
#: them when a command is interrupted.
_WRITTEN: list = []


def written_files() -> list:
    """Paths written completely (renamed into place) by this process so far."""
    return list(_WRITTEN)


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


_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))


def _kind(mode) -> str:
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def _existing_ancestor(folder: Path, shown) -> Path:
    """The nearest existing ancestor of ``folder``; OutputError if it is not a writable folder."""
    anc = folder
    while True:
        try:
            st = os.stat(anc)
            break
        except FileNotFoundError:
            if anc.parent == anc:
                raise OutputError(f"{shown}: no existing folder above it") from None
            anc = anc.parent
        except NotADirectoryError:
            anc = anc.parent
            continue
        except OSError as exc:
            raise OutputError(f"{shown}: cannot use folder {anc} ({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise OutputError(f"{shown}: {anc} is a file, not a folder; choose another path")
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputError(f"{shown}: folder {anc} is not writable")
    return anc


def output_path(path) -> Path:
    """The regular file a write to ``path`` replaces, checked before anything is computed.

    polypack writes only regular files.  A symbolic link is followed: the write goes to
    the regular file it points to (or creates it), and the link stays.  An existing
    folder, device, FIFO or socket at the target, a file where a parent folder should
    be, or a folder that is not writable raise :class:`~polypack.errors.OutputError`
    with one line.  Missing parent folders are allowed (they are created on writing).
    """
    shown = str(path)
    if shown == "":
        raise OutputError("empty output path")
    p = Path(os.path.realpath(os.fspath(path))) if os.path.islink(path) else Path(os.path.abspath(path))
    try:
        st = os.stat(p)
    except FileNotFoundError:
        st = None
    except NotADirectoryError:
        st = None  # a file in the parent chain: reported below
    except OSError as exc:
        raise OutputError(f"{shown}: cannot be written ({exc.strerror or exc})") from None
    if st is not None:
        if not stat.S_ISREG(st.st_mode):
            what = _kind(st.st_mode)
            hint = "; give a file name inside it" if stat.S_ISDIR(st.st_mode) else "; polypack writes only regular files"
            raise OutputError(f"{shown}: is {what}{hint}")
        if not os.access(p, os.W_OK):
            raise OutputError(f"{shown}: the existing file is read-only")
    _existing_ancestor(p.parent, shown)
    return p


def check_output_folder(path) -> Path:
    """A folder polypack may create or fill (the run folder): OutputError with one line otherwise."""
    shown = str(path)
    p = Path(os.path.abspath(path))
    try:
        st = os.stat(p)
    except (FileNotFoundError, NotADirectoryError):
        _existing_ancestor(p.parent, shown)
        return p
    except OSError as exc:
        raise OutputError(f"{shown}: cannot be used as output folder ({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise OutputError(f"{shown}: is {_kind(st.st_mode) if not stat.S_ISREG(st.st_mode) else 'a file'}, "
                          "not a folder; give a folder for the results")
    if not os.access(p, os.W_OK | os.X_OK):
        raise OutputError(f"{shown}: folder is not writable")
    return p


def make_folder(path) -> Path:
    """``mkdir -p`` with a one-line OutputError instead of an OSError traceback."""
    p = check_output_folder(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{path}: cannot create the folder ({exc.strerror or exc})") from None
    return Path(path)


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path in the destination folder; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched, so an
    interrupted write leaves the old file or none.  The target is checked first
    (:func:`output_path`): only regular files are written, a symbolic link is written
    through (its target file is replaced, the link kept).
    """
    target = output_path(path)
    folder = target.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise OutputError(f"{path}: cannot be written ({exc.strerror or exc})") from None
    os.close(fd)
    try:
        yield Path(tmp)
        # mkstemp makes the file private (0600); give it the mode a plain open() would
        # (the old file's mode when replacing one, else 0666 minus the umask)
        try:
            mode = os.stat(target).st_mode & 0o7777
        except FileNotFoundError:
            mode = 0o666 & ~_umask()
        os.chmod(tmp, mode)
        try:
            os.replace(tmp, target)
        except OSError as exc:
            if exc.errno in (errno.EISDIR, errno.ENOTDIR, errno.EACCES, errno.EPERM, errno.EROFS, errno.EBUSY):
                raise OutputError(f"{path}: cannot be replaced ({exc.strerror or exc})") from None
            raise
        _WRITTEN.append(str(path))
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


@contextlib.contextmanager
def atomic_paths(*paths):
    """Temporary paths for outputs written together (a file and its sidecar, an index and its
    parts): each is renamed onto its target only once the body has written all of them; on
    any exception none is, so a pair is written together or not at all."""
    with contextlib.ExitStack() as stack:
        tmps = [stack.enter_context(atomic_path(p)) for p in paths]
        yield tmps


def _same_file(a, b) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.abspath(a) == os.path.abspath(b)


#: File kinds by extension, for :func:`check_new_output` (what an existing file is).
_FILE_KINDS = {
    ".gsd": "GSD", ".xyz": "XYZ", ".extxyz": "XYZ", ".data": "LAMMPS data", ".lmp": "LAMMPS data",
    ".vtp": "VTK", ".vtm": "VTK", ".csv": "CSV", ".json": "JSON", ".html": "HTML", ".htm": "HTML",
    ".png": "PNG", ".svg": "SVG", ".pdf": "PDF", ".txt": "text", ".toml": "TOML",
}


def file_kind(path) -> str:
    """The kind of file ``path`` names by its extension (:data:`_FILE_KINDS`)."""
    ext = Path(path).suffix.lower()
    return _FILE_KINDS.get(ext, f"a {ext or 'extension-less'} file")


def check_new_output(path, kind, *, inputs=(), force=False, option="-o"):
    """Check an output path before anything is computed; return it as a Path.

    Refused with one line (:class:`~polypack.errors.InvalidInputError`): ``path`` is one of
    the command's ``inputs`` (no command writes onto its own input, ``--force`` or not);
    an existing file whose kind (by extension, :data:`_FILE_KINDS`) differs from the
    ``kind`` the command writes (e.g. HTML onto a ``.gsd``), unless ``force``. Then the
    checks of :func:`output_path` (a folder, a read-only file, ...).
    """
    shown = str(path)
    for src in inputs:
        if src is not None and _same_file(path, src):
            raise InvalidInputError(f"{option} {shown}: is the input file {src}; choose another output path")
    if os.path.isfile(path) and not force:
        have = file_kind(path)
        if have != kind:
            raise InvalidInputError(f"{option} {shown}: an existing {have} file would be replaced by {kind}; "
                                    "choose another path or pass --force")
    output_path(path)
    return Path(path)


#: Figure formats the CLI writes (by extension).
PLOT_FORMATS = ("png", "pdf", "svg")


def check_plot_path(path, option="--plot") -> str:
    """The figure format of ``path`` (its extension), checked before anything is computed:
    one-line InvalidInputError for another extension, then :func:`output_path`."""
    fmt = Path(path).suffix.lower().lstrip(".")
    if fmt not in PLOT_FORMATS:
        raise InvalidInputError(f"{option} {path}: cannot tell a figure format from {Path(path).suffix or '(none)'!r}; "
                                f"allowed extensions: {', '.join('.' + f for f in PLOT_FORMATS)}")
    output_path(path)
    return fmt
