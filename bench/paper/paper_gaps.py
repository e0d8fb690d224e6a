"""The cross-fidelity gaps of a finished paper study (`bench/paper/paper_study.py --out DIR`): per
vehicle, the largest lateral displacement max |d| between the ideal and the MuJoCo run of each
curve (by arc length, as `simgap compare` and the report's heatmaps compute it), as a radius x
angle table, with its median and where it is largest.

Usage: python bench/paper/paper_gaps.py DIR [DIR2]
With two study directories (e.g. before and after a change) it prints both and the change of
each vehicle's median and largest gap. No pass/fail.
"""

from __future__ import annotations

import argparse
import statistics
from collections import defaultdict
from pathlib import Path

from simgap.files import BenchmarkResults
from simgap.report.collection import collect


def gaps(study: Path) -> dict[str, dict[tuple[float, float], float]]:
    """max |d| by fidelity label and (radius, angle)."""
    table: dict[str, dict[tuple[float, float], float]] = defaultdict(dict)
    for group in collect(study / "runs"):
        key = (float(group.parameters.get("radius", 0)), float(group.parameters.get("angle", 0)))
        for fidelity, comparisons in group.comparisons.items():
            table[fidelity][key] = max(c.lateral_displacement.max for c in comparisons)
    return table


def print_table(name: str, cells: dict[tuple[float, float], float]) -> None:
    radii = sorted({r for r, _ in cells})
    angles = sorted({a for _, a in cells})
    print(f"\n{name}: max |d| [m] between the ideal and the MuJoCo run (rows: radius [m], columns: angle [deg])")
    corner = "r / angle"
    print(f"{corner:>9} " + " ".join(f"{a:>6.0f}" for a in angles))
    for r in radii:
        print(f"{r:>9.0f} " + " ".join(f"{cells.get((r, a), float('nan')):>6.2f}" for a in angles))
    worst = max(cells, key=cells.get)
    print(f"median {statistics.median(cells.values()):.3f} m, largest {cells[worst]:.3f} m at r = {worst[0]:g} m, "
          f"angle = {worst[1]:g} deg ({len(cells)} curves)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("studies", nargs="+", type=Path)
    parser.add_argument("--json", type=Path, metavar="FILE",
                        help="also write what is printed, with commit, date, machine and load, to this results file")
    args = parser.parse_args()
    results_file = BenchmarkResults(tee=args.json)
    summaries = []
    for study in args.studies:
        print(f"\n# {study}")
        table = gaps(study)
        for fidelity in sorted(table):
            print_table(fidelity, table[fidelity])
        summaries.append({f: (statistics.median(c.values()), max(c.values())) for f, c in table.items()})
    if len(summaries) == 2:
        print(f"\n# change, {args.studies[0]} -> {args.studies[1]}: median and largest max |d| [m]")
        for fidelity in sorted(set(summaries[0]) & set(summaries[1])):
            (m0, x0), (m1, x1) = summaries[0][fidelity], summaries[1][fidelity]
            print(f"{fidelity:<14} median {m0:.3f} -> {m1:.3f} ({m1 / m0:.2f}x), largest {x0:.3f} -> {x1:.3f}")
    if args.json:
        results_file.write(args.json, {"arguments": vars(args)})


if __name__ == "__main__":
    main()
