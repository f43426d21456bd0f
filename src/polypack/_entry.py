"""Console entry point (``polypack``, ``python -m polypack``): a Ctrl-C while the CLI's
modules are still being imported exits 130 with one line, like one during a command."""

from __future__ import annotations

import sys


def main(argv=None):
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt:
        sys.stderr.write("interrupted: nothing was saved\n")
        sys.exit(130)
    return cli_main(argv)
