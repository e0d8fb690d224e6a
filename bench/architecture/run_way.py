"""A run request's way through the packages: which of simgap's packages one run enters, and when —
before its co-simulation loop starts, while it runs, after it ends — how often it reads the scenario
(its CommonRoad XML and sidecar) or makes what the run needs of it (its recorded obstacles, ground
and drivable area), and how many calls write the run directory.

A call counts as an entry into a package when its caller is in another package (calls inside a
package are its own business). The run is `simgap run`'s code path (`execute(RunRequest(...))`),
traced with ``sys.setprofile``; its wall time is measured again untraced. The scenarios are a
generated 3D road (the built-in ``curve-3d``, 5 % grade, 4° bank) and, with ``--files``, recorded CommonRoad files.

    python bench/architecture/run_way.py [--worlds ideal mujoco] [--files DIR ...] [--json FILE]

It compares nothing: run it before and after a change to the run's wiring (issue 55, item 9).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path
from types import FrameType
from typing import Any

from simgap.experiment.single_run import RunRequest, execute
from simgap.files import BenchmarkResults
from simgap.scenario import build_scenario, write_scenario

PHASES = ("before the loop", "in the loop", "after the loop")
LOOP = ("simgap.cosim.loop", "_CoSimulation.run")          # the co-simulation's loop
READS = {("simgap.scenario.files", "load_scenario"): "scenario XML read",
         ("simgap.scenario.sidecar", "read_sidecar"): "sidecar read",
         ("simgap.scenario.ground", "ground_of"): "ground built",
         ("simgap.scenario.obstacles", "recorded_obstacles"): "recorded obstacles made",
         ("simgap.scenario.obstacles", "without_recorded_egos"): "recorded egos taken out",
         ("simgap.scenario.road_frame", "DrivableArea.__init__"): "drivable area built"}
WRITES = {("simgap.record.run_files", name) for name in ("write_run", "rewrite_record")}


def _package(module: str) -> str:
    """``simgap.scenario.files`` → ``scenario``; simgap's top-level modules by their name."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else parts[0]


class Way:
    """The package entries, file reads and writes of what runs while it is installed."""

    def __init__(self) -> None:
        self.phase = 0
        self.entries: list[Counter[str]] = [Counter() for _ in PHASES]
        self.functions: list[Counter[str]] = [Counter() for _ in PHASES]
        self.reads: list[Counter[str]] = [Counter() for _ in PHASES]
        self.writes = 0
        self._loop_frame: FrameType | None = None

    def __call__(self, frame: FrameType, event: str, arg: Any) -> None:
        if event == "return" and frame is self._loop_frame:
            self.phase, self._loop_frame = 2, None
            return
        if event != "call":
            return
        module = frame.f_globals.get("__name__", "")
        if not module.startswith("simgap."):
            return
        name = frame.f_code.co_qualname
        if (module, name) == LOOP and self.phase == 0:
            self.phase, self._loop_frame = 1, frame
        if (module, name) in READS:
            self.reads[self.phase][READS[module, name]] += 1
        if (module, name) in WRITES:
            self.writes += 1
        caller = frame.f_back
        caller_module = caller.f_globals.get("__name__", "") if caller is not None else ""
        if _package(module) != _package(caller_module) or not caller_module.startswith("simgap."):
            self.entries[self.phase][_package(module)] += 1
            self.functions[self.phase][f"{module}.{name} from {caller_module}.{caller.f_code.co_qualname}"
                                       if caller is not None else f"{module}.{name}"] += 1


def traced(request: RunRequest, out: Path) -> Way:
    way = Way()
    sys.setprofile(way)
    try:
        execute(request, out)
    finally:
        sys.setprofile(None)
    return way


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", default=["ideal", "mujoco"])
    parser.add_argument("--files", nargs="*", type=Path, default=[], help="recorded CommonRoad files to run too")
    parser.add_argument("--json", type=Path, metavar="FILE")
    args = parser.parse_args()
    results = BenchmarkResults()
    rows = []
    with tempfile.TemporaryDirectory(prefix="simgap-run-way-") as tmp:
        road = build_scenario("curve-3d", {"grade": 5, "bank": 4})
        scenarios = [write_scenario(road, Path(tmp) / "scenarios", preview=False), *args.files]
        for xml in scenarios:
            for world in args.worlds:
                request = RunRequest(scenario=xml, backend=world)
                execute(request, Path(tmp) / "warm")          # imports and caches out of the figures
                clock = time.perf_counter()
                execute(request, Path(tmp) / "plain")
                wall = time.perf_counter() - clock
                way = traced(request, Path(tmp) / "traced")
                row = {"scenario": xml.name, "world": world, "wall_s": round(wall, 3), "writes": way.writes}
                for k, phase in enumerate(PHASES):
                    row[f"{phase}: reads"] = ", ".join(f"{what} x{n}" for what, n in way.reads[k].items()) or "none"
                    row[f"{phase}: package entries"] = ", ".join(
                        f"{p} {n}" for p, n in sorted(way.entries[k].items(), key=lambda e: -e[1]))
                    if k:
                        row[f"{phase}: scenario/ entered"] = "; ".join(
                            f"{f} x{n}" for f, n in sorted(way.functions[k].items()) if f.startswith("simgap.scenario.")
                        ) or "never"
                rows.append(row)
                print(f"\n{xml.name} in {world}: {wall:.2f} s untraced; {way.writes} write call(s) of the run directory")
                for phase in PHASES:
                    print(f"  {phase:15s} reads: {row[phase + ': reads']}; package entries: "
                          f"{row[phase + ': package entries']}")
                for k in (1, 2):
                    print(f"  scenario/ entered {PHASES[k]}: {row[PHASES[k] + ': scenario/ entered']}")
    if args.json:
        results.write(args.json, {"rows": rows})


if __name__ == "__main__":
    main()
