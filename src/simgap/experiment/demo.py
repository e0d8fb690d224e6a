"""The README's main job: a small real experiment on the built-in defaults, ending in a report.

A few `curve` scenarios from the paper's grid, each run in the ideal 2D world and in the MuJoCo
3D world with two vehicles; every physics run is compared with the ideal run of its scenario
(lateral displacement by arc length, errors by time), and an HTML page shows the outcome.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from simgap.cosim import Run
from simgap.evaluate.compare import compare_runs
from simgap.experiment.single_run import RunRequest, execute
from simgap.report.overview import Section, write_page
from simgap.report.plots import plot_d_over_s, plot_v_over_t, runtime_rows
from simgap.report.scene2d import render_run
from simgap.scenario import build_scenario, load_scenario, read_metadata, write_scenario
from simgap.sim.registry import backend_available

DEMO_SCENARIOS = [{"radius": 10, "angle": 90}, {"radius": 30, "angle": -120}, {"radius": 75, "angle": 180}]
DEMO_FIDELITIES = [("ideal", "sedan"), ("dynamic", "sedan"), ("mujoco", "sedan"), ("mujoco", "city")]


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
    report_dir = out / "report"
    report_dir.mkdir(parents=True, exist_ok=True)
    sections, outcome_rows, gap_rows = [], [], []
    wall: dict[str, list[float]] = {}
    failed = 0
    for params in scenarios:
        xml = write_scenario(build_scenario("curve", params), out / "scenarios", preview=False)
        scenario, problems = load_scenario(xml)
        meta = read_metadata(xml)
        runs: dict[str, Run] = {}
        for backend, vehicle in fidelities:
            label = f"{backend}/{vehicle}" if backend != "ideal" else "ideal"
            run_dir = out / "runs" / xml.stem / label.replace("/", "-")
            say(f"{xml.stem}: running {label}")
            try:
                run = execute(RunRequest(scenario=xml, backend=backend, vehicles=vehicle), run_dir)
            except Exception as exc:   # a failed run is reported, the demo goes on
                failed += 1
                outcome_rows.append({"scenario": xml.stem, "fidelity": label, "outcome": "failed",
                                     "time to goal [s]": str(exc)[:80], "wall time [s]": float("nan")})
                continue
            runs[label] = run
            wall.setdefault(label, []).append(run.wall_time_s)
            agent = run.agents[0]
            outcome_rows.append({"scenario": xml.stem, "fidelity": label, "outcome": agent.outcome,
                                 "time to goal [s]": agent.time_to_goal_s if agent.time_to_goal_s is not None else "—",
                                 "wall time [s]": run.wall_time_s})
            render_run(run_dir, report_dir / xml.stem / label.replace("/", "-"), animation=False)
        images = [(f"{xml.stem}/{lbl.replace('/', '-')}/scene.png", f"{lbl}: driven path") for lbl in runs]
        if "ideal" in runs:
            curves = {}
            for label, run in runs.items():
                if label == "ideal":
                    continue
                for cmp in compare_runs(runs["ideal"], run, scenario, problems, meta.get("sections")):
                    curves.setdefault("ideal", (cmp.s, cmp.d_a))
                    shading = None if cmp.section_along_s is None else (cmp.s, cmp.section_along_s)
                    curves[label] = (cmp.s, cmp.d_b)
                    d = cmp.lateral_displacement
                    gap_rows.append({"scenario": xml.stem, "fidelity": label, "max |d| [m]": d.max,
                                     "RMS |d| [m]": d.rms, "max |Δv| [m/s]": cmp.velocity_error.max,
                                     "max position error by time [m]": cmp.position_error.max})
            if curves:
                plot_d_over_s(curves, report_dir / xml.stem / "d_over_s.png",
                              f"{xml.stem}: lateral offset from the lane centre", shading)
                images.append((f"{xml.stem}/d_over_s.png", "lateral offset d over arc length s"))
            plot_v_over_t({lbl: r.driven[1] for lbl, r in runs.items()}, report_dir / xml.stem / "v_over_t.png",
                          f"{xml.stem}: speed over time")
            images.append((f"{xml.stem}/v_over_t.png", "speed v over time t"))
        sections.append(Section(xml.stem, images=images))
    gap_rows.sort(key=lambda r: -r["max |d| [m]"])
    summary = [
        Section("Outcomes", rows=outcome_rows),
        Section("Cross-fidelity gaps (each run against the ideal run of its scenario, largest first)", rows=gap_rows,
                text="d is the lateral offset from the route's lane centre, compared at equal arc length; "
                     "Δv and the position error are compared at equal time."),
        Section("Run times per fidelity [s]", rows=runtime_rows(wall)),
    ]
    if not gap_rows:
        summary[1].text = "No physics fidelity ran, so there is nothing to compare with the ideal runs."
    labels = ", ".join(f"{b}/{v}" if b != "ideal" else b for b, v in fidelities)
    page = write_page(report_dir / "index.html", "simgap demo: the paper's curve across fidelities",
                      f"{len(scenarios)} curve scenarios × fidelities {labels}; {failed} failed runs.",
                      summary + sections)
    return DemoResult(page, len(scenarios) * len(fidelities), failed, time.perf_counter() - t0)

