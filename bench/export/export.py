"""What `simgap export` writes, measured: the generated roads (curve, S-curve, T-junction,
intersection: OpenDRIVE exactly as built, and a run on each as OpenSCENARIO 1.2) and every
installed real map (OpenDRIVE fitted to the lanelets).

Per map: ASAM's Quality Checker (every checker of the OpenDRIVE bundle; errors and warnings, and
the checkers that did not run), the lane centres' distance from the lanelets' centre lines read
back from the file every 0.1 m (largest and 99th percentile), the lanelets' successor and neighbour
relations against those the file keeps (counted from the file), the junctions written, and the
time of the export (the first export of a process also loads the XSD schemas: shown apart). A
lanelet whose bounds cross, double back (a turn over 90 degrees between two segments) or step
sideways (a segment over 0.5 m at more than 60 degrees to both its neighbours) has no faithful
lane: such lanelets are named per map with the reason, with the roads over 0.1 m (and whether a
malformed lanelet is among their lanes) and the largest deviation on the roads without one. Every
relation the file does not keep is counted by why (lanelets that do not touch, neighbours whose
ends differ, a one-sided relation in the source, ...). Results: bench/results/export.json.

    .venv/bin/python bench/export/export.py                  # generated roads and every real map
    .venv/bin/python bench/export/export.py --maps 5         # ... the first 5 maps
    .venv/bin/python bench/export/export.py --only DEU_AachenAseag-1 --only USA_Roundabout-1 --no-generated
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
import shapely
from commonroad.scenario.lanelet import Lanelet
from shapely.geometry import LineString

from simgap.experiment.single_run import RunRequest, execute
from simgap.export import checks, quality_checker, road_topology
from simgap.export.write import Export, export_road, export_run
from simgap.files import BenchmarkResults
from simgap.scenario import build_scenario, write_scenario
from simgap.scenario.real_maps import load_map, map_files, maps_dir

RESULTS = Path(__file__).resolve().parents[1] / "results" / "export.json"
GENERATED = (("curve", {"radius": 10, "angle": 90, "transition": 5}), ("s-curve", {}), ("t-junction", {"agents": 3}),
             ("intersection", {"agents": 2}))


STEP_M = 0.5                # a bound segment longer than this ...
STEP_TURN = math.radians(60)  # ... at more than this to the segments on both sides of it: a sideways step


def malformed_reason(lanelet: Lanelet) -> str | None:
    """Why the lanelet has no faithful lane, or None: bounds that cross each other or themselves,
    double back (a turn over 90 degrees between two segments) or step sideways (a segment over
    `STEP_M` at more than 60 degrees to both its neighbours: the lane jumps across)."""
    left, right = LineString(lanelet.left_vertices), LineString(lanelet.right_vertices)
    if left.intersects(right):
        return "bounds cross"
    if not left.is_simple or not right.is_simple:
        return "a bound crosses itself"
    for side, bound in (("left", lanelet.left_vertices), ("right", lanelet.right_vertices)):
        d = np.diff(bound, axis=0)
        d = d[np.linalg.norm(d, axis=1) > 1e-6]
        heading = np.arctan2(d[:, 1], d[:, 0])
        turn = np.abs(np.angle(np.exp(1j * np.diff(heading))))
        if len(heading) > 1 and np.max(turn) > math.pi / 2:
            return f"{side} bound doubles back ({math.degrees(np.max(turn)):.0f} deg)"
        length = np.linalg.norm(d, axis=1)
        steps = [k for k in range(1, len(heading) - 1)
                 if length[k] > STEP_M and turn[k - 1] > STEP_TURN and turn[k] > STEP_TURN]
        if steps:
            return f"{side} bound steps sideways {max(length[k] for k in steps):.1f} m"
    return None


def malformed(lanelet: Lanelet) -> bool:
    return malformed_reason(lanelet) is not None


def common_m(a: Lanelet, b: Lanelet) -> float:
    """How long a stretch of ``a``'s bound towards its neighbour ``b`` lies within 0.1 m of ``b``'s bound facing it."""
    left = a.adj_left == b.lanelet_id
    same = a.adj_left_same_direction if left else a.adj_right_same_direction
    ours = LineString(a.left_vertices if left else a.right_vertices)
    theirs = LineString((b.right_vertices if left else b.left_vertices) if same else
                        (b.left_vertices if left else b.right_vertices))     # the bound facing ours
    s = np.arange(0.0, ours.length, 0.1)
    return float(np.sum(shapely.distance(theirs, shapely.line_interpolate_point(ours, s)) <= 0.1) * 0.1)


UNREPRESENTABLE = "not representable:"   # reasons that no OpenDRIVE file could keep start with this


def representable(r: dict) -> dict:
    """Per kind (successors, neighbours): the source's relations less those no file could keep
    (lanelets that do not touch, V-shaped neighbours, one-sided relations, overlapping lanelets that
    run the same way but are called opposite neighbours), the file's of them and
    how many were not representable."""
    out = {}
    for kind in ("successors", "neighbours"):
        unrep = sum(n for why, n in r.get("lost", {}).get(kind, {}).items() if why.startswith(UNREPRESENTABLE))
        out[kind] = {"source": r["links"][kind], "not_representable": unrep,
                     "representable": r["links"][kind] - unrep, "kept": r["links"][f"{kind}_kept"]}
    return out


OVERLAP_SHARE = 0.5      # neighbours whose areas overlap by more than this share of the smaller one are not lanes


def overlap_share(a: Lanelet, b: Lanelet) -> float:
    """How much of the smaller lanelet's area the two lanelets share."""
    pa, pb = a.polygon.shapely_object, b.polygon.shapely_object
    return float(pa.intersection(pb).area / max(min(pa.area, pb.area), 1e-9)) if pa.is_valid and pb.is_valid else 0.0


