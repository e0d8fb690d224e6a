"""OpenDRIVE in, measured on the public roads of tests/scenario/opendrive_roads (ASAM's and esmini's
examples) and on simgap's own exported roads.

Per public road, with its route from routes.yaml:

    import      opendrive_network(file): the median wall time of 5 reads, the lanelets made, the
                successor relations (and those across roads or through junctions), the neighbour
                pairs, the file's lane links between lanes that became lanelets and how many were
                kept, the roads with a relief (elevation or superelevation)
    worlds      the commands a user types, each in its own process:
                    simgap generate ROAD.xodr --start S --goal G --out DIR
                    simgap run DIR/ROAD.xml --backend ideal|mujoco --json --out RUN
                the outcome, time to goal, solution validity and the command's wall time
    export      `simgap export DIR/ROAD.xml --format opendrive` (fitted: no blueprint), its time
                and fit, and the file read back: the largest distance of a lanelet's centre vertex
                from the read-back lanes' centres

Round trip: simgap's generated roads exported (exact) and read back, the largest Hausdorff distance
between a lanelet's centre line and its twin's.

    MUJOCO_GL=egl .venv/bin/python bench/export/opendrive_import.py [--json bench/results/opendrive_import.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import shapely
import yaml
from shapely.geometry import LineString, MultiLineString

from simgap.export.write import export_road
from simgap.files import BenchmarkResults
from simgap.scenario import build_scenario, load_scenario, write_scenario
from simgap.scenario.opendrive.network import OpenDriveNetwork, opendrive_network

ROADS = Path(__file__).resolve().parents[2] / "tests" / "scenario" / "opendrive_roads"
GENERATED = [("curve", {"radius": 20, "angle": 90}), ("curve", {"radius": 30, "angle": -60, "transition": 10,
                                                                "lanes": 2}),
             ("s-curve", {"radius": 25, "angle": 45}), ("t-junction", {}), ("intersection", {})]


def simgap(*args: str) -> tuple[subprocess.CompletedProcess, float, str]:
    """The command, run as a user runs it: its result, wall time and text."""
    command = ["simgap", *args]
    started = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "simgap", *args], capture_output=True, text=True,
                          env=dict(os.environ, COLUMNS="200"))
    return proc, time.perf_counter() - started, " ".join(command)


def topology(roads: OpenDriveNetwork) -> dict:
    network, places = roads.lanelets, roads.origin.lanelets
    successors = [(l.lanelet_id, s) for l in network.lanelets for s in l.successor]
    neighbours = {frozenset((l.lanelet_id, n)) for l in network.lanelets for n in (l.adj_left, l.adj_right)
                  if n is not None}
    return {"lanelets": len(network.lanelets), "roads": len(roads.document.roads),
            "junctions": len(roads.document.junctions),
            "successors": len(successors),
            "successors_across_roads": sum(places[a].road != places[b].road for a, b in successors),
            "neighbour_pairs": len(neighbours),
            "lane_links_in_file": roads.links.source, "lane_links_kept": roads.links.kept,
            "roads_with_relief": len(roads.origin.profiles)}


def public_road(name: str, route: dict, tmp: Path) -> dict:
    path = ROADS / name
    times = []
    for _ in range(5):
        started = time.perf_counter()
        roads = opendrive_network(path)
        times.append(time.perf_counter() - started)
    row = {"file": name, "bytes": path.stat().st_size, "start": route["start"], "goal": route["goal"],
           "import_s": round(statistics.median(times), 3), **topology(roads)}
    out = tmp / path.stem
    proc, seconds, command = simgap("generate", str(path), "--start", route["start"], "--goal", route["goal"],
                                    "--out", str(out / "scenario"))
    if proc.returncode != 0:
        return row | {"generate": {"command": command, "error": proc.stderr.strip()}}
    row["generate"] = {"command": command, "wall_s": round(seconds, 2)}
    xml = out / "scenario" / f"{path.stem}.xml"
    for backend in ("ideal", "mujoco"):
        proc, seconds, command = simgap("run", str(xml), "--backend", backend, "--json", "--out", str(out / backend))
        agent = json.loads(proc.stdout)["agents"][0] if proc.stdout.strip().startswith("{") else {}
        row[backend] = {"command": command, "outcome": agent.get("outcome", proc.stderr.strip()[-200:]),
                        "time_to_goal_s": agent.get("time_to_goal_s"), "solution_valid": agent.get("solution_valid"),
                        "wall_s": round(seconds, 2)}
    started = time.perf_counter()
    exported = export_road(xml, out / "export")
    seconds = time.perf_counter() - started
    scenario, _ = load_scenario(xml)
    back = MultiLineString([l.center_vertices for l in opendrive_network(exported.files[0]).lanelets.lanelets])
    worst = max(float(shapely.distance(back, shapely.points(l.center_vertices)).max())
                for l in scenario.lanelet_network.lanelets)
    row["export"] = {"command": f"simgap export {xml.name} --format opendrive --out DIR", "method": exported.method.value,
                     "export_s": round(seconds, 2), "fit_m": round(max(exported.fit_deviation_m.values()), 4),
                     "read_back_m": round(worst, 4)}
    return row


def round_trip(tmp: Path) -> list[dict]:
    rows = []
    for logical, parameters in GENERATED:
        concrete = build_scenario(logical, parameters)
        exported = export_road(write_scenario(concrete, tmp / "generated", preview=False), tmp / "generated_out")
        back = opendrive_network(exported.files[0]).lanelets
        worst = max(min(shapely.hausdorff_distance(LineString(l.center_vertices), LineString(b.center_vertices))
                        for b in back.lanelets) for l in concrete.scenario.lanelet_network.lanelets)
        rows.append({"scenario": concrete.name, "lanelets": len(concrete.scenario.lanelet_network.lanelets),
                     "read_back": len(back.lanelets), "hausdorff_m": round(worst, 4)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--json", help="write the results here")
    args = parser.parse_args()
    results_file = BenchmarkResults()
    routes = yaml.safe_load((ROADS / "routes.yaml").read_text())
    with tempfile.TemporaryDirectory() as tmp:
        rows = [public_road(name, route, Path(tmp)) for name, route in routes.items()]
        trips = round_trip(Path(tmp))
    print(f"{'road':<52} {'import [s]':>10} {'lanelets':>8} {'succ (across)':>13} {'nbrs':>5} {'links kept':>10} "
          f"{'ideal':>12} {'mujoco':>12} {'export [s]':>10} {'read back [m]':>13}")
    for r in rows:
        def world(b, r=r):
            if b not in r:
                return "—"
            reached = r[b]["time_to_goal_s"]
            return f"goal {reached:4.1f} s" if reached is not None else r[b]["outcome"]
        print(f"{r['file']:<52} {r['import_s']:>10.3f} {r['lanelets']:>8} "
              f"{r['successors']:>6} ({r['successors_across_roads']:>3}) {r['neighbour_pairs']:>6} "
              f"{r['lane_links_kept']:>4}/{r['lane_links_in_file']:<5} {world('ideal'):>12} {world('mujoco'):>12} "
              f"{r.get('export', {}).get('export_s', 0):>10.2f} {r.get('export', {}).get('read_back_m', 0):>13.4f}")
    print("\nround trip (export, read back):")
    for t in trips:
        print(f"  {t['scenario']:<48} {t['lanelets']:>3} lanelets, {t['read_back']:>3} read back, "
              f"centre lines within {t['hausdorff_m']:.4f} m")
    if args.json:
        results_file.write(args.json, {"roads": rows, "round_trip": trips})


if __name__ == "__main__":
    main()
