"""Command-line interface: ``polypack COMMAND ...``.

Commands live in modules of :mod:`polypack._cli`; each defines ``register(app)``
and is discovered automatically, so adding a command never edits this file.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys
import time
from typing import Optional

import typer

from ._version import __version__
from .errors import PolypackError

app = typer.Typer(
    name="polypack",
    help="Exact random packs of polydisperse spheres: size distributions, packing, shaking, statistics.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version_callback(value: bool):
    if value:
        typer.echo(f"polypack {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Optional[bool] = typer.Option(
        None, "--version", callback=_version_callback, is_eager=True, help="Print the version and exit."
    ),
):
    """polypack command line."""


@app.command()
def warmup():
    """Compile every numba kernel once (later runs start instantly) and report the time."""
    from . import _kernels

    t0 = time.perf_counter()
    names = []
    for mod in pkgutil.iter_modules(_kernels.__path__):
        m = importlib.import_module(f"{_kernels.__name__}.{mod.name}")
        fn = getattr(m, "warmup", None)
        if fn is not None:
            t = time.perf_counter()
            fn()
            names.append((mod.name, time.perf_counter() - t))
    for name, dt in names:
        typer.echo(f"  {name:<20s} {dt:7.2f} s")
    typer.echo(f"compiled {len(names)} kernel modules in {time.perf_counter() - t0:.2f} s")


def _register_commands():
    from . import _cli

    for mod in sorted(pkgutil.iter_modules(_cli.__path__), key=lambda m: m.name):
        m = importlib.import_module(f"{_cli.__name__}.{mod.name}")
        reg = getattr(m, "register", None)
        if reg is not None:
            reg(app)
    from ._cli._generated import register_generated

    register_generated(app)  # every protocol and mechanics stage without a hand-written command


_register_commands()


def _click_exception_types():
    """Usage-error and abort classes of click and of typer's vendored copy (typer >= 0.29
    no longer depends on click), whichever are installed."""
    import importlib

    errors, aborts = [], []
    for name in ("click.exceptions", "typer._click.exceptions"):
        try:
            mod = importlib.import_module(name)
        except ImportError:
            continue
        errors.append(mod.ClickException)
        if hasattr(mod, "Abort"):  # not in typer's vendored copy
            aborts.append(mod.Abort)
    return tuple(errors), tuple(aborts)


def _interrupted():
    """Ctrl-C: one line naming what this command saved, exit code 130."""
    from ._interrupt import interrupted_line, said_interrupted

    said_interrupted()  # in the CLI's process a further Ctrl-C is ignored until the exit
    typer.echo(interrupted_line(), err=True)
    sys.exit(130)


def main(argv=None):
    """Entry point: polypack errors become one-line messages and exit code 1; Ctrl-C exits 130.

    A command that saves something on Ctrl-C (``run``, ``pack --checkpoint``) says what
    itself; otherwise the line names the files completed before the interrupt (writes
    are atomic: nothing half-written is ever left under a requested name).
    """
    from . import _interrupt, _util

    _interrupt.restore_sigint()  # SIGINT works for a command started in the background too
    _util._WRITTEN.clear()
    try:
        # The whole command runs with Ctrl-C deferred to its safe points (kernel chunks,
        # global shakes, stages, realizations, analyses): a KeyboardInterrupt raised at
        # a random bytecode (inside a numba result, a finaliser, a half-written record)
        # could be lost or leave a traceback; a second Ctrl-C stops at once.
        with _interrupt.deferred():
            rv = app(args=argv, standalone_mode=False)
    except PolypackError as exc:
        typer.echo(f"error: {exc}", err=True)
        sys.exit(1)
    except KeyboardInterrupt:
        _interrupted()
    except SystemExit:
        raise
    except Exception as exc:  # click usage errors and friends
        if _interrupt.is_interrupt(exc):  # e.g. numba's SystemError while a Ctrl-C is delivered
            _interrupted()
        click_errors, aborts = _click_exception_types()
        if isinstance(exc, click_errors):
            exc.show()
            sys.exit(exc.exit_code)
        if isinstance(exc, aborts):
            typer.echo("aborted", err=True)
            sys.exit(1)
        raise
    if rv == 130:  # typer turns a KeyboardInterrupt inside a command into exit code 130
        _interrupted()
    if isinstance(rv, int) and not isinstance(rv, bool) and rv != 0:
        sys.exit(rv)
    return 0


if __name__ == "__main__":  # pragma: no cover
    main()
