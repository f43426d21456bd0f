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
import os
import signal
import sys
import threading

__all__ = ["deferred", "pending", "check", "is_interrupt", "guard_cli_process", "install_cli_handler", "arm",
           "restore_sigint", "interrupted_line", "said_interrupted", "say_and_exit_130", "exit_130"]

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


# --------------------------------------------------------------------------- the CLI's own process
# (moved here from polypack._entry so that polypack.cli and the package root need not import the
# entry point, which imports the CLI: no import cycle; tests/test_layers.py::test_no_import_cycles)
#
# Console entry point (``polypack``, ``python -m polypack``): a Ctrl-C at any moment of the
# process exits 130 with one line (or, once the command is over, is ignored), never a traceback.
#
# The process's SIGINT handler is ours from the first statement of ``import polypack`` (the
# package imports this module and calls :func:`guard_cli_process` before numpy) to the end:
#
# - before the command starts (imports) and after it has finished (reporting, exit): exit 130
#   at once with one line naming the files saved so far (nothing can be half-done there);
# - while :func:`polypack._entry.main` runs the command (*armed*): the first SIGINT outside a
#   :func:`polypack._interrupt.deferred` section raises one KeyboardInterrupt and disarms, so
#   it always lands in its ``try`` (the command's line, exit 130) and a later one
#   in a clean-up exits at once; inside a deferred section the first Ctrl-C stops at the next
#   safe point, a second one falls through to this handler;
# - at the last atexit callback SIGINT becomes ignored: Python resets a Python-level handler
#   to the default action (death by SIGINT, exit status -2) when it finalizes, and the
#   finalization of the numba/LLVM modules takes a few tenths of a second.
#
# Only a SIGINT that arrives before Python has run any polypack code (interpreter start-up,
# ``site``) is Python's own business: it dies of SIGINT or prints a KeyboardInterrupt there.

_cli = {"armed": False, "said": False, "installed": False}


def interrupted_line() -> str:
    """``interrupted: saved A, B before the interrupt`` / ``interrupted: nothing was saved``."""
    files = []
    util = sys.modules.get("polypack._util")  # never import here: we may be inside an import
    if util is not None:
        try:
            files = list(util.written_files())
        except Exception:  # noqa: BLE001 - half-imported module
            files = []
    saved = f"saved {', '.join(map(str, files))} before the interrupt" if files else "nothing was saved"
    return f"interrupted: {saved}"


def said_interrupted():
    """The command is writing its one ``interrupted`` line and exits 130: a Ctrl-C from now
    on is ignored (it neither cuts the line nor adds a second one)."""
    _cli["armed"] = False
    _cli["said"] = True


def exit_130():
    # os._exit: CPython kills itself with SIGINT at exit once a KeyboardInterrupt passed
    # through some C-level code (even if it was caught later); the exit code must be 130
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 - closed or broken stream (or a re-entrant flush)
            pass
    os._exit(130)


def say_and_exit_130():
    if not _cli["said"]:
        said_interrupted()
        line = interrupted_line() + "\n"
        try:
            sys.stderr.flush()
        except Exception:  # noqa: BLE001
            pass
        try:
            os.write(2, line.encode(errors="replace"))
        except OSError:
            pass
    exit_130()


def _on_sigint(signum, frame):
    if _cli["said"]:  # the interrupted line is being written; exit 130 follows
        return
    if _cli["armed"]:
        _cli["armed"] = False  # one KeyboardInterrupt per process: a later Ctrl-C exits at once
        raise KeyboardInterrupt
    say_and_exit_130()


def _ignore_sigint_at_exit():
    import signal

    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except (ValueError, OSError):  # pragma: no cover - not the main thread
        pass


def install_cli_handler():
    """Make :func:`_on_sigint` the SIGINT handler of this process (idempotent)."""
    import signal

    try:
        signal.signal(signal.SIGINT, _on_sigint)  # also replaces an inherited SIG_IGN (see restore_sigint)
    except (ValueError, OSError, AttributeError):  # not the main thread, or no signals here
        return
    if not _cli["installed"]:
        import atexit

        _cli["installed"] = True
        atexit.register(_ignore_sigint_at_exit)  # registered first: runs last


def _is_cli_process() -> bool:
    """True while ``import polypack`` runs for ``python -m polypack`` or the ``polypack`` script."""
    if sys.argv and sys.argv[0] == "-m":  # runpy imports the package before it sets argv[0]
        argv = list(getattr(sys, "orig_argv", ()))
        for k, a in enumerate(argv[1:], 1):
            if a == "-m":
                return argv[k + 1 : k + 2] == ["polypack"]
            if a.startswith("-m"):
                return a == "-mpolypack"
        return False
    main = sys.modules.get("__main__")
    script = getattr(main, "__file__", None) or ""
    name = os.path.basename(sys.argv[0]) if sys.argv else ""
    for suffix in ("-script.pyw", "-script.py", ".exe"):
        name = name.removesuffix(suffix)
    if name != "polypack" or not script:
        return False
    try:  # the console script pip generates: "from polypack._entry import main"
        with open(script, "rb") as fh:
            return b"polypack._entry" in fh.read(4096)
    except OSError:
        return False


def guard_cli_process():
    """Called by ``polypack/__init__`` before anything else: in the CLI's own process, a
    Ctrl-C during the imports exits 130 with one line instead of a traceback."""
    if _is_cli_process():
        install_cli_handler()


def restore_sigint():
    """Give Ctrl-C / ``kill -INT`` back to a command started in the background.

    A POSIX shell without job control (a script, ``cmd &`` in a non-interactive shell)
    starts background commands with SIGINT ignored, and Python then keeps it ignored:
    ``kill -INT`` would not stop a long ``polypack run`` at a safe point.  The CLI
    restores Python's default handler (KeyboardInterrupt), so SIGINT stops every
    command at its next safe point however it was started (in the CLI's own process the
    entry point's handler replaced SIG_IGN already).  SIGTERM keeps its default action
    (the process ends at once; outputs are written atomically, so nothing interrupted is
    recorded as complete).
    """
    import signal

    try:
        if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    except (ValueError, OSError, AttributeError):  # not the main thread, or no signals here
        pass


def arm(on: bool) -> None:
    """While :func:`polypack._entry.main` runs the command: the first SIGINT outside a
    :func:`deferred` section raises one KeyboardInterrupt (``on``), else exits 130."""
    _cli["armed"] = bool(on)
