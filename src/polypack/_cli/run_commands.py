"""``polypack run``: a study file through size distribution -> packing -> analyses, P realizations."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command("run")
    def run(
        study: Path = typer.Argument(..., help="Study file (TOML) with tables study, psd, protocol, analysis.*, output (see docs/run.md)."),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="Output folder (default: out/<study name>)."),
        workers: int = typer.Option(1, "--workers", "-j", min=1, help="Worker processes (1: serial, in-process)."),
        scheduler: Optional[str] = typer.Option(
            None, "--scheduler", help="Dask scheduler address (tcp://host:8786) of an existing cluster."
        ),
        dask: bool = typer.Option(False, "--dask", help="Run on a local Dask cluster with --workers workers."),
        check: bool = typer.Option(False, "--check", help="Only validate the study file and print it resolved."),
        force: bool = typer.Option(False, "--force", help="Recompute in an --out folder holding a different study."),
        wait: float = typer.Option(0.0, "--wait", min=0.0, help="Seconds to wait for another run that owns --out."),
        progress: Optional[bool] = typer.Option(
            None, "--progress/--no-progress", help="Progress bar (default: on a terminal)."
        ),
        report: bool = typer.Option(True, "--report/--no-report", help="Write OUT/report.html (3D viewer, tables, "
                                    "figures; with [output] plots also OUT/figures/)."),
    ):
        """Run a study: P seeded realizations, one GSD + record each, ensemble curves, summary table, plots.

        Rerunning the same command resumes: realizations whose GSD and record exist
        and whose checksum matches are kept, the others are computed.
        """
        from ..errors import InvalidInputError
        from ..study import load_study

        from ..ensemble.sweep import has_sweep

        if has_sweep(study):  # a [sweep] table: one study per value, then its report (docs/run.md)
            _run_sweep(study, out, workers, scheduler, dask, check, force, wait, progress, report)
            return
        st = load_study(study)
        if check:
            from ..ensemble.stages import check_available, child_seed_records, preflight

            check_available(st.data)
            preflight(st.data, child_seed_records(st.seed, 1)[0])
            typer.echo(f"# {study}: valid; fingerprint {st.fingerprint}")
            typer.echo(st.to_toml(), nl=False)
            return
        if scheduler and dask:
            raise InvalidInputError("--scheduler and --dask: give one (--scheduler uses an existing cluster)")
        from ..ensemble import dask_executor, run_study

        out_dir = out if out is not None else Path("out") / st.name
        try:
            if scheduler or dask:
                with dask_executor(address=scheduler, n_workers=workers) as ex:
                    res = run_study(st, out_dir, executor=ex, force=force, progress=progress, wait=wait)
            else:
                res = run_study(st, out_dir, workers=workers, force=force, progress=progress, wait=wait)
        except KeyboardInterrupt:
            done = len(list((out_dir / "realizations").glob("r*.json")))
            typer.echo(
                f"interrupted: {done} of {st.realizations} realization(s) are saved in {out_dir}; "
                "rerun the same command to resume",
                err=True,
            )
            raise SystemExit(130) from None
        typer.echo(res.summary())
        if report:
            from ..report import report as write_report

            plots = bool(st.data["output"]["plots"])
            path = write_report(out_dir, out_dir / "report.html", plots_dir=(out_dir / "figures") if plots else None,
                                formats=(st.data["output"]["plot_format"],) if plots else ())
            typer.echo(f"  {'report':<20s} {path}")


def _run_sweep(study, out, workers, scheduler, dask, check, force, wait, progress, report=True):
    from ..errors import InvalidInputError
    from ..ensemble.sweep import run_sweep, sweep_plan

    sw, plan, name = sweep_plan(study)
    if check:
        from ..ensemble.stages import check_available, child_seed_records, preflight

        for e in plan:
            try:
                check_available(e.study.data)
                preflight(e.study.data, child_seed_records(e.study.seed, 1)[0])
            except InvalidInputError as exc:
                where = "sweep" if e.set is None else f'sweep.set "{e.set}"'
                raise InvalidInputError(f"{where} value {e.value!r}: {exc}") from None
        if sw["sets"] is None:
            typer.echo(f"# {study}: valid sweep over {len(plan)} values of {sw['parameter']}: "
                       f"{', '.join(repr(e.value) for e in plan)}")
        else:
            typer.echo(f"# {study}: valid sweep of {len(sw['sets'])} sets, {len(plan)} values in all")
            for s in sw["sets"]:
                nd = s.get("dynamic_realizations")
                on = "every realization" if nd is None else "realization 0" if nd == 1 else f"realizations 0..{nd - 1}"
                dyn = (f"; dynamic G'p at {', '.join(repr(v) for v in s['dynamic'])} ({on})"
                       if s["dynamic"] else "")
                typer.echo(f"#   {s['name']}: {s['parameter']} = {', '.join(repr(v) for v in s['values'])}{dyn}")
        return
    if scheduler and dask:
        raise InvalidInputError("--scheduler and --dask: give one (--scheduler uses an existing cluster)")
    try:
        if scheduler or dask:
            from ..ensemble import dask_executor

            with dask_executor(address=scheduler, n_workers=workers) as ex:
                run_sweep(study, out, executor=ex, force=force, progress=progress, wait=wait, echo=typer.echo)
        else:
            run_sweep(study, out, workers=workers, force=force, progress=progress, wait=wait, echo=typer.echo)
    except KeyboardInterrupt:
        typer.echo("interrupted: finished realizations are saved; rerun the same command to resume", err=True)
        raise SystemExit(130) from None
    if report:  # each value's run report, then OUT/report.html linking them (with the heterogeneity outputs)
        from ..report import report as write_report
        from ..report.build import sweep_report

        out_dir = Path(out) if out is not None else Path("out") / name
        entries = []
        for e in plan:
            sub = out_dir / e.rel
            plots = bool(e.study.data["output"]["plots"])
            write_report(sub, sub / "report.html", plots_dir=(sub / "figures") if plots else None,
                         formats=(e.study.data["output"]["plot_format"],) if plots else ())
            entries.append((e.value if e.set is None else e.text, sub))
        path = sweep_report(out_dir, entries, title=name)
        typer.echo(f"  {'report':<20s} {path}")
