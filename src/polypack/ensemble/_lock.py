"""Advisory ownership of a run folder: one ``polypack run`` at a time per folder.

``DIR/.polypack.lock`` holds the owner's pid, host, start time and study fingerprint
(JSON) and is held with an exclusive ``flock`` while the run lasts, so the kernel
releases it when the owner dies (even on SIGKILL).  A second run on the same folder
waits up to ``wait`` seconds, then refuses with one line naming the owner.  A lock
file left by a dead process on this host (or with no live flock holder) is stale and
taken over; the takeover is reported in the lock's ``previous`` entry.
"""

from __future__ import annotations

import json
import os
import socket
import time
from pathlib import Path

from ..errors import OutputError

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows: pid/host check only
    fcntl = None

__all__ = ["RunFolderLock", "LOCK_NAME", "FolderBusyError"]

LOCK_NAME = ".polypack.lock"


class FolderBusyError(OutputError):
    """Another live run owns the folder."""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except (OSError, ValueError, OverflowError):
        return False
    return True


class RunFolderLock:
    """Context manager: own ``folder`` for the duration of a run (see the module docstring)."""

    def __init__(self, folder, fingerprint: str = "", wait: float = 0.0, poll: float = 0.2):
        self.folder = Path(folder)
        self.path = self.folder / LOCK_NAME
        self.fingerprint = fingerprint
        self.wait = float(wait)
        self.poll = poll
        self.fd = None
        self.previous = None

    def _owner(self):
        try:
            return json.loads(self.path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    def _describe(self, owner) -> str:
        if not owner:
            return "another run"
        since = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(owner.get("started", 0)))
        return f"pid {owner.get('pid')} on {owner.get('host')} (since {since})"

    def _try(self) -> bool:
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                owner = self._owner()
                # held, but the recorded owner on this host is dead: the holders are orphans
                # (e.g. pool workers forked with the lock open); the lock is stale, so a new
                # lock file replaces it (the orphans keep the old, unlinked one)
                stale = (owner and owner.get("host") == socket.gethostname() and owner.get("pid")
                         and not _alive(int(owner["pid"])) and os.fstat(fd).st_ino == os.stat(self.path).st_ino)
                os.close(fd)
                if stale:
                    self.previous = owner
                    os.unlink(self.path)
                    return self._try()
                return False
        owner = self._owner()
        host = socket.gethostname()
        if owner and owner.get("pid") not in (None, os.getpid()):
            # the flock is ours, so the recorded owner is gone (stale); on another host with a
            # file system without flock, trust the pid only when it is on this host
            if fcntl is None and owner.get("host") == host and _alive(int(owner["pid"])):
                os.close(fd)
                return False
            self.previous = owner
        rec = {"pid": os.getpid(), "host": host, "started": time.time(), "fingerprint": self.fingerprint}
        if self.previous:
            rec["previous"] = {k: self.previous.get(k) for k in ("pid", "host", "started")}
        data = json.dumps(rec).encode()
        os.ftruncate(fd, 0)
        os.pwrite(fd, data, 0)
        os.fsync(fd)
        self.fd = fd
        return True

    def acquire(self):
        self.folder.mkdir(parents=True, exist_ok=True)
        deadline = time.monotonic() + self.wait
        while True:
            try:
                if self._try():
                    return self
            except OSError as exc:
                raise OutputError(f"{self.folder}: cannot lock the run folder ({exc.strerror or exc})") from None
            if time.monotonic() >= deadline:
                owner = self._owner()
                raise FolderBusyError(
                    f"{self.folder} is in use by {self._describe(owner)}: one run per folder at a time; "
                    "wait for it to finish (or --wait SECONDS) or use another --out"
                )
            time.sleep(self.poll)

    def release(self):
        if self.fd is None:
            return
        try:
            os.ftruncate(self.fd, 0)  # an empty lock file: nobody owns the folder
        except OSError:
            pass
        os.close(self.fd)  # releases the flock
        self.fd = None

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()
        return False
