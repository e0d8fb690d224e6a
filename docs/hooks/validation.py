"""The Validation pages' tables, generated from the benchmarks' results files (bench/results/*.json).

``render_results("index")`` is the list of results files with their provenance and the script that
wrote each (from bench/README.md's table); ``render_results("all")`` shows every file's figures as
tables: a list of records as rows, a mapping of records as rows keyed by name, scalars as name and
value; ``render_results("KIND:FILE")`` is one benchmark's table as its page shows it (``TABLES``:
printed, printed_section, planners, planner_scores, frenetix, gaps, recorded, road_3d, road_3d_grid,
road_relief, realism_steps, realism_tracking, vehicle_dynamics, opendrive_import, export_maps,
real_scenarios). Nothing here is typed: a figure on these pages is the file's.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "bench" / "results"
PROVENANCE = ("commit", "date", "machine", "load")
MAX_ROWS = 60


def _scalar(value: Any) -> bool:
    return value is None or isinstance(value, (str, int, float, bool))


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value).replace("|", "\\|").replace("\n", " ")


def _flatten(record: dict, prefix: str = "", depth: int = 0) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in record.items():
        name = f"{prefix}{key}"
        if _scalar(value):
            out[name] = value
        elif isinstance(value, dict) and depth < 1:
            out.update(_flatten(value, name + ".", depth + 1))
    return out


def _table(rows: list[dict[str, Any]], first: str | None = None) -> list[str]:
    columns: list[str] = [first] if first else []
    for row in rows:
        columns += [c for c in row if c not in columns]
    if not columns:
        return []
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(_fmt(row.get(c, "")) for c in columns) + " |" for row in rows[:MAX_ROWS]]
    if len(rows) > MAX_ROWS:
        lines += ["", f"*{len(rows) - MAX_ROWS} more rows in the file.*"]
    return lines


def _section(data: Any, level: int) -> list[str]:
    """Tables of one JSON value."""
    if isinstance(data, list):
        records = [_flatten(r) for r in data if isinstance(r, dict)]
        if records:
            return _table(records) + [""]
        return ["| value |", "|---|"] + [f"| {_fmt(v)} |" for v in data[:MAX_ROWS] if _scalar(v)] + [""]
    if isinstance(data, dict):
        scalars = {k: v for k, v in data.items() if _scalar(v)}
        records = {k: v for k, v in data.items() if isinstance(v, dict)}
        lists = {k: v for k, v in data.items() if isinstance(v, list)}
        lines: list[str] = []
        if scalars:
            lines += ["| name | value |", "|---|---|"] + [f"| {_fmt(k)} | {_fmt(v)} |" for k, v in scalars.items()]
            lines.append("")
        if records:
            if all(any(_scalar(x) for x in r.values()) for r in records.values()):
                lines += _table([{"name": k, **_flatten(r)} for k, r in records.items()], "name") + [""]
            else:
                for key, value in records.items():
                    lines += [f"{'#' * level} `{key}`", ""] + _section(value, level + 1)
        for key, value in lists.items():
            lines += [f"{'#' * level} `{key}`", ""] + _section(value, level + 1)
        return lines
    return [_fmt(data), ""]


def provenance(data: Any) -> str:
    meta = data.get("provenance", data) if isinstance(data, dict) else {}
    found = {k: meta[k] for k in PROVENANCE if isinstance(meta, dict) and k in meta}
    if not found:
        return "not recorded in the file"
    load = found.get("load")
    if isinstance(load, dict) and {"start", "end", "cpus"} <= set(load):
        found["load"] = f"{load['start']} at the start, {load['end']} at the end, on {load['cpus']} CPUs"
    elif isinstance(load, dict):
        found["load"] = ", ".join(f"{k} {v}" for k, v in load.items())
    return "; ".join(f"{k} {v}" for k, v in found.items())


def scripts() -> dict[str, str]:
    """results file name → the script that writes it, from bench/README.md's table."""
    table = (ROOT / "bench" / "README.md").read_text()
    out = {}
    for line in table.splitlines():
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]
        if len(cells) >= 6:           # subject, script, claim, command, runtime, results file
            for name in re.findall(r"results/([\w.-]+\.json)", cells[-1]):
                out[name] = re.sub(r"`", "", cells[1])
    return out


