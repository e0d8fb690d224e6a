"""`simgap generate`: concrete CommonRoad scenarios from a logical scenario."""

from __future__ import annotations

import time
from pathlib import Path

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from simgap.cli.console import ProgressBars, output_console
from simgap.cli.main import app
from simgap.cli.outputs import OVERWRITE_HELP, files_out
from simgap.errors import InputError
from simgap.files import writable_directory
from simgap.scenario import builtin_names, load_logical, write_scenario


def _parse_sets(items: list[str]) -> dict[str, str]:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise InputError(f"'{item}' is not NAME=VALUE", field="--set", allowed="e.g. --set radius=10")
        out[name.strip()] = value.strip()
    return out


@app.command()
def generate(
    logical: str | None = typer.Argument(None, help="built-in logical scenario name, a YAML file, or an "
                                                    "OpenDRIVE road (.xodr, with --start and --goal)"),
    out: Path | None = typer.Option(None, "--out", "-o", help="directory for the XML, JSON and PNG files",
                                       callback=writable_directory),
    set_: list[str] = typer.Option([], "--set", help="pin a parameter: NAME=VALUE (repeatable); on an OpenDRIVE "
                                   "road: initial_speed (m/s), time_limit (s), dt (s)"),
    start: str | None = typer.Option(None, "--start", help="OpenDRIVE road: where the agent starts, "
                                        "ROAD:LANE:S (road id, lane id, station along the road in m) or X,Y"),
    goal: str | None = typer.Option(None, "--goal", help="OpenDRIVE road: the centre of the goal area, "
                                       "ROAD:LANE:S or X,Y (ahead of the start along the lanes' links)"),
    preview: bool = typer.Option(True, "--preview/--no-preview", help="write a PNG preview per scenario"),
    overwrite: bool = typer.Option(False, "--overwrite", help=OVERWRITE_HELP),
    list_: bool = typer.Option(False, "--list", help="list the built-in logical scenarios and their parameters"),
) -> None:
    """Generate one CommonRoad scenario per parameter combination (full grid).

    Example: simgap generate curve --set radius=10 --set angle=90 --out scenarios/
    (an OpenDRIVE road: simgap generate road.xodr --start 2:-2:30 --goal 4:1:80 --out scenarios/)
    """
    console = output_console()
    if list_:
        _print_builtins(console)
        return
    if logical is not None and logical.endswith(".xodr"):
        _from_opendrive(console, Path(logical), start, goal, _parse_sets(set_), out, preview, overwrite)
        return
    if start is not None or goal is not None:
        raise InputError("--start and --goal place an agent on an OpenDRIVE road",
                         field="--start" if start is not None else "--goal",
                         allowed="a .xodr file as LOGICAL (a logical scenario places its agents itself)")
    if logical is None or out is None:
        raise InputError("LOGICAL and --out are required (or use --list)", field="LOGICAL",
                         allowed=", ".join(builtin_names()) + ", or a .yaml path")
    spec = load_logical(logical)
    pins = spec.pinned(_parse_sets(set_))
    combos = list(spec.grid(pins))
    written: list[Path] = []
    warned: set[str] = set()
    where = logical if logical.endswith((".yaml", ".yml")) else None
    with (files_out(out, "generate", _scenario_files([spec.scenario_name(p) for p in combos], preview), overwrite),
          ProgressBars(shown=len(combos) > 4) as bars):
        for params in combos:
            try:
                concrete = spec.build(params)
            except InputError as err:       # a template's bound: name the logical scenario's file
                if err.file is None and where is not None:
                    raise InputError(err.reason, file=where, field=err.field, allowed=err.allowed) from None
                raise
            _warn(concrete.warnings, warned)
            written.append(write_scenario(concrete, out, preview=preview))
            bars.update(f"generating {spec.name}", len(written), len(combos))
    console.print(f"wrote {len(written)} scenario{'s' * (len(written) != 1)} of '{spec.name}' to [bold]{out}[/bold]")
    for path in written[:5]:
        console.print(f"  {path.name}")
    if len(written) > 5:
        console.print(f"  … and {len(written) - 5} more")


def _scenario_files(names: list[str], preview: bool) -> list[str]:
    """The files `write_scenario` writes of scenarios ``names``."""
    return [f"{name}{suffix}" for name in names for suffix in (".xml", ".json") + ((".png",) if preview else ())]


def _from_opendrive(console: Console, road: Path, start: str | None, goal: str | None, pins: dict[str, str],
                    out: Path | None, preview: bool, overwrite: bool) -> None:
    """One scenario on an OpenDRIVE road: its lanelets, one agent from ``start`` to ``goal``."""
    from simgap.scenario.opendrive.scenario import PLACE_FORMS, opendrive_scenario

    for option, value in (("--start", start), ("--goal", goal), ("--out", out)):
        if value is None:
            raise InputError(f"an OpenDRIVE road needs {option}", field=option,
                             allowed=PLACE_FORMS if option != "--out" else "a directory to write into")
    assert start is not None and goal is not None and out is not None       # each refused above when missing
    started = time.perf_counter()
    concrete = opendrive_scenario(road, start, goal, pins)
    _warn(concrete.warnings, set())
    with files_out(out, "generate", _scenario_files([concrete.name], preview), overwrite):
        xml = write_scenario(concrete, out, preview=preview)
    problem = next(iter(concrete.problems.planning_problem_dict.values()))
    origin = concrete.opendrive
    assert origin is not None, "a scenario on an OpenDRIVE road keeps its origin"
    console.print(f"wrote [bold]{xml}[/bold]: {len(origin.lanelets)} lanelets from {road.name} "
                  f"({time.perf_counter() - started:.2f} s), one agent from "
                  f"({problem.initial_state.position[0]:.1f}, {problem.initial_state.position[1]:.1f})")


def _warn(warnings: tuple[str, ...], said: set[str]) -> None:
    """Each warning not ``said`` yet, one line on stderr."""
    console = output_console(stderr=True)
    for text in warnings:
        if text not in said:
            said.add(text)
            console.print(f"[yellow]warning[/yellow]: {escape(text)}")


def _print_builtins(console: Console) -> None:
    for name in builtin_names():
        spec = load_logical(name)
        table = Table(title=f"{name} — {spec.description.strip()}", title_justify="left", title_style="bold")
        for col in ("parameter", "unit", "range", "default", "grid values", "meaning"):
            table.add_column(col)
        for pname, par in spec.parameters.items():
            span = par.span()
            table.add_row(pname, par.unit, f"{par.min:g} … {par.max:g}", f"{par.default:g}",
                          ", ".join(f"{v:g}" for v in span) if len(span) > 1 else "—", par.description)
        console.print(table)
        console.print(f"  {len(list(spec.grid()))} scenarios in the full grid\n")
