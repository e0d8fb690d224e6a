"""The paper's vehicle-model comparison: its left-right curve (the built-in ``s-curve``) run in the
ideal world and in MuJoCo with each catalogue car, compared by lateral displacement d over the
travelled distance s (arc length) and by speed v over time t.

Per car it prints max and mean |d| against the ideal run (overall and per road section), the
largest speed difference at equal time, the largest lateral acceleration and the time to goal;
``--plot FILE`` writes the two figures (d over s, v over t) as one PNG.

Usage: python bench/paper/vehicle_models.py [--vehicles sedan suv city] [--plot d_v.png]
No pass/fail.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from simgap.evaluate.compare import compare_histories
from simgap.experiment.single_run import RunRequest, execute
from simgap.files import BenchmarkResults
from simgap.scenario import build_scenario
from simgap.scenario.files import load_scenario, write_scenario
from simgap.vehicles import vehicle_names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vehicles", nargs="+", default=vehicle_names())
    parser.add_argument("--plot", type=Path)
    parser.add_argument("--kinematic-feedforward", action="store_true",
                        help="controllers without the tyre-based understeer and sideslip feed-forward (ablation)")
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    settings = {}
    if args.kinematic_feedforward:
        settings = {"controller_gains": {"understeer_gradient": 0.0, "sideslip_compensation": 0.0}}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        xml = write_scenario(build_scenario("s-curve", {}), tmp, preview=False)
        scenario, problems = load_scenario(xml)
        ideal = execute(RunRequest(scenario=xml, backend="ideal"), tmp / "ideal")
        runs = {v: execute(RunRequest(scenario=xml, backend="mujoco", vehicles=v, backend_settings=settings), tmp / v)
                for v in args.vehicles}
    aid = ideal.agents[0].id
    print(f"s-curve ({ideal.scenario_id}): ideal world vs MuJoCo, agent {aid}")
    print(f"{'vehicle':<8} {'outcome':<13} {'goal [s]':>8} {'max|d| [m]':>10} {'mean|d|':>8} {'by section (max |d|)':<34} "
          f"{'max|dv| [m/s]':>13} {'peak a_y':>8}")
    series = {}
    for name, run in runs.items():
        comparison = compare_histories(ideal.history, run.history, scenario, problems,
                                       run.settings.sections or None)[0]
        agent = run.history.agents[0]
        driven, ref = run.history.driven[aid], ideal.history.driven[aid]
        n = min(len(driven.t), len(ref.t))
        dv = np.abs(np.asarray(driven.v[:n]) - np.asarray(ref.v[:n]))
        a_y = np.abs(np.asarray(driven.v) * np.asarray(driven.yaw_rate))
        sections = ", ".join(f"{k} {v.max:.3f}" for k, v in comparison.by_section.items())
        goal = f"{agent.time_to_goal_s:.1f}" if agent.time_to_goal_s is not None else "—"
        print(f"{name:<8} {agent.outcome:<13} {goal:>8} {comparison.lateral_displacement.max:>10.3f} "
              f"{comparison.lateral_displacement.mean:>8.3f} {sections:<34} {dv.max():>13.3f} {a_y.max():>8.2f}")
        series[name] = (comparison.s, comparison.d_b - comparison.d_a, np.asarray(driven.t), np.asarray(driven.v))
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax_d, ax_v) = plt.subplots(1, 2, figsize=(11, 3.6))
        ax_v.plot(ideal.history.driven[aid].t, ideal.history.driven[aid].v, color="black", lw=1.5, label="ideal")
        for name, (s, d, t, v) in series.items():
            ax_d.plot(s, d, lw=1.2, label=name)
            ax_v.plot(t, v, lw=1.2, label=name)
        ax_d.set(xlabel="travelled distance s [m]", ylabel="lateral displacement d [m]",
                 title="d over s: MuJoCo minus ideal")
        ax_v.set(xlabel="time t [s]", ylabel="speed v [m/s]", title="v over t")
        for ax in (ax_d, ax_v):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)
        print(f"wrote {args.plot}")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