def _share(goals: int, total: int) -> str:
    return f"{goals}/{total} ({100 * goals / total:.0f} %)" if total >= 10 else f"{goals}/{total}"


def recorded_table(spec: str) -> str:
    """Goals reached per world and kind, from a results file of bench/recorded/real_recorded.py (its records:
    scenario, kind, world, agent, outcome, reason, wall_s, excluded, human); agents that start in a
    collision or overhanging the road (``excluded``) are not counted, as the benchmark prints. ``spec``: FILE, or
    FILE,WORLD for one world's row of a file that holds several."""
    name, _, only = spec.partition(",")
    data = json.loads((RESULTS / name).read_text())
    records = data["rows"] if isinstance(data, dict) else data
    records = [r for r in records if not only or r["world"] == only]
    kinds = sorted({r["kind"] for r in records})
    lines = ["| world | " + " | ".join(k.replace("_", "-") for k in kinds) + " | all | files with a human recording "
             "| files without | errors | wall / scenario |", "|---|" + "---|" * (len(kinds) + 5)]
    counted = [r for r in records if not r["excluded"]]
    for world in sorted({r["world"] for r in records}):
        rows = [r for r in counted if r["world"] == world]
        goal = [r for r in rows if r["outcome"] == "goal_reached"]
        cells = [_share(sum(r["kind"] == k for r in goal), sum(r["kind"] == k for r in rows)) for k in kinds]
        human = [r for r in rows if r["human"]]
        scenarios = {r["scenario"] for r in records if r["world"] == world}
        wall = sum(r["wall_s"] for r in records if r["world"] == world) / max(len(scenarios), 1)
        lines.append(f"| {world} | " + " | ".join(cells) + f" | **{_share(len(goal), len(rows))}** | "
                     f"{_share(sum(r in goal for r in human), len(human))} | "
                     f"{_share(sum(r in goal for r in rows if not r['human']), len(rows) - len(human))} | "
                     f"{sum(r['outcome'] == 'error' for r in rows)} | {wall:.1f} s |")
    first = sorted({r["world"] for r in records})[0]
    human = [r for r in counted if r["world"] == first and r["human"]]
    reached = [r for r in human if r["human"].startswith("goal")]
    lines.append("| the recorded human | " + " | ".join(
        _share(sum(r["kind"] == k for r in reached), sum(r["kind"] == k for r in human)) for k in kinds)
        + f" | {_share(len(reached), len(human))} | | | | |")
    lines += ["", f"*Generated from `bench/results/{name}` (provenance: {provenance(data)}).*"]
    return "\n".join(lines)


def _generated(name: str, data: Any) -> list[str]:
    return ["", f"*Generated from `bench/results/{name}` (provenance: {provenance(data)}).*"]


def _rows(lines: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(cells) + " |" for cells in lines]


def _closed_form_row(check: str, case: str, measured: str, closed: str, error: float | None) -> list[str]:
    return [check, case, measured, closed, "—" if error is None else f"{error:.2g} %".replace("-", "−")]


