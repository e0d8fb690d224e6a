"""`simgap export`: runs, scenarios and search findings as OpenSCENARIO and OpenDRIVE files; a run as a
rerun recording."""

from __future__ import annotations

import json
import shutil
from enum import StrEnum
from pathlib import Path

import typer
from rich.console import Console

from simgap.cli.console import ProgressBars, output_console, print_notes
from simgap.cli.main import app
from simgap.cli.outputs import OVERWRITE_HELP, files_out, record_files
from simgap.errors import InputError
from simgap.files import writable_directory

RECORDING_SUFFIX = ".rrd"


class Format(StrEnum):
    OPENSCENARIO = "openscenario"
    OPENDRIVE = "opendrive"
    RERUN = "rerun"


def _writable_out(path: Path | None) -> Path | None:
    """``--out``: a directory simgap can write in, or a rerun recording's ``.rrd`` file in one."""
    if path is None or path.suffix != RECORDING_SUFFIX:
        return writable_directory(path)
    if path.is_dir():
        raise InputError("is a directory", file=path, field="--out",
                         allowed=f"a {RECORDING_SUFFIX} file to write, or a directory without that suffix")
    writable_directory(path.parent)
    return path


@app.command("export")
def export_cmd(
    source: Path = typer.Argument(..., help="a run directory, a CommonRoad scenario (.xml), or with --violations "
                                            "a search directory"),
    out: Path = typer.Option(..., "--out", "-o", help="directory to write into (rerun: or the .rrd file)",
                             callback=_writable_out),
    format: str | None = typer.Option(None, "--format", "-f",
                                         help="openscenario (a run: .xosc + .xodr), opendrive (a scenario's "
                                              "road: .xodr) or rerun (a run: .rrd, for rerun's viewer); "
                                              "default: by SOURCE, rerun for an --out ending in .rrd"),
    ideal: Path | None = typer.Option(None, "--ideal", help="rerun: a run of the same scenario drawn beside "
                                                               "as its ideal twin"),
    violations: bool = typer.Option(False, "--violations", help="SOURCE is a search: a folder per distinct violation"),
    version: str | None = typer.Option(None, "--version", help="OpenSCENARIO version: 1.2 (default: every rule of ASAM's "
                                                         "Quality Checker applies), 1.0 (CARLA's ScenarioRunner), "
                                                         "1.1 or 1.3"),
    overwrite: bool = typer.Option(False, "--overwrite", help=OVERWRITE_HELP),
) -> None:
    """Write a run, a scenario's road or a search's findings in the formats other simulators read.

    Every file is checked before it is moved into place: it validates against the schema of the
    version it declares, trajectories parse back to within 1 cm, and the road's lane centres lie
    where the lanelets are. Examples:
    simgap export runs/c10 --format openscenario --out exported;
    simgap export runs/c10 --format rerun --out c10.rrd (open it with: rerun c10.rrd);
    simgap export scenarios/curve_radius-10_angle-90.xml --format opendrive --out exported;
    simgap export studies/gaps --violations --out findings
    """
    from simgap.export.openscenario import DEFAULT_VERSION, OpenScenarioVersion

    osc_version = OpenScenarioVersion.parse(version) if version is not None else DEFAULT_VERSION
    chosen = None
    if format is not None:
        try:
            chosen = Format(format)
        except ValueError:
            raise InputError(f"unknown format '{format}'", field="--format",
                             allowed=", ".join(f.value for f in Format)) from None
    elif out.suffix == RECORDING_SUFFIX:
        chosen = Format.RERUN
    if out.suffix == RECORDING_SUFFIX and chosen is not None and chosen is not Format.RERUN:
        raise InputError(f"a {RECORDING_SUFFIX} file is a rerun recording", field="--out",
                         allowed=f"a directory for {chosen.value}, or --format rerun")
    if ideal is not None and chosen is not Format.RERUN:
        raise InputError("an ideal twin is drawn in a rerun recording only", field="--ideal", allowed="--format rerun")
    console = output_console()
    if not source.exists():
        raise InputError("no such file or directory", file=source,
                         allowed="a run directory, a .xml scenario, or a search directory with --violations")
    if chosen is Format.RERUN and (violations or not (source / "run.json").is_file()):
        raise InputError("a rerun recording is of one run", file=source, field="--format",
                         allowed="a run directory (with run.json) for rerun; openscenario or opendrive otherwise")
    if ideal is not None and not ideal.exists():
        raise InputError("no such file or directory", file=ideal, field="--ideal", allowed="a run directory")
    if chosen is Format.RERUN:
        from simgap.export.rerun_recording import export_recording

        _show_recording(console, export_recording(source, out, ideal))
        return
    if violations:
        if chosen is Format.OPENDRIVE:
            raise InputError("a search's findings are runs: they export as openscenario", field="--format",
                             allowed="openscenario")
        with files_out(out, "export", [], overwrite), ProgressBars() as bars:
            exports = _violations(source, out, osc_version, bars)
        _show_violations(console, source, exports)
        record_files(out, "export", [p.parent.name for e in exports for p in e.files])
        return
    if (source / "run.json").is_file():
        if chosen is Format.OPENDRIVE:
            raise InputError("a run exports as openscenario (its .xosc with its road's .xodr beside it)",
                             file=source, field="--format", allowed="openscenario")
        from simgap.export.write import export_run

        with files_out(out, "export", [], overwrite), ProgressBars() as bars:
            exported = export_run(source, out, osc_version, on_progress=bars.update)
        record_files(out, "export", [p.name for p in exported.files])
        _show(console, [exported])
    elif source.is_file() and source.suffix == ".xml":
        if chosen is Format.OPENSCENARIO:
            raise InputError("a scenario file exports its road; OpenSCENARIO needs a run of it", file=source,
                             field="--format", allowed="opendrive (or give a run directory)")
        from simgap.export.write import export_road

        with files_out(out, "export", [], overwrite), ProgressBars() as bars:
            exported = export_road(source, out, on_progress=bars.update)
        record_files(out, "export", [p.name for p in exported.files])
        _show(console, [exported])
    else:
        raise InputError("not a run directory (no run.json) nor a CommonRoad scenario file", file=source,
                         allowed="a run directory, a .xml scenario, or a search directory with --violations")


