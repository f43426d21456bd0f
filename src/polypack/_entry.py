"""Console entry point (``polypack``, ``python -m polypack``): a Ctrl-C at any moment of the
process exits 130 with one line (or, once the command is over, is ignored), never a traceback.

The process's SIGINT handler is ours from the first statement of ``import polypack`` (the
package imports this module and calls :func:`guard_cli_process` before numpy) to the end:

- before the command starts (imports) and after it has finished (reporting, exit): exit 130
  at once with one line naming the files saved so far (nothing can be half-done there);
- while :func:`main` runs the command (*armed*): the first SIGINT outside a
  :func:`polypack._interrupt.deferred` section raises one KeyboardInterrupt and disarms, so
  it always lands in :func:`main`'s ``try`` (the command's line, exit 130) and a later one
  in a clean-up exits at once; inside a deferred section the first Ctrl-C stops at the next
  safe point, a second one falls through to this handler;
- at the last atexit callback SIGINT becomes ignored: Python resets a Python-level handler
  to the default action (death by SIGINT, exit status -2) when it finalizes, and the
  finalization of the numba/LLVM modules takes a few tenths of a second.

Only a SIGINT that arrives before Python has run any polypack code (interpreter start-up,
``site``) is Python's own business: it dies of SIGINT or prints a KeyboardInterrupt there.
"""

from __future__ import annotations

import os
import sys

_state = {"armed": False, "said": False, "installed": False}


def _interrupted_line() -> str:
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
    _state["armed"] = False
    _state["said"] = True


def _exit_130():
    # os._exit: CPython kills itself with SIGINT at exit once a KeyboardInterrupt passed
    # through some C-level code (even if it was caught later); the exit code must be 130
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 - closed or broken stream (or a re-entrant flush)
            pass
    os._exit(130)


def _say_and_exit_130():
    if not _state["said"]:
        said_interrupted()
        line = _interrupted_line() + "\n"
        try:
            sys.stderr.flush()
        except Exception:  # noqa: BLE001
            pass
        try:
            os.write(2, line.encode(errors="replace"))
        except OSError:
            pass
    _exit_130()


def _on_sigint(signum, frame):
    if _state["said"]:  # the interrupted line is being written; exit 130 follows
        return
    if _state["armed"]:
        _state["armed"] = False  # one KeyboardInterrupt per process: a later Ctrl-C exits at once
        raise KeyboardInterrupt
    _say_and_exit_130()


def _ignore_sigint_at_exit():
    import signal

    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except (ValueError, OSError):  # pragma: no cover - not the main thread
        pass


def _install():
    """Make :func:`_on_sigint` the SIGINT handler of this process (idempotent)."""
    import signal

    try:
        signal.signal(signal.SIGINT, _on_sigint)  # also replaces an inherited SIG_IGN (see _restore_sigint)
    except (ValueError, OSError, AttributeError):  # not the main thread, or no signals here
        return
    if not _state["installed"]:
        import atexit

        _state["installed"] = True
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
        _install()


def _restore_sigint():
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


def main(argv=None):
    _install()  # (in place already when polypack/__init__ recognised this process)
    from .cli import main as cli_main  # a Ctrl-C here exits 130 at once: nothing started yet

    try:
        try:
            _state["armed"] = True
            rv = cli_main(argv)
        finally:
            _state["armed"] = False
    except KeyboardInterrupt:  # one that reached none of cli.main's handlers (e.g. in one of them)
        _say_and_exit_130()
    except SystemExit as exc:
        if exc.code == 130:
            _exit_130()
        raise
    return rv
