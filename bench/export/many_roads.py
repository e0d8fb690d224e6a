"""`simgap export` of a scenario with many roads: how long it takes and what its progress costs.

The scenario is synthetic: ROADS straight one-lane lanelets, 20 m long and 3.5 m wide, side by
side on a grid 30 m apart and unrelated to each other, so the fitted export makes one road of
each. The export runs as the user runs it (`simgap export X.xml --format opendrive`), once with
its progress bars forced onto standard error (``SIMGAP_PROGRESS=always``, written to a file) and
once without (``never``); each time its wall and CPU time, and for the first the time until the
bars first drew and the last bars drawn (each phase, its count, elapsed and remaining time).

    PYTHONPATH=src nice python bench/export/many_roads.py --roads 300 [--repeats 2]   # bars against none
    PYTHONPATH=src nice python bench/export/many_roads.py --roads 20000 --repeats 1 --only-bars
    ... --write FILE.xml --roads N     # only write the scenario

Results: bench/results/many_roads_<ROADS>.json.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from simgap.files import BenchmarkResults

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "bench" / "results"
LENGTH_M, WIDTH_M, SPACING_M, PER_ROW = 20.0, 3.5, 30.0, 100
_ESCAPE = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _bound(x0: float, y: float) -> str:
    points = "".join(f"<point><x>{x0 + LENGTH_M * k / 4:g}</x><y>{y:g}</y></point>" for k in range(5))
    return f"{points}<lineMarking>solid</lineMarking>"


def many_roads_xml(path: Path, roads: int) -> Path:
    """A CommonRoad scenario of ``roads`` unrelated straight lanelets (no planning problem) at ``path``."""
    parts = ["<?xml version='1.0' encoding='UTF-8'?>\n",
             '<commonRoad timeStepSize="0.1" commonRoadVersion="2020a" author="simgap bench" affiliation="" '
             f'source="bench/export/many_roads.py" benchmarkID="ZAM_ManyRoads-{roads}" date="2026-12-02">',
             "<location><geoNameId>-999</geoNameId><gpsLatitude>999</gpsLatitude><gpsLongitude>999</gpsLongitude>"
             "</location><scenarioTags/>"]
    for i in range(roads):
        x0, y0 = SPACING_M * (i % PER_ROW), SPACING_M * (i // PER_ROW)
        parts.append(f'<lanelet id="{1000 + i}"><leftBound>{_bound(x0, y0 + WIDTH_M / 2)}</leftBound><rightBound>'
                     f"{_bound(x0, y0 - WIDTH_M / 2)}</rightBound><laneletType>urban</laneletType></lanelet>")
    parts.append("</commonRoad>\n")
    path.write_text("".join(parts))
    return path


def last_bars(stderr: str) -> list[str]:
    """Each phase's bar as it was drawn last, escape codes removed, in the order the phases began."""
    last: dict[str, str] = {}
    for line in _ESCAPE.sub("", stderr).replace("\r", "\n").splitlines():
        if "elapsed," in line:
            last[line.split("  ")[0].split(" ━")[0].strip()] = " ".join(line.split())
    return list(last.values())


def export(xml: Path, out: Path, bars: bool, stderr_file: Path) -> dict:
    """One `simgap export` of ``xml``: its wall and CPU time, and with ``bars`` when they first drew."""
    env = dict(os.environ, SIMGAP_PROGRESS="always" if bars else "never", COLUMNS="150")
    env["PYTHONPATH"] = os.pathsep.join([str(REPO / "src")] + [p for p in [env.get("PYTHONPATH")] if p])
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    first_drawn = None
    with stderr_file.open("w") as err:
        proc = subprocess.Popen([sys.executable, "-m", "simgap", "export", str(xml), "--format", "opendrive",
                                 "--out", str(out), "--overwrite"], stdout=subprocess.PIPE, stderr=err, text=True,
                                env=env)
        while proc.poll() is None:
            if first_drawn is None and bars and stderr_file.stat().st_size > 0:
                first_drawn = time.perf_counter() - started
            time.sleep(0.05)
        stdout = proc.stdout.read()
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    row = {"bars": bars, "exit": proc.returncode, "wall_s": round(wall, 2),
           "cpu_s": round(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, 2),
           "stdout_first_line": stdout.splitlines()[0] if stdout else ""}
    if bars:
        text = stderr_file.read_text(errors="replace")
        row |= {"first_bar_after_s": None if first_drawn is None else round(first_drawn, 2),
                "stderr_bytes": len(text), "last_bars": last_bars(text)}
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--roads", type=int, default=300, help="roads of the scenario")
    parser.add_argument("--repeats", type=int, default=2, help="exports of each kind, alternating")
    parser.add_argument("--only-bars", action="store_true", help="time the export with its bars only")
    parser.add_argument("--write", type=Path, help="only write the scenario to this file")
    args = parser.parse_args(argv)
    if args.write:
        many_roads_xml(args.write, args.roads)
        return 0
    results = BenchmarkResults()
    rows = []
    with tempfile.TemporaryDirectory(prefix="simgap-many-roads-") as tmp:
        xml = many_roads_xml(Path(tmp) / f"roads_{args.roads}.xml", args.roads)
        kinds = [True] if args.only_bars else [True, False]
        for repeat in range(args.repeats):
            for bars in kinds if repeat % 2 == 0 else kinds[::-1]:
                row = export(xml, Path(tmp) / "out", bars, Path(tmp) / "stderr.txt")
                rows.append(row)
                print(f"{args.roads} roads, bars {'on ' if bars else 'off'}: exit {row['exit']}, "
                      f"wall {row['wall_s']:.1f} s, CPU {row['cpu_s']:.1f} s"
                      + (f", first bar after {row['first_bar_after_s']} s" if bars else ""), flush=True)
                for line in row.get("last_bars", []):
                    print(f"    {line}")
    figures = {"roads": args.roads, "rows": rows}
    for key in ("wall_s", "cpu_s"):
        on = [r[key] for r in rows if r["bars"]]
        off = [r[key] for r in rows if not r["bars"]]
        if on and off:
            figures[f"{key}_ratio_bars_to_none"] = round(min(on) / min(off), 3)
            print(f"{key}: best with bars {min(on):.1f}, without {min(off):.1f}: "
                  f"ratio {figures[f'{key}_ratio_bars_to_none']:.3f}")
    results.write(RESULTS / f"many_roads_{args.roads}.json", figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
