"""``polypack report`` (self-contained HTML report of a pack or a run folder) and ``polypack view``."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer


def _fields(specs):
    """``NAME=FILE`` options: one number per sphere from a ``.npy`` or a text file (one per line)."""
    import numpy as np

    from ..errors import InvalidInputError

    out = {}
    for spec in specs or ():
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            raise InvalidInputError(f"--field {spec!r}: expected NAME=FILE (a .npy file or one number per line)")
        try:
            vals = np.load(path) if path.endswith(".npy") else np.loadtxt(path, ndmin=1)
        except (OSError, ValueError) as exc:
            raise InvalidInputError(f"--field {name}={path}: cannot be read ({str(exc).splitlines()[0]})") from None
        out[name] = np.asarray(vals).ravel()
    return out


def _formats(text):
    return tuple(f.strip() for f in text.split(",") if f.strip()) if text else ()


def register(app: typer.Typer) -> None:
    @app.command("report")
    def report_cmd(
        source: Path = typer.Argument(..., help="A pack file (GSD, XYZ, LAMMPS data, CSV) or a polypack run folder."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="HTML file (default: RUN/report.html or PACK.html)."),
        color: Optional[str] = typer.Option(None, "--color", help="Initial colour of the viewer: species, radius, "
                                            "coordination or a --field name."),
        theory: bool = typer.Option(False, "--theory", help="Draw the analytic partial RDFs of seed 000 §5 "
                                    "(Eqs. 19-22) beside the measured ones."),
        compare: Optional[List[Path]] = typer.Option(None, "--compare", help="Another run folder whose curves are "
                                                     "overlaid (e.g. CRM beside SCRM); repeatable."),
        plots: Optional[Path] = typer.Option(None, "--plots", help="Also write the figures as files into this folder."),
        plot_format: str = typer.Option("png,svg", "--plot-format", help="Formats of --plots: png, svg, pdf "
                                        "(comma separated)."),
        tolerance: Optional[float] = typer.Option(None, "--tolerance", help="Relative gap below which two spheres "
                                                  "touch, for the coordination colours (default: the run's, or 0.01)."),
        field: Optional[List[str]] = typer.Option(None, "--field", help="NAME=FILE: a per-particle colour field "
                                                  "(one number per sphere, .npy or text) of a pack file; repeatable."),
        force: bool = typer.Option(False, "--force", help="Replace an existing -o file of another kind."),
    ):
        """Write one self-contained HTML report (3D viewer, tables, figures); nothing is fetched when viewing it."""
        from .._util import check_new_output
        from ..report import report

        if out is not None:
            check_new_output(out, "HTML", inputs=(source, *(compare or ())), force=force)

        path = report(source, out, color=color, theory=theory, compare=tuple(compare or ()), plots_dir=plots,
                      formats=_formats(plot_format) if plots else (), fields=_fields(field), tolerance=tolerance)
        typer.echo(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")

    @app.command("view")
    def view_cmd(
        file: Path = typer.Argument(..., help="A pack file (GSD, XYZ, LAMMPS data, CSV)."),
        color: str = typer.Option("species", "--color", help="Initial colour: species, radius, coordination or a "
                                  "--field name."),
        field: Optional[List[str]] = typer.Option(None, "--field", help="NAME=FILE: a per-particle colour field; "
                                                  "repeatable."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Write the page here instead of a temporary file."),
        browser: bool = typer.Option(True, "--browser/--no-browser", help="Open the page in the web browser."),
        force: bool = typer.Option(False, "--force", help="Replace an existing -o file of another kind."),
    ):
        """Open the 3D viewer of one pack in the web browser (the page is written to a temporary file)."""
        from .._util import check_new_output
        from ..report.build import _read_pack

        if out is not None:
            check_new_output(out, "HTML", inputs=(file,), force=force)
        from ..report.viewer import view

        pk = _read_pack(file)
        v = view(pk, color=color, fields=_fields(field), title=f"polypack view: {file.name}")
        path = v.show(out, browser=browser)
        typer.echo(f"wrote {path}")
