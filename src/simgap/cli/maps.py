"""`simgap maps`: the real road networks installed with simgap, each with a start and a goal to
drive it from the command line."""

from __future__ import annotations

import time

from rich.markup import escape
from rich.table import Table

from simgap.cli.console import output_console
from simgap.cli.main import app


@app.command("maps")
def maps_cmd() -> None:
    """List the installed real maps (CommonRoad lanelet networks of recording sites) with their
    extent and a start and goal to drive each one.

    \b
    Example: simgap maps
    then: simgap run MAP.xml --start X,Y --goal X,Y --out runs/map
    """
    from simgap.scenario.real_maps import MAPS_PACKAGE, example_places, load_map, map_files, maps_dir

    console = output_console()
    files = map_files()
    if not files:
        console.print(f"no real maps in {escape(str(maps_dir()))}: `make install` puts them there (from "
                      f"{MAPS_PACKAGE}), or `python -m simgap.scenario.real_maps`; SIMGAP_REAL_MAPS points elsewhere")
        return
    started = time.perf_counter()
    table = Table(title=f"real maps in {maps_dir()}", title_justify="left")
    for col in ("map", "extent [m]", "a start and a goal"):
        table.add_column(escape(col), no_wrap=True)
    first = None
    for path in files:
        network = load_map(path).lanelet_network
        xs = [float(p[0]) for lanelet in network.lanelets for vs in (lanelet.left_vertices, lanelet.right_vertices)
              for p in vs]
        ys = [float(p[1]) for lanelet in network.lanelets for vs in (lanelet.left_vertices, lanelet.right_vertices)
              for p in vs]
        places = example_places(network)
        example = "—" if places is None else \
            f"--start {places[0][0]:.1f},{places[0][1]:.1f}\n--goal {places[1][0]:.1f},{places[1][1]:.1f}"
        if first is None and places is not None:
            first = (path, example.replace("\n", " "))
        table.add_row(f"{path.stem}\n{len(network.lanelets)} lanelets",
                      f"x {min(xs):.0f} … {max(xs):.0f}\ny {min(ys):.0f} … {max(ys):.0f}" if xs else "—", example)
    console.print(table)
    console.print(f"{len(files)} maps ({time.perf_counter() - started:.1f} s); lanelet networks of the "
                  f"{MAPS_PACKAGE.split('==')[0]} package (BSD-3-Clause)")
    if first is not None:
        console.print(f"drive one: simgap run {escape(str(first[0]))} {first[1]} --out runs/{first[0].stem}")