def same_way(a: Lanelet, b: Lanelet) -> bool:
    """Whether the two lanelets run the same way (their chords from start to end within 90 degrees)."""
    da, db = a.center_vertices[-1] - a.center_vertices[0], b.center_vertices[-1] - b.center_vertices[0]
    return float(da @ db) > 0.0


def lost_relations(network, links) -> dict:
    """Why each relation the file does not keep is lost, counted by reason."""
    by_id = {l.lanelet_id: l for l in network.lanelets}
    successors: dict[str, int] = {}
    for a, b in links.lost_successors:
        la, lb = by_id[a], by_id[b]
        gap = road_topology._gap(la, lb)
        left = float(np.linalg.norm(la.left_vertices[-1] - lb.left_vertices[0]))
        right = float(np.linalg.norm(la.right_vertices[-1] - lb.right_vertices[0]))
        reason = (f"{UNREPRESENTABLE} the source's lanelets do not touch ({a}->{b}: left bounds {left:.1f} m, "
                  f"right bounds {right:.1f} m apart)" if gap > road_topology.JOINABLE_M else "other")
        successors[reason] = successors.get(reason, 0) + 1
    neighbours: dict[str, int] = {}
    for a, b in links.lost_neighbours:
        la, lb = by_id[a], by_id[b]
        same = la.adj_left_same_direction if la.adj_left == b else la.adj_right_same_direction
        if a not in (lb.adj_left, lb.adj_right):
            reason = f"{UNREPRESENTABLE} one-sided in the source (the neighbour does not name the lanelet back)"
        elif common_m(la, lb) < max(1.0, 0.1 * min(LineString(la.center_vertices).length,
                                                 LineString(lb.center_vertices).length)):
            reason = (f"{UNREPRESENTABLE} their bounds meet at one end only and part (V-shaped merge or split, or a gap opening "
                      "between them): no common border")
        elif same and not road_topology._shares_bound(
                la.left_vertices if la.adj_left == b else la.right_vertices,
                lb.right_vertices if la.adj_left == b else lb.left_vertices):
            reason = "same direction, ends differ by more than 0.1 m (needs lanes beginning/ending inside a road)"
            if malformed(la) or malformed(lb):
                reason += "; one of them malformed"
        elif not same and road_topology._opposite(la, by_id) is lb:
            reason = "opposite direction, two roads: their lanes end askew (skew guard)"
        elif not same and overlap_share(la, lb) > OVERLAP_SHARE and same_way(la, lb):
            reason = (f"{UNREPRESENTABLE} the lanelets overlap (over {OVERLAP_SHARE:.0%} of the smaller) and run the "
                      f"same way, though the source calls them opposite neighbours (no two lanes of a file overlap)")
        elif not same and la.adj_right == b and lb.adj_right == a:
            reason = ("opposite direction on both lanelets' right (a left-hand-traffic pair: a road with "
                      "rule LHT, not written)")
        elif not same:
            reason = "opposite direction, not one road (ends differ or groups not paired)"
        else:
            reason = "same direction, other (not one lateral group)"
        neighbours[reason] = neighbours.get(reason, 0) + 1
    return {"successors": successors, "neighbours": neighbours}


