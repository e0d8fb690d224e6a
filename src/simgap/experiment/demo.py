"""The README's main job: a small real experiment on the built-in defaults, ending in a report.

A few `curve` scenarios from the paper's grid, each run in the ideal 2D world, the dynamic
single-track world and the MuJoCo 3D world with two vehicles; every run is drawn (2D, and the
sharpest curve in 3D), and `simgap.report.site` writes the HTML report comparing each physics
run with the ideal run of its scenario.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from simgap.experiment.single_run import RunRequest, execute
from simgap.report.scene2d import render_run
from simgap.report.site import build_report
from simgap.scenario import build_scenario, write_scenario
from simgap.sim.registry import backend_available

DEMO_SCENARIOS = [{"radius": 10, "angle": 90}, {"radius": 30, "angle": -120}, {"radius": 75, "angle": 180}]
DEMO_FIDELITIES = [("ideal", "sedan"), ("dynamic", "sedan"), ("mujoco", "sedan"), ("mujoco", "city")]
RENDER_3D = ({"radius": 10, "angle": 90}, ("mujoco", "sedan"))


@dataclass
class DemoResult:
    report: Path
    runs: int
    failed: int
    wall_time_s: float


def run_demo(out: Path, fidelities=None, scenarios=DEMO_SCENARIOS,
             say: Callable[[str], None] = print) -> DemoResult:
    t0 = time.perf_counter()
    if fidelities is None:
        fidelities = [(b, v) for b, v in DEMO_FIDELITIES if backend_available(b)]
        missing = sorted({b for b, _ in DEMO_FIDELITIES if not backend_available(b)})
        if missing:
            say(f"not installed, skipped: {', '.join(missing)} backend")
    out = Path(out)
    failed = 0
    for params in scenarios:
        xml = write_scenario(build_scenario("curve", params), out / "scenarios", preview=False)
        for backend, vehicle in fidelities:
            label = f"{backend}/{vehicle}" if backend != "ideal" else "ideal"
            run_dir = out / "runs" / xml.stem / label.replace("/", "-")
            say(f"{xml.stem}: running {label}")
            try:
                run = execute(RunRequest(scenario=xml, backend=backend, vehicles=vehicle), run_dir)
            except Exception as exc:   # a run that cannot even start is reported, the demo goes on
                failed += 1
                say(f"{xml.stem}: {label} failed: {exc}")
                continue
            failed += run.failure is not None
            render_run(run_dir, animation=False)
            if (params, (backend, vehicle)) == RENDER_3D:
                from simgap.report.scene3d import render_run_3d

                say(f"{xml.stem}: rendering {label} in 3D")
                render_run_3d(run_dir, frame_every=5)
    say("building the report")
    index = build_report(out / "runs", out / "report")
    return DemoResult(index, len(scenarios) * len(fidelities), failed, time.perf_counter() - t0)
