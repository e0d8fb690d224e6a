"""The Validation pages' tables, generated from the benchmarks' results files (bench/results/*.json).

``render_results("index")`` is the list of results files with their provenance and the script that
wrote each (from bench/README.md's table); ``render_results("all")`` shows every file's figures as
tables: a list of records as rows, a mapping of records as rows keyed by name, scalars as name and
value. Nothing here is typed: a figure on these pages is the file's.
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
    return ", ".join(f"{k} {v}" for k, v in found.items())


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


def recorded_table(name: str) -> str:
    """Goals reached per world and kind, from a results file of bench/recorded/real_recorded.py (its records:
    scenario, kind, world, agent, outcome, reason, wall_s, excluded, human); agents that start in a
    collision or overhanging the road (``excluded``) are not counted, as the benchmark prints."""
    data = json.loads((RESULTS / name).read_text())
    records = data["rows"] if isinstance(data, dict) else data
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


def render_results(which: str | None) -> str:
    if which and which.startswith("recorded:"):
        return recorded_table(which.split(":", 1)[1])
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