def road_relief_table(name: str) -> str:
    """bench/roads/road_relief.py's checks: each drive against its closed form."""
    data = json.loads((RESULTS / name).read_text())
    lines = ["| check | case | measured | closed form | error |", "|---|---|---|---|---|"]
    rows: list[list[str]] = []
    for i, r in enumerate(data["braking"]):
        rows.append(_closed_form_row("braking from 100 km/h at the tyres' peak μ, v²/(2g(μ cos θ + sin θ))" if i == 0
                                     else "", f"{r['grade_percent']:+g} %".replace("+0", "0").replace("-", "−"),
                                     f"{r['measured']:.2f} m", f"{r['closed_form']:.2f} m", r["error_percent"]))
    for i, r in enumerate(data["crest"]):
        rows.append(_closed_form_row("tyre load at a crest's top, m(g − v²/R)" if i == 0 else "",
                                     f"R {r['radius']:g} m, ±{r['grade_percent']:g} %, {r['speed']:.1f} m/s",
                                     f"{r['measured']:.0f} N", f"{r['closed_form']:.0f} N", r["error_percent"]))
    for i, r in enumerate(data["bank"]):
        rows.append(_closed_form_row("friction a steady turn needs on a bank" if i == 0 else "",
                                     f"{r['bank_deg']:+g}°, R {r['radius']:.0f} m, {r['speed']:.0f} m/s"
                                     .replace("+0", "0").replace("-", "−"),
                                     f"{r['measured']:.5f}", f"{r['closed_form']:.5f}", r["error_percent"]))
    hold = {r["facing"]: r["moved_m"] * 1000 for r in data["hold"]}
    grades = sorted({r["grade_percent"] for r in data["hold"]})
    rows.append(["a braked car on " + ", ".join(f"{g:g} %" for g in grades), " / ".join(f"facing {f}" for f in hold),
                 "moved " + " / ".join(f"{v:.2f}" for v in hold.values()) + " mm", "stays", "—"])
    rows.append(["a flat relief against no relief", "on a circle", f"{data['flat_relief_against_plane_m']:g} m apart",
                 "0 m", "—"])
    rt = data["realtime"]
    rows.append([f"real-time factor of one car (physics and control, no planner; best of {rt['rounds']})",
                 "flat proving ground / banked 3D one", f"{rt['flat']:.1f}× / {rt['relief']:.1f}×", "", ""])
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def realism_steps_table(name: str) -> str:
    """bench/vehicles/realism.py's actuator step responses: the source's figures, the model's, the car's."""
    data = json.loads((RESULTS / name).read_text())
    lines = ["| vehicle | channel | dead time: source / model / car [s] | 63 % rise after it: source / model / car [s] |",
             "|---|---|---|---|"]
    rows = [[r["vehicle"], r["channel"], f"{r['dead_time_s']:.3f} / {r['measured_dead_s']:.3f} / {r['car_dead_s']:.3f}",
             f"{r['time_constant_s']:.3f} / {r['measured_rise_s']:.3f} / {r['car_rise_s']:.3f}"]
            for r in data["step_responses"]]
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def realism_tracking_table(name: str) -> str:
    """bench/vehicles/realism.py's tracking: RMS / peak lateral error per manoeuvre, controller and car."""
    data = json.loads((RESULTS / name).read_text())
    cars = list(dict.fromkeys(r["car"] for r in data["tracking"]))
    cells: dict[tuple[str, str], dict[str, str]] = {}
    for r in data["tracking"]:
        cell = f"{r['rms_m']:.3f} / {r['peak_m']:.3f}"
        if r["outcome"] != "goal_reached":
            cell += f" **{r['outcome'].replace('_', ' ')}**"
        cells.setdefault((r["scenario"], r["controller"].replace("_", " ")), {})[r["car"]] = cell
    lines = ["| manoeuvre | controller | " + " | ".join(cars) + " |", "|---|---|" + "---|" * len(cars)]
    rows = [[scenario, controller] + [by_car.get(c, "") for c in cars] for (scenario, controller), by_car in cells.items()]
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def _arrow(values: dict[str, float]) -> str:
    return " → ".join(f"{v:.3f}" for _, v in sorted(values.items(), key=lambda kv: float(kv[0])))


def _lane_change(result: dict[str, dict[str, Any]]) -> str:
    if all(r["peak_lateral_error_m"] is None for r in result.values()):
        return "state no longer finite (spins)"
    verdict = "pass" if all(r["passed"] for r in result.values()) else "fail"
    return verdict + " " + " / ".join("—" if r["peak_lateral_error_m"] is None else f"{r['peak_lateral_error_m']:.2f}"
                                      for r in result.values())