def qc(path: Path) -> dict:
    try:
        report = quality_checker.check(path)
    except quality_checker.QualityCheckerMissing as missing:
        return {"missing": str(missing)}
    return {"errors": report.errors, "warnings": report.warnings, "rules": report.rules,
            "checkers": len(report.checkers),
            "not_run": {c.checker: c.summary.split(". ")[0] for c in report.skipped}}


def row(name: str, export: Export, road_qc: dict, bad: dict[int, str] | None = None, network=None,
        **extra) -> dict:
    links = asdict(export.links)
    lost_successors, lost_neighbours = links.pop("lost_successors"), links.pop("lost_neighbours")
    out = {"map": name, "method": export.method.value, "roads": len(export.lane_deviation_m),
           "seconds": round(export.seconds, 2), "deviation_max_m": round(export.largest_deviation_m, 4),
           "deviation_p99_m": round(export.lane_deviation_p99_m, 4), "links": links,
           "qc": road_qc, "malformed_lanelets": None if bad is None else len(bad), "notes": export.notes, **extra}
    if bad is not None:
        out["malformed"] = {str(i): why for i, why in sorted(bad.items())}
        # the roads beyond 0.1 m, and the largest deviation on roads none of whose lanes stands for
        # a malformed lanelet (where the map's excess is not at a malformed lanelet)
        worst = sorted(((d, r) for r, d in export.lane_deviation_m.items() if d > 0.1), reverse=True)
        out["roads_over_0.1_m"] = [{"road": r, "deviation_m": round(d, 3), "lanelets": list(export.road_lanelets[r]),
                                    "malformed": sorted(set(export.road_lanelets[r]) & set(bad))} for d, r in worst]
        out["deviation_max_without_malformed_m"] = round(max(
            (d for r, d in export.lane_deviation_m.items() if not set(export.road_lanelets[r]) & set(bad)),
            default=0.0), 4)
        out["lost"] = lost_relations(network, export.links)
        out["lost"]["successor_relations"] = [list(r) for r in lost_successors]
        out["lost"]["neighbour_relations"] = [list(r) for r in lost_neighbours]
    out["representable"] = representable(out)
    return out


