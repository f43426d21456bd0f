"""Console entry point (``polypack``, ``python -m polypack``): a Ctrl-C at any moment of the
process exits 130 with one line (or, once the command is over, is ignored), never a traceback.

The process's SIGINT handler and its state live in :mod:`polypack._interrupt` (the package
root installs it before numpy, :func:`polypack._interrupt.guard_cli_process`); this module
only runs the command with it armed. Nothing in polypack imports this module (the console
script and ``python -m polypack`` do), so it may import the CLI without an import cycle.
"""

from __future__ import annotations

from . import _interrupt as _i


def main(argv=None):
    _i.install_cli_handler()  # (in place already when polypack/__init__ recognised this process)
    from .cli import main as cli_main  # a Ctrl-C here exits 130 at once: nothing started yet

    try:
        try:
            _i.arm(True)
            rv = cli_main(argv)
        finally:
            _i.arm(False)
    except KeyboardInterrupt:  # one that reached none of cli.main's handlers (e.g. in one of them)
        _i.say_and_exit_130()
    except SystemExit as exc:
        if exc.code == 130:
            _i.exit_130()
        raise
    return rv