VEHICLE_ROWS = [  # (row, the figure of a car's record, target)
    ("understeer gradient [deg/g] (fit to 0.4 g)", lambda c: f"{c['understeer_gradient_deg_per_g']:.2f}",
     "0 to 4 for every car"),
    ("sideslip gradient [deg/g]", lambda c: f"{c['sideslip_gradient_deg_per_g']:.2f}", ""),
    ("roll gradient [deg/g] (fit to 0.4 g)", lambda c: f"{c['roll_gradient_deg_per_g']:.1f}",
     "real cars: sedan 3–6, SUV 5–8"),
    ("largest lateral acceleration held on the circle [m/s²] (at speed [m/s])",
     lambda c: f"{c['max_lateral_acceleration']:.2f} ({c['circle_limit_speed']:g})", "suv lower than sedan"),
    ("yaw-rate rise time, step steer at 80 km/h to ~4 m/s² [s]", lambda c: f"{c['yaw_rate_rise_time_s']:.3f}",
     "sedan within 30 % of MB; city quicker than sedan"),
    ("yaw-rate overshoot [%]", lambda c: f"{c['yaw_rate_overshoot_percent']:.1f}", ""),
    ("braking from 100 km/h, full pedal [m]", lambda c: f"{c['braking_distance_100_m']:.1f}"
     + (" (wheels lock)" if c.get("braking_full_pedal_locks") else ""), "sedan 35–42"),
    ("braking, largest pedal that locks no wheel [m]", lambda c: f"{c['braking_distance_100_unlocked_m']:.1f}", ""),
    ("lateral error on the circle at the last speeds below the limit [m]",
     lambda c: _arrow(c["circle_near_limit_lateral_error_m"]), "rising progressively"),
    ("ISO 3888-2 double lane change, 60 km/h: peak lateral error [m] by controller",
     lambda c: _lane_change(c["lane_change_60"]), "no rollover"),
    ("beyond the limit: runs, rollovers, largest roll [deg], longest two-wheel lift [s]",
     lambda c: f"{c['beyond_limit_runs']}, {c['beyond_limit_rollovers']}, {c['beyond_limit_max_roll_deg']:.1f}, "
               f"{c['beyond_limit_longest_two_wheel_lift_s']:.2f}" if "beyond_limit_runs" in c else "", "no rollover"),
]


def vehicle_dynamics_table(name: str) -> str:
    """bench/vehicles/vehicle_dynamics.py: each car's handling figures beside the sedan's multi-body reference."""
    data = json.loads((RESULTS / name).read_text())
    cars = [k for k, v in data.items() if isinstance(v, dict) and "understeer_gradient_deg_per_g" in v]
    columns = []
    for car in cars:
        columns.append((car, data[car]))
        if "mb_reference" in data[car]:
            columns.append((f"MB ({car}'s reference)", data[car]["mb_reference"]))
    controllers = next(iter(columns))[1].get("lane_change_60", {})
    lines = ["| | " + " | ".join(c for c, _ in columns) + " | target |", "|---|" + "---|" * (len(columns) + 1)]
    rows = []
    for label, figure, target in VEHICLE_ROWS:
        if "lane change" in label:
            label += " (" + " / ".join(controllers) + ")"
        cells = []
        for _, record in columns:
            try:
                cells.append(figure(record))
            except (KeyError, TypeError):
                cells.append("—")
        rows.append([label] + cells + [target])
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def opendrive_import_table(name: str) -> str:
    """bench/export/opendrive_import.py: each public road read, run in both worlds and exported back."""
    data = json.loads((RESULTS / name).read_text())

    def run(r: dict[str, Any]) -> str:
        if r.get("outcome") == "goal_reached":
            return f"goal, {r['time_to_goal_s']:.1f} s"
        return str(r.get("outcome", "—")).replace("_", " ")

    def wall(r: dict[str, Any]) -> str:
        return " / ".join(f"{r[w]['wall_s']:.1f}" if "wall_s" in r.get(w, {}) else "—" for w in ("ideal", "mujoco"))

    lines = ["| file | import | lanelets | successors (across roads) | neighbour pairs | lane links kept | ideal | MuJoCo "
             "| run wall time, ideal / MuJoCo [s] | exported back: export [s], lanelet centres off [mm] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    rows = [[f"`{r['file']}`", f"{r['import_s']:.2f} s", str(r["lanelets"]),
             f"{r['successors']} ({r['successors_across_roads']})", str(r["neighbour_pairs"]),
             f"{r['lane_links_kept']} of {r['lane_links_in_file']}" if r["lane_links_in_file"] else "— (one road)",
             run(r.get("ideal", {})), run(r.get("mujoco", {})), wall(r),
             f"{r['export']['export_s']:.1f}, {1000 * r['export']['read_back_m']:.0f}" if "export" in r else "—"]
            for r in data["roads"]]
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def printed_block(name: str) -> str:
    """What a benchmark printed, as its results file keeps it (``printed``), under its command."""
    data = json.loads((RESULTS / name).read_text())
    return "\n".join(["```console", f"$ {data['command']}", *data["printed"], "```"] + _generated(name, data))


