"""Console entry point (``polypack``, ``python -m polypack``): a Ctrl-C while the CLI's
modules are still being imported exits 130 with one line, like one during a command."""

from __future__ import annotations

import os
import sys


def _exit_130():
    # os._exit: CPython kills itself with SIGINT at exit once a KeyboardInterrupt passed
    # through some C-level code (even if it was caught later); the exit code must be 130
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:  # noqa: BLE001 - closed or broken stream
            pass
    os._exit(130)


def main(argv=None):
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt:
        sys.stderr.write("interrupted: nothing was saved\n")
        _exit_130()
    try:
        return cli_main(argv)
    except SystemExit as exc:
        if exc.code == 130:
            _exit_130()
        raise