def _violations(search_dir: Path, out: Path, version, bars: ProgressBars) -> list:
    """One folder per distinct violation: its high-fidelity run as .xosc + .xodr, the CommonRoad
    scenario and violation.json (what made it one); each folder built aside, then moved in."""
    from simgap.experiment.search.results import search_results
    from simgap.export.write import export_run
    from simgap.files import replace_directory

    results = search_results(search_dir)
    found = [v for strategy in results.strategies for v in strategy.found]
    exports = []
    bars.update("violations", 0, len(found))
    for v in found:
        folder = f"{v.strategy}_{v.scenario}"

        def write(staged: Path, v=v, folder=folder) -> None:
            exports.append(export_run(v.run_dir, staged, version, scenario_xml=v.scenario_xml, name=folder,
                                      on_progress=bars.update))
            if v.scenario_xml is not None:
                shutil.copyfile(v.scenario_xml, staged / f"{folder}.xml")
            facts = v.facts(results.spec) | {"run_dir": str(v.run_dir), "files": sorted(p.name for p in staged.iterdir())
                                             + ["violation.json"]}
            (staged / "violation.json").write_text(json.dumps(facts, indent=2))

        replace_directory(out / folder, write)
        exports[-1].files = [out / folder / p.name for p in exports[-1].files]
        bars.update("violations", len(exports), len(found))
    return exports


def _show_violations(console: Console, search_dir: Path, exports: list) -> None:
    console.print(f"{len(exports)} distinct violation{'s' if len(exports) != 1 else ''} in {search_dir}")
    if exports:
        _show(console, exports)


def _show_recording(console: Console, recording) -> None:
    """The recording written: what it holds, its size and time, and how to open it."""
    twin = {k: n for k, n in recording.driven_poses.items() if k.startswith("world/ideal/")}
    cars = len(recording.driven_poses) - len(twin)
    poses = sum(recording.driven_poses.values()) - sum(twin.values())
    what = f"{cars} road user{'s' if cars != 1 else ''} with {poses} driven poses"
    if twin:
        what += f", the ideal twin's {len(twin)} with {sum(twin.values())}"
    console.print(f"[bold]{recording.name}[/bold]: rerun recording, {len(recording.entities)} entities, {what} "
                  f"({recording.seconds:.2f} s)")
    console.print(f"  {recording.path}  {recording.path.stat().st_size / 1e6:.2f} MB; open it with: "
                  f"rerun {recording.path}", soft_wrap=True)
    print_notes(console, recording.notes)


def _show(console: Console, exports) -> None:
    """Each export: the files, what their checks measured, and its time."""
    for e in exports:
        roads = len(e.lane_deviation_m)
        what = f"{e.method.value} road network, {roads} road{'s' if roads != 1 else ''}"
        if e.entities:
            what += f", {e.entities} entit{'ies' if e.entities != 1 else 'y'}"
        console.print(f"[bold]{e.name}[/bold]: {what} ({e.seconds:.2f} s)")
        for path in e.files:
            line = f"  {path}  valid against {e.schemas[path.name]}"
            if path.suffix == ".xodr":
                line += (f"; lane centres within {e.largest_deviation_m:.4f} m of the lanelets' centres (99 % within "
                         f"{e.lane_deviation_p99_m:.4f} m)")
                if e.links is not None:
                    line += (f"; {e.links.successors_kept} of {e.links.successors} successor and "
                             f"{e.links.neighbours_kept} of {e.links.neighbours} neighbour relations kept, "
                             f"{e.links.junctions} junction{'s' if e.links.junctions != 1 else ''}")
            elif e.trajectory_error_m is not None:
                line += f"; every trajectory vertex parses back within {e.trajectory_error_m:.1e} m"
            console.print(line, soft_wrap=True)
    print_notes(console, [n for e in exports for n in e.notes])