def road_3d_table(name: str) -> str:
    """bench/roads/road_3d_study.py: per 3D family, each world on the 3D road against the road's flat twin."""
    data = json.loads((RESULTS / name).read_text())
    lines = ["| family (3D scenarios) | goals, MuJoCo / dynamic on the 3D road | max \\|d\\| [m], MuJoCo: flat twin → 3D road "
             "(median / max) | dynamic: flat twin → 3D (max) | the flat plan's peak grip use: on its plane → on the real "
             "road | MuJoCo's peak grip use on the relief: flat twin → 3D | CLS drop against ideal, MuJoCo 3D (mean / max) |",
             "|---|---|---|---|---|---|---|"]
    rows = []
    for family, f in data["families"].items():
        w = f["worlds"]
        mj, mjf, dy, dyf, ideal = w["mujoco 3D"], w["mujoco flat"], w["dynamic 3D"], w["dynamic flat"], w["ideal 3D"]
        rows.append([f"`{family}` ({f['scenarios']})", f"{mj['goals']}/{mj['runs']}, {dy['goals']}/{dy['runs']}",
                     f"{mjf['max_d_median_m']:.2f} / {mjf['max_d_max_m']:.2f} → {mj['max_d_median_m']:.2f} / "
                     f"{mj['max_d_max_m']:.2f}", f"{dyf['max_d_max_m']:.2f} → {dy['max_d_max_m']:.2f}",
                     f"{ideal['grip_2d_max']:.2f} → {ideal['grip_3d_max']:.2f}",
                     f"{mjf['grip_3d_max']:.2f} → {mj['grip_3d_max']:.2f}",
                     f"{mj['score_drop_mean']:.3g} / {mj['score_drop_max']:.3g}"])
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def road_3d_grid_table(name: str, family: str = "curve-3d") -> str:
    """bench/roads/road_3d_study.py: MuJoCo's largest max |d| over the radii, by grade and bank."""
    data = json.loads((RESULTS / name).read_text())
    runs = [r for r in data["families"][family]["runs"] if r["backend"] == "mujoco" and r["status"] == "ok"]
    grades, banks = sorted({r["grade"] for r in runs}), sorted({r["bank"] for r in runs})
    lines = ["| grade \\ bank | " + " | ".join(f"{b:+g}°".replace("+0", "0").replace("-", "−") for b in banks) + " |",
             "|---|" + "---|" * len(banks)]
    rows = []
    for g in grades:
        cells = []
        for b in banks:
            cell = [r for r in runs if r["grade"] == g and r["bank"] == b]
            worst = max(cell, key=lambda r: r["max_lateral_offset_m"])
            cells.append(f"{worst['max_lateral_offset_m']:.2f} m (r = {worst['radius']:g} m)")
        rows.append([f"{g:+g} %".replace("+0", "0").replace("-", "−")] + cells)
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def gaps_table(names: str) -> str:
    """bench/paper/realism_gaps.py: max |d| against the ideal run per car (median / p90 / max) before and after,
    and the score drops and missed goals after; ``names``: one file holding both studies, or BEFORE,AFTER."""
    import numpy as np

    files = names.split(",")
    studies = [s for f in files for s in json.loads((RESULTS / f).read_text()).values()]
    before, after = studies[0], studies[-1]

    def car(fidelity: str) -> str:
        return fidelity.split("/")[1]

    def spread(values: list[float]) -> str:
        return " / ".join(f"{v:.3f}" for v in (np.median(values), np.percentile(values, 90), max(values)))

    old = {car(k): v for k, v in before.items()}
    lines = ["| car | runs | max \\|d\\| before (median / p90 / max) [m] | after | score drop > 0 after | goals missed "
             "after |", "|---|---|---|---|---|---|"]
    rows = []
    for fidelity, new in after.items():
        drops = [d for d in new["score_drop"] if d > 0]
        rows.append([car(fidelity), str(len(new["max_d"])), spread(old[car(fidelity)]["max_d"]) if car(fidelity) in old
                     else "—", spread(new["max_d"]),
                     f"{len(drops)}" + (f" ({', '.join(sorted({f'{d:.3g}' for d in drops}))})" if drops else ""),
                     str(len(new["missed"]))])
    data = json.loads((RESULTS / files[-1]).read_text())
    return "\n".join(lines + _rows(rows) + ["", "*Generated from " + ", ".join(f"`bench/results/{f}`" for f in files)
                                            + f" (provenance: {provenance(data)}).*"])