def show(r: dict) -> None:
    q, links = r["qc"], r["links"]

    def kept_of(kind: str) -> str:       # kept of the representable (not representable in brackets)
        k = r["representable"][kind]
        return f"{k['kept']:>4}/{k['representable']:<4}" + f"({k['not_representable']})".ljust(6)
    verdict = q.get("missing") and "QC not installed" or \
        f"QC {q['errors']:>3} errors {q['warnings']:>3} warnings" + (f" ({len(q['not_run'])} not run)" if q["not_run"] else "")
    print(f"{r['map']:<30} {r['roads']:>4} {verdict:<36} {r['deviation_max_m']:>7.3f} {r['deviation_p99_m']:>7.3f} "
          f"{links['successors_kept']:>4}/{links['successors']:<4} {links['neighbours_kept']:>4}/{links['neighbours']:<4} "
          f"{kept_of('successors')} {kept_of('neighbours')} "
          f"{links['junctions']:>3} {'' if r['malformed_lanelets'] is None else r['malformed_lanelets']:>4} "
          f"{r['seconds']:>6.2f}" + (f"  xosc: QC {r['xosc_qc']['errors']} errors {r['xosc_qc']['warnings']} warnings, "
                                    f"{len(r['xosc_qc']['not_run'])} not run" if "errors" in r.get("xosc_qc", {}) else ""))
    for rule, n in q.get("rules", {}).items():
        print(f"    {n} x {rule}")
    if r.get("malformed"):
        print(f"    malformed: {', '.join(f'{i} ({why})' for i, why in r['malformed'].items())}; largest deviation "
              f"on roads without them {r['deviation_max_without_malformed_m']:.3f} m")
    for road in r.get("roads_over_0.1_m", [])[:4]:
        print(f"    road {road['road']}: {road['deviation_m']:.3f} m, lanelets {road['lanelets']}"
              + (f" (malformed: {road['malformed']})" if road["malformed"] else ""))
    for kind in ("successors", "neighbours"):
        for reason, n in r.get("lost", {}).get(kind, {}).items():
            print(f"    {kind} lost: {n} x {reason}")


SHORT = (("do not touch", "do not touch"), ("one-sided", "one-sided"), ("V-shaped", "V"), ("overlap", "overlapping"),
         ("skew guard", "skew"), ("not one road", "opposite, not paired"), ("ends differ", "ends differ"))


