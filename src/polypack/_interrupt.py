"""One interrupt discipline for every long computation (generators, analyses, stages, commands).

A Ctrl-C (SIGINT) never tears a numba kernel or a half-updated state apart: while a
:func:`deferred` section runs, SIGINT only sets a flag, and the computation stops at
its next *safe point* (the end of a kernel chunk, a global shake, a growth stage),
where it raises :class:`polypack.errors.Interrupted` carrying the state reached so far
(``partial``), which is never a complete result.  ``Interrupted`` derives from
:class:`KeyboardInterrupt`, so ``except Exception`` handlers never swallow it and a
caller that knows nothing about it sees an ordinary Ctrl-C.

Only the main thread of a process whose SIGINT handler is a Python callable (the
default one, or a notebook's) defers; elsewhere (worker threads, pool workers that
ignore SIGINT) the sections are no-ops.  A second Ctrl-C while a request is pending
falls through to the previous handler, so a computation stuck between safe points can
still be stopped by pressing Ctrl-C twice.
"""

from __future__ import annotations

import contextlib
import signal
import threading

__all__ = ["deferred", "pending", "check", "is_interrupt"]

_state = {"depth": 0, "requested": False, "previous": None}


def _handler(signum, frame):
    if _state["requested"]:  # second Ctrl-C: do what the previous handler does (raise)
        prev = _state["previous"]
        if callable(prev):
            prev(signum, frame)
        return
    _state["requested"] = True


@contextlib.contextmanager
def deferred():
    """Defer SIGINT to the safe points of the enclosed computation (re-entrant).

    At the end of the outermost section a request nobody consumed is raised as a
    :class:`KeyboardInterrupt` (unless an exception is already propagating).
    """
    installed = False
    if _state["depth"] == 0 and threading.current_thread() is threading.main_thread():
        try:
            prev = signal.getsignal(signal.SIGINT)
        except (ValueError, OSError):  # pragma: no cover - no signals here
            prev = None
        if callable(prev) and prev is not _handler:
            _state["previous"] = prev
            _state["requested"] = False
            signal.signal(signal.SIGINT, _handler)
            installed = True
    _state["depth"] += 1
    ok = False
    try:
        yield
        ok = True
    finally:
        _state["depth"] -= 1
        if installed:
            signal.signal(signal.SIGINT, _state["previous"])
            requested = _state["requested"]
            _state["requested"] = False
            _state["previous"] = None
            if requested and ok:
                raise KeyboardInterrupt


def pending() -> bool:
    """True if a Ctrl-C arrived in the current deferred section and was not consumed yet."""
    return bool(_state["requested"])


def consume() -> bool:
    """:func:`pending`, and clear the request (the caller raises Interrupted itself)."""
    req = bool(_state["requested"])
    _state["requested"] = False
    return req


def check(message="interrupted", partial=None):
    """At a safe point: raise :class:`~polypack.errors.Interrupted` if Ctrl-C was pressed."""
    if consume():
        from .errors import Interrupted

        raise Interrupted(message, partial=partial)


def is_interrupt(exc: BaseException) -> bool:
    """True for a KeyboardInterrupt, or an error raised while one was being delivered.

    numba reports a Ctrl-C that arrives while it boxes a kernel's result as a
    ``SystemError`` whose context is the ``KeyboardInterrupt``.
    """
    seen = 0
    while exc is not None and seen < 8:
        if isinstance(exc, KeyboardInterrupt):
            return True
        exc = exc.__cause__ or exc.__context__
        seen += 1
    return False