def frenetix_table(name: str) -> str:
    """bench/planners/frenetix_guest.py: each planner on the paper's curves, ideal against MuJoCo, per MuJoCo
    plan-latency setting the benchmark ran with."""
    data = json.loads((RESULTS / name).read_text())
    lines = ["| MuJoCo's plan latency | planner | goals ideal, MuJoCo | score ideal / MuJoCo (mean) | max \\|d\\| ideal vs "
             "MuJoCo, median / max [m] | ms per call, ideal / MuJoCo (mean) |", "|---|---|---|---|---|---|"]
    rows = []
    for variant, v in data["variants"].items():
        for planner, e in v["summary"].items():
            ideal, mujoco = e["ideal"], e["mujoco"]
            rows.append([variant.removeprefix("latency="), f"`{planner}`",
                         f"{ideal['goals']}/{ideal['runs']}, {mujoco['goals']}/{mujoco['runs']}",
                         f"{ideal['score_mean']:.3f} / {mujoco['score_mean']:.3f}",
                         f"{e['max_d_median_m']:.3f} / {e['max_d_max_m']:.3f}",
                         f"{ideal['ms_per_call_mean']:.0f} / {mujoco['ms_per_call_mean']:.0f}"])
    return "\n".join(lines + _rows(rows) + ["", f"*Generated from `bench/results/{name}` (the file records each "
                                            "variant's command, load average and guest environment, not its commit).*"])


def _num(value: float | None, spec: str) -> str:
    return "—" if value is None else format(value, spec)


def planner_table(name: str) -> str:
    """bench/planners/planner_study.py: per scenario and planner, goals, times, the cross-fidelity gap and the cost
    of a planning call (its results file's ``rows``)."""
    data = json.loads((RESULTS / name).read_text())
    lines = ["| scenario | planner | goal ideal | goal mujoco | t_goal ideal [s] | t_goal mujoco [s] | gap mean [m] "
             "| gap max [m] | failed cycles | calls | ms/call | p95 ms |", "|---|" * 1 + "---|" * 11]
    rows = [[r["scenario"].replace("-r", " r"), r["planner"], f"{r['goals_ideal']}/{r['agents']}",
             f"{r['goals_mujoco']}/{r['agents']}", _num(r["time_to_goal_ideal_s"], ".1f"),
             _num(r["time_to_goal_mujoco_s"], ".1f"), _num(r["gap_mean_m"], ".3f"), _num(r["gap_max_m"], ".3f"),
             str(r["planner_failures"]), str(r["planning_calls"]), f"{r['ms_per_call_mean']:.1f}",
             f"{r['ms_per_call_p95']:.1f}"] for r in data["rows"]]
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def planner_scores_table(name: str) -> str:
    """bench/planners/planner_study.py: per scenario and planner, the closed-loop score, the KS2/SM1 cost and the
    valid solutions in each world (its results file's ``rows``)."""
    data = json.loads((RESULTS / name).read_text())
    lines = ["| scenario | planner | score ideal → MuJoCo | KS2/SM1 cost ideal → MuJoCo | valid ideal / MuJoCo |",
             "|---|---|---|---|---|"]
    rows = [[r["scenario"].replace("-r", " r"), r["planner"],
             f"{_num(r['score_ideal'], '.3f')} → {_num(r['score_mujoco'], '.3f')}",
             f"{_num(r['cost_ideal'], '.0f')} → {_num(r['cost_mujoco'], '.0f')}",
             f"{r['valid_ideal']}/{r['agents']} / {r['valid_mujoco']}/{r['agents']}"] for r in data["rows"]]
    return "\n".join(lines + _rows(rows) + _generated(name, data))