def table(rows: list[dict]) -> str:
    """The per-map table of docs/tutorials/export.md (markdown) from the bench's results: relations
    kept of the source's and of those a file can represent (not representable in brackets: lanelets
    that do not touch, V-shaped, one-sided or overlapping neighbours), and why the others are lost
    (not representable ones marked *)."""
    out = ["| map | roads | ASAM QC errors / warnings | lane centres max / p99 [m] | max on roads without malformed "
           "lanelets [m] | successors kept | neighbours kept | successors kept of representable (not) | neighbours "
           "kept of representable (not) | junctions | malformed lanelets | export [s] | relations not kept: why "
           "(* not representable) |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---|"]
    for r in rows:
        q, links = r["qc"], r["links"]
        qc_cell = f"{q.get('errors', '?')} / {q.get('warnings', '?')}" + (
            f" (.xosc {r['xosc_qc']['errors']} / {r['xosc_qc']['warnings']})" if "errors" in r.get("xosc_qc", {}) else "")
        rep = r.get("representable")
        kept_of = {k: (f"{rep[k]['kept']}/{rep[k]['representable']} ({rep[k]['not_representable']})" if rep else
                       f"{links[k + '_kept']}/{links[k]} (0)") for k in ("successors", "neighbours")}
        why = []
        for kind in ("successors", "neighbours"):
            counts: dict[str, int] = {}
            for reason, n in r.get("lost", {}).get(kind, {}).items():
                label = next((short for key, short in SHORT if key in reason), "other")
                label += "*" if reason.startswith(UNREPRESENTABLE) else ""
                counts[label] = counts.get(label, 0) + n
            if counts:
                why.append(f"{kind}: " + ", ".join(f"{n} {label}" for label, n in counts.items()))
        bad = r.get("malformed")
        out.append(f"| {r['map']} | {r['roads']} | {qc_cell} | {r['deviation_max_m']:.3f} / {r['deviation_p99_m']:.3f} | "
                   f"{'' if r['malformed_lanelets'] is None else format(r['deviation_max_without_malformed_m'], '.3f')} | "
                   f"{links['successors_kept']}/{links['successors']} | {links['neighbours_kept']}/{links['neighbours']} | "
                   f"{kept_of['successors']} | {kept_of['neighbours']} | {links['junctions']} | "
                   f"{'' if bad is None else (', '.join(bad) or 0)} | {r['seconds']:.2f} | {'; '.join(why)} |")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--maps", type=int, default=None, help="export only the first N real maps")
    parser.add_argument("--only", action="append", default=[], metavar="NAME",
                        help="export only the real map NAME (repeatable); the results file is left as it is")
    parser.add_argument("--no-generated", action="store_true", help="leave out the generated roads")
    parser.add_argument("--table", action="store_true",
                        help="print the per-map table of docs/tutorials/export.md from the saved results and stop")
    args = parser.parse_args()
    if args.table:
        saved = json.loads(RESULTS.read_text())
        print(table(saved["rows"] if isinstance(saved, dict) else saved))
        return
    results_file = BenchmarkResults()
    t0 = time.perf_counter()
    for name in checks.SCHEMA_FILES.values():
        checks.schema(name)
    print(f"loading the {len(checks.SCHEMA_FILES)} XSD schemas: {time.perf_counter() - t0:.2f} s (once per process)\n")
    print(f"{'map':<30} {'roads':>4} {'ASAM QC (OpenDRIVE bundle)':<36} {'dev max':>7} {'p99':>7} "
          f"{'successors':>9} {'neighbours':>9} {'succ/repr (not)':>15} {'nbr/repr (not)':>15} {'jct':>3} {'bad':>4} {'time s':>6}")
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
                network = load_map(path).lanelet_network
                bad = {l.lanelet_id: why for l in network.lanelets if (why := malformed_reason(l))}
                export = export_road(path, tmp / "maps")
            rows.append(row(path.stem, export, qc(export.files[0]), bad, network))
            show(rows[-1])
    real = [r for r in rows if r["method"] == "fitted"]
    if real:
        clean = [r for r in real if r["malformed_lanelets"] == 0]
        print(f"\n{len(real)} real maps: QC errors {sum(r['qc'].get('errors', 0) for r in real)}, warnings "
              f"{sum(r['qc'].get('warnings', 0) for r in real)}; successors kept "
              f"{sum(r['links']['successors_kept'] for r in real)}/{sum(r['links']['successors'] for r in real)}, "
              f"neighbours {sum(r['links']['neighbours_kept'] for r in real)}/"
              f"{sum(r['links']['neighbours'] for r in real)}; of the representable (less lanelets that do not touch, V-shaped, "
              f"one-sided and overlapping neighbours): successors "
              f"{sum(r['representable']['successors']['kept'] for r in real)}/"
              f"{sum(r['representable']['successors']['representable'] for r in real)} "
              f"({sum(r['representable']['successors']['not_representable'] for r in real)} not representable), "
              f"neighbours {sum(r['representable']['neighbours']['kept'] for r in real)}/"
              f"{sum(r['representable']['neighbours']['representable'] for r in real)} "
              f"({sum(r['representable']['neighbours']['not_representable'] for r in real)} not representable); "
              f"deviation max median "
              f"{np.median([r['deviation_max_m'] for r in real]):.3f} m, p99 median "
              f"{np.median([r['deviation_p99_m'] for r in real]):.3f} m; on the {len(clean)} maps without malformed "
              f"lanelets the largest deviation is {max((r['deviation_max_m'] for r in clean), default=0):.3f} m, on "
              f"roads without malformed lanelets (all maps) "
              f"{max(r['deviation_max_without_malformed_m'] for r in real):.3f} m; "
              f"export time median {np.median([r['seconds'] for r in real]):.2f} s, "
              f"max {max(r['seconds'] for r in real):.2f} s")
    if args.only or args.no_generated or args.maps:
        print("\nresults not saved (a subset of the maps)")
        return
    results_file.write(RESULTS, rows)
    print(f"\nresults: {RESULTS}")


if __name__ == "__main__":
    main()
