"""What `simgap export` writes, measured: the generated roads (curve, S-curve, T-junction,
intersection: OpenDRIVE exactly as built, and a run on each as OpenSCENARIO 1.2) and every
installed real map (OpenDRIVE fitted to the lanelets).

Per map: ASAM's Quality Checker (every checker of the OpenDRIVE bundle; errors and warnings, and
the checkers that did not run), the lane centres' distance from the lanelets' centre lines read
back from the file every 0.1 m (largest and 99th percentile), the lanelets' successor and neighbour
relations against those the file keeps (counted from the file), the junctions written, and the
time of the export (the first export of a process also loads the XSD schemas: shown apart). A
lanelet whose bounds cross or double back (a turn over 90 degrees between two segments) has no
faithful lane: the number of such lanelets is given per map. Results: bench/results/export.json.

    .venv/bin/python bench/export.py                  # generated roads and every real map
    .venv/bin/python bench/export.py --maps 5         # ... the first 5 maps
    .venv/bin/python bench/export.py --only DEU_AachenAseag-1 --only USA_Roundabout-1 --no-generated
                                                      # ... these maps only (results not saved)
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
import warnings
from dataclasses import asdict
from pathlib import Path

import numpy as np
from commonroad.scenario.lanelet import Lanelet
from shapely.geometry import LineString

from simgap.experiment.single_run import RunRequest, execute
from simgap.export import checks, quality_checker
from simgap.export.write import Export, export_road, export_run
from simgap.scenario import build_scenario, write_scenario
from simgap.scenario.real_maps import load_map, map_files, maps_dir

RESULTS = Path(__file__).parent / "results" / "export.json"
GENERATED = (("curve", {"radius": 10, "angle": 90, "transition": 5}), ("s-curve", {}), ("t-junction", {"agents": 3}),
             ("intersection", {"agents": 2}))


def malformed(lanelet: Lanelet) -> bool:
    """Bounds that cross each other or themselves, or double back."""
    left, right = LineString(lanelet.left_vertices), LineString(lanelet.right_vertices)
    if left.intersects(right) or not left.is_simple or not right.is_simple:
        return True
    for bound in (lanelet.left_vertices, lanelet.right_vertices):
        d = np.diff(bound, axis=0)
        d = d[np.linalg.norm(d, axis=1) > 1e-6]
        heading = np.arctan2(d[:, 1], d[:, 0])
        if len(heading) > 1 and np.max(np.abs(np.angle(np.exp(1j * np.diff(heading))))) > math.pi / 2:
            return True
    return False


def qc(path: Path) -> dict:
    try:
        report = quality_checker.check(path)
    except quality_checker.QualityCheckerMissing as missing:
        return {"missing": str(missing)}
    return {"errors": report.errors, "warnings": report.warnings, "rules": report.rules,
            "checkers": len(report.checkers),
            "not_run": {c.checker: c.summary.split(". ")[0] for c in report.skipped}}


def row(name: str, export: Export, road_qc: dict, malformed_lanelets: int | None = None, **extra) -> dict:
    links = export.links
    return {"map": name, "method": export.method.value, "roads": len(export.lane_deviation_m),
            "seconds": round(export.seconds, 2), "deviation_max_m": round(export.largest_deviation_m, 4),
            "deviation_p99_m": round(export.lane_deviation_p99_m, 4), "links": asdict(links),
            "qc": road_qc, "malformed_lanelets": malformed_lanelets, "notes": export.notes, **extra}


def show(r: dict) -> None:
    q, links = r["qc"], r["links"]
    verdict = q.get("missing") and "QC not installed" or \
        f"QC {q['errors']:>3} errors {q['warnings']:>3} warnings" + (f" ({len(q['not_run'])} not run)" if q["not_run"] else "")
    print(f"{r['map']:<30} {r['roads']:>4} {verdict:<36} {r['deviation_max_m']:>7.3f} {r['deviation_p99_m']:>7.3f} "
          f"{links['successors_kept']:>4}/{links['successors']:<4} {links['neighbours_kept']:>4}/{links['neighbours']:<4} "
          f"{links['junctions']:>3} {'' if r['malformed_lanelets'] is None else r['malformed_lanelets']:>4} "
          f"{r['seconds']:>6.2f}" + (f"  xosc: QC {r['xosc_qc']['errors']} errors {r['xosc_qc']['warnings']} warnings, "
                                    f"{len(r['xosc_qc']['not_run'])} not run" if "errors" in r.get("xosc_qc", {}) else ""))
    for rule, n in q.get("rules", {}).items():
        print(f"    {n} x {rule}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--maps", type=int, default=None, help="export only the first N real maps")
    parser.add_argument("--only", action="append", default=[], metavar="NAME",
                        help="export only the real map NAME (repeatable); the results file is left as it is")
    parser.add_argument("--no-generated", action="store_true", help="leave out the generated roads")
    args = parser.parse_args()
    t0 = time.perf_counter()
    for name in checks.SCHEMA_FILES.values():
        checks.schema(name)
    print(f"loading the {len(checks.SCHEMA_FILES)} XSD schemas: {time.perf_counter() - t0:.2f} s (once per process)\n")
    print(f"{'map':<30} {'roads':>4} {'ASAM QC (OpenDRIVE bundle)':<36} {'dev max':>7} {'p99':>7} "
          f"{'successors':>9} {'neighbours':>9} {'jct':>3} {'bad':>4} {'time s':>6}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for logical, params in ([] if args.no_generated else GENERATED):
            xml = write_scenario(build_scenario(logical, params), tmp / "scenarios", preview=False)
            run_dir = tmp / "runs" / xml.stem
            execute(RunRequest(scenario=xml), run_dir)
            export = export_run(run_dir, tmp / "out")
            xodr, xosc = export.files
            rows.append(row(logical, export, qc(xodr), xosc_qc=qc(xosc)))
            show(rows[-1])
        maps = map_files()[: args.maps] if args.maps else map_files()
        if args.only:
            maps = [m for m in map_files() if m.stem in args.only]
            missing = set(args.only) - {m.stem for m in maps}
            if missing:
                parser.error(f"no such real map: {', '.join(sorted(missing))}")
        if not maps:
            print(f"\nno real maps in {maps_dir()}")
        for path in maps:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                bad = sum(malformed(l) for l in load_map(path).lanelet_network.lanelets)
                export = export_road(path, tmp / "maps")
            rows.append(row(path.stem, export, qc(export.files[0]), bad))
            show(rows[-1])
    real = [r for r in rows if r["method"] == "fitted"]
    if real:
        clean = [r for r in real if r["malformed_lanelets"] == 0]
        print(f"\n{len(real)} real maps: QC errors {sum(r['qc'].get('errors', 0) for r in real)}, warnings "
              f"{sum(r['qc'].get('warnings', 0) for r in real)}; successors kept "
              f"{sum(r['links']['successors_kept'] for r in real)}/{sum(r['links']['successors'] for r in real)}, "
              f"neighbours {sum(r['links']['neighbours_kept'] for r in real)}/"
              f"{sum(r['links']['neighbours'] for r in real)}; deviation max median "
              f"{np.median([r['deviation_max_m'] for r in real]):.3f} m, p99 median "
              f"{np.median([r['deviation_p99_m'] for r in real]):.3f} m; on the {len(clean)} maps without malformed "
              f"lanelets the largest deviation is {max((r['deviation_max_m'] for r in clean), default=0):.3f} m; "
              f"export time median {np.median([r['seconds'] for r in real]):.2f} s, "
              f"max {max(r['seconds'] for r in real):.2f} s")
    if args.only or args.no_generated or args.maps:
        print("\nresults not saved (a subset of the maps)")
        return
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text(json.dumps(rows, indent=1) + "\n")
    print(f"\nresults: {RESULTS}")


if __name__ == "__main__":
    main()
