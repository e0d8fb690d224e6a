"""Time per export and the deviations of the written roads: a curve and a T-junction (runs in the
ideal world, exported as OpenSCENARIO + OpenDRIVE, exact geometry) and the installed real maps
(their road networks exported as OpenDRIVE, fitted lanelet by lanelet).

For every export: the files, the time (the first export of a process also loads the XSD schemas:
shown apart), the largest distance of a lane centre, read back from the file every metre, from
its lanelets' centre, and for fitted maps the fit's deviation from the lanelet bounds per road
(largest, 95th percentile and median over the map's roads).

    .venv/bin/python bench/export.py                  # curve, T-junction, every real map
    .venv/bin/python bench/export.py --maps 5         # ... the first 5 maps
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from simgap.experiment.single_run import RunRequest, execute
from simgap.export import checks
from simgap.export.write import export_road, export_run
from simgap.scenario import build_scenario, write_scenario
from simgap.scenario.real_maps import map_files, maps_dir


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--maps", type=int, default=None, help="export only the first N real maps")
    args = parser.parse_args()
    t0 = time.perf_counter()
    for name in checks.SCHEMA_FILES.values():
        checks.schema(name)
    print(f"loading the {len(checks.SCHEMA_FILES)} XSD schemas: {time.perf_counter() - t0:.2f} s (once per process)\n")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print("runs (ideal world) as OpenSCENARIO 1.0 + OpenDRIVE 1.7")
        print(f"{'scenario':<34} {'roads':>5} {'entities':>8} {'lane centres max [m]':>21} "
              f"{'trajectory max [m]':>19} {'export [s]':>10}")
        for logical, params in (("curve", {"radius": 10, "angle": 90, "transition": 5}),
                                ("t-junction", {"agents": 3})):
            xml = write_scenario(build_scenario(logical, params), tmp / "scenarios", preview=False)
            run_dir = tmp / "runs" / xml.stem
            execute(RunRequest(scenario=xml), run_dir)
            e = export_run(run_dir, tmp / "out")
            per_road = ", ".join(f"{r}: {d:.4f}" for r, d in sorted(e.lane_deviation_m.items()))
            print(f"{xml.stem:<34} {len(e.lane_deviation_m):>5} {e.entities:>8} {e.largest_deviation_m:>21.4f} "
                  f"{e.trajectory_error_m:>19.1e} {e.seconds:>10.2f}")
            print(f"    files: {', '.join(p.name for p in e.files)} ({sum(p.stat().st_size for p in e.files) / 1e3:.0f} kB)"
                  f"; per road: {per_road}")
        maps = map_files()[: args.maps] if args.maps else map_files()
        if not maps:
            print(f"\nno real maps in {maps_dir()}")
            return
        print(f"\nreal maps as OpenDRIVE 1.7, fitted (a road per lanelet); deviations per road [m]")
        print(f"{'map':<34} {'roads':>5} {'fit max':>8} {'fit p95':>8} {'median':>8} {'file max':>8} "
              f"{'kB':>6} {'export [s]':>10}")
        worst, times = [], []
        for path in maps:
            e = export_road(path, tmp / "maps")
            fit = np.array(list(e.fit_deviation_m.values()))
            worst.append(fit.max())
            times.append(e.seconds)
            print(f"{path.stem:<34} {len(fit):>5} {fit.max():>8.3f} {np.percentile(fit, 95):>8.3f} "
                  f"{np.median(fit):>8.3f} {e.largest_deviation_m:>8.3f} {e.files[0].stat().st_size / 1e3:>6.0f} "
                  f"{e.seconds:>10.2f}")
        print(f"\n{len(maps)} maps: largest fit deviation median {np.median(worst):.3f} m, max {max(worst):.3f} m; "
              f"export time median {np.median(times):.2f} s, max {max(times):.2f} s")


if __name__ == "__main__":
    main()