def printed_section(spec: str) -> str:
    """One section of what a benchmark printed: ``FILE,HEADING``, the printed lines from the first that starts with
    HEADING to the next blank line, under the benchmark's command."""
    name, _, heading = spec.partition(",")
    data = json.loads((RESULTS / name).read_text())
    lines = "\n".join(data["printed"]).splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(heading))
    end = next((i for i in range(start, len(lines)) if not lines[i].strip()), len(lines))
    return "\n".join(["```console", f"$ {data['command']}", "...", *lines[start:end], "```"] + _generated(name, data))


def export_maps_table(name: str) -> str:
    """bench/export/export.py's per-map table, built by the script's own ``table`` (what ``--table`` prints) from the
    results file."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("simgap_bench_export", ROOT / "bench" / "export" / "export.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    data = json.loads((RESULTS / name).read_text())
    return "\n".join([script.table(data["rows"] if isinstance(data, dict) else data)] + _generated(name, data))


def real_scenarios_table(name: str) -> str:
    """bench/recorded/real_scenarios.py: goals reached per world (its ``goal_rates``) and every run that missed,
    with the outcome and reason it printed (the script cuts a reason at 110 characters: marked …)."""
    data = json.loads((RESULTS / name).read_text())
    runs = [m.groups() for m in (re.match(r"(\S+)\s+(\w+)\s+(\w+)\s+[\d.]+  (.*)$", line)
                                 for line in "\n".join(data["printed"]).splitlines()) if m]
    lines = ["| world | goal reached | mean wall time per scenario | not reached: scenario, outcome (reason) |",
             "|---|---|---|---|"]
    rows = []
    for world, rate in data["goal_rates"].items():
        missed = [f"`{scenario}`, {outcome.replace('_', ' ')} ({reason.strip()}{'…' if len(reason) >= 110 else ''})"
                  for scenario, w, outcome, reason in runs if w == world and outcome != "goal_reached"]
        share = 100 * rate["goals"] / max(rate["agents"], 1)
        rows.append([world, f"{rate['goals']} / {rate['agents']} ({share:.0f} %)",
                     f"{rate['mean_wall_s']:.1f} s", "; ".join(missed) or "—"])
    return "\n".join(lines + _rows([[_fmt(c) for c in r] for r in rows]) + _generated(name, data))


def attribution_table(name: str) -> str:
    """bench/attribution/explain_paper_study.py: what was run and explained, how many explanations add up, the
    dominant assumption's counts per car and the cost (its results file's ``summary``), then a row per explained run
    (its ``rows``)."""
    data = json.loads((RESULTS / name).read_text())
    counts, rows = data["summary"], data["rows"]
    ran = data.get("curves_run")
    curves = ("its curves" if not ran else f"all {len(ran)} curves of the grid" if len(ran) == data["curves_in_grid"]
              else f"{len(ran)} of the grid's {data['curves_in_grid']} curves ({', '.join(ran)})")
    cost, cpu = counts["cost_ratio"], counts["cpu_ratio"]
    lines = [f"- **Run**: {counts['physical_runs']} MuJoCo runs on {curves}; **{counts['explained']} explained** "
             f"(failed, or parted from the ideal run by more than {data['arguments']['threshold']} m), "
             f"{counts['failed']} of them failed.",
             f"- **Adding up**: the shares of {counts['adds_up']} of {counts['explained']} add up to the gap measured "
             f"against the study's ideal run within 5 %"
             + "".join(f"; not: {r['curve']} {r['vehicle']} (sum/gap {r['sum_over_gap']:.3f})"
                       for r in rows if not r["adds_up"]) + ".",
             f"- **Fixed**: restoring the dominant assumption alone fixes the outcome of {counts['fixes_outcome']} of "
             f"the {counts['failed']} failed runs.",
             "- **Dominant assumption**, per car: " + "; ".join(
                 f"{car} ({counts['explained_per_car'][car]} explained): "
                 + (", ".join(f"`{a}` {n}" for a, n in dominant.items()) or "—")
                 for car, dominant in counts["dominant"].items()) + ".",
             f"- **Cost** (explanation wall time / the run's own wall time as its record keeps it, on "
             f"{data['arguments']['workers']} workers): median {_num(cost['median'], '.1f')}, largest "
             f"{_num(cost['max'], '.1f')}, {cost['over_8']} of {counts['explained']} over 8; processor time "
             f"(explanation / run): median {_num(cpu['median'], '.1f')}, largest {_num(cpu['max'], '.1f')}.", "",
             "| curve | car | outcome | gap [m] | dominant | fixes it alone | sum / gap | worlds | cut | explanation [s] "
             "| run [s] | wall ratio | processor ratio |", "|---|" + "---|" * 12]
    table = [[r["curve"], r["vehicle"], r["outcome"].replace("_", " "), f"{r['gap_m']:.3f}", f"`{r['dominant']}`",
              "yes" if r["fixes_outcome"] else "no", f"{r['sum_over_gap']:.3f}", str(r["runs"]),
              str(sum(w.get("until_s") is not None for w in r["explanation"].get("worlds", ()))), f"{r['wall_s']:.1f}",
              f"{r['run_wall_s']:.2f}", f"{r['cost_ratio']:.1f}", _num(r.get("cpu_ratio"), ".1f")] for r in rows]
    return "\n".join(lines + _rows(table) + _generated(name, data))


TABLES = {"printed": printed_block, "printed_section": printed_section, "planners": planner_table,
          "planner_scores": planner_scores_table, "frenetix": frenetix_table, "gaps": gaps_table,
          "road_3d": road_3d_table, "road_3d_grid": road_3d_grid_table, "recorded": recorded_table,
          "road_relief": road_relief_table, "realism_steps": realism_steps_table,
          "realism_tracking": realism_tracking_table, "vehicle_dynamics": vehicle_dynamics_table,
          "opendrive_import": opendrive_import_table, "export_maps": export_maps_table,
          "real_scenarios": real_scenarios_table, "attribution": attribution_table}


def render_results(which: str | None) -> str:
    kind, _, name = (which or "").partition(":")
    if name and kind in TABLES:
        return TABLES[kind](name)
    files = sorted(RESULTS.glob("*.json"))
    written_by = scripts()
    if which == "index":
        lines = ["| results file | written by | commit, date, machine, load |", "|---|---|---|"]
        for f in files:
            data = json.loads(f.read_text())
            lines.append(f"| [`{f.name}`](results.md#{f.stem.lower()}) | "
                         f"`{written_by.get(f.name, 'not in bench/README.md')}` | {provenance(data)} |")
        return "\n".join(lines)
    lines = []
    for f in files:
        data = json.loads(f.read_text())
        lines += [f"## {f.stem}", "",
                  f"`bench/results/{f.name}`, written by `{written_by.get(f.name, 'not in bench/README.md')}`; "
                  f"provenance: {provenance(data)}.", ""]
        lines += _section(data, 3)
    return "\n".join(lines)
