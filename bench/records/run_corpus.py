"""Every scenario file below a folder run with `simgap run`'s own code path into run directories
(``OUT/<world>/<file>/``), for `compare_studies.py` to compare two versions of simgap on data we
did not make (the recorded corpus). It uses only what every version of simgap has
(`RunRequest`, `execute`, `CosimSettings`), so the same command runs the code before a change
(``PYTHONPATH=<old checkout>/src``) and after it.

    python bench/records/run_corpus.py --files /work/corpus/recorded --worlds ideal mujoco \\
        --latency 0.1 --workers 2 --out /tmp/corpus-after

A fixed plan latency makes the physical worlds' runs independent of the machine's load. A run
that raises is kept as ``OUT/<world>/<file>.error`` with its exception.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
import traceback
from pathlib import Path


def run_one(task: tuple[Path, str, float | None, Path, bool]) -> tuple[str, str, float]:
    xml, world, latency, out, validate = task
    from simgap.cosim import CosimSettings
    from simgap.experiment.single_run import RunRequest, execute

    target = out / world / xml.stem
    clock = time.perf_counter()
    try:
        execute(RunRequest(scenario=xml, backend=world, validate=validate,
                           cosim=CosimSettings(**({} if latency is None else {"latency": latency}))), target)
        status = "ok"
    except Exception as exc:  # noqa: BLE001 - every crash is a result here
        target.parent.mkdir(parents=True, exist_ok=True)
        (out / world / f"{xml.stem}.error").write_text(f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}")
        status = f"error: {type(exc).__name__}: {exc}"
    return f"{world}/{xml.stem}", status, time.perf_counter() - clock


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=Path, required=True, help="a folder of CommonRoad scenario files")
    parser.add_argument("--worlds", nargs="+", default=["ideal", "mujoco"])
    parser.add_argument("--latency", type=float, default=None, help="a fixed plan latency [s] (default: measured)")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--no-validate", action="store_true", help="skip the solutions' validity check")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    files = sorted(args.files.rglob("*.xml"), key=lambda p: p.stem)
    tasks = [(xml, world, args.latency, args.out, not args.no_validate) for world in args.worlds for xml in files]
    start = time.perf_counter()
    with multiprocessing.get_context("spawn").Pool(args.workers, maxtasksperchild=20) as pool:
        results = list(pool.imap_unordered(run_one, tasks))
    errors = [r for r in results if r[1] != "ok"]
    print(f"{len(results)} runs ({len(files)} files x {len(args.worlds)} worlds) in "
          f"{time.perf_counter() - start:.0f} s with {args.workers} workers; {len(errors)} raised")
    for name, status, _ in errors[:10]:
        print(f"  {name}: {status[:160]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
