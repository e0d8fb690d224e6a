"""Real searches (the ideal world and the single-track one, no planted rows): killed and resumed
without a run lost or repeated, and resumed with a larger budget and reported. Apart from the planted-landscape tests (`test_search.py`) so that the two files run on
different test workers."""

from __future__ import annotations

import json
import os
import signal
import time

import pytest
import simgap_command
from search_specs import LADDER, write

from simgap.errors import InputError
from simgap.experiment.search import Budget, run_search
from simgap.experiment.search.results import search_results
from simgap.experiment.store import ResultsStore
from simgap.report.search_page import build_search_report


def small_search(tmp_path, **fields):
    return write(tmp_path, **({"parameters": {"radius": {"min": 10, "max": 30}, "initial_speed": {"min": 10, "max": 20}},
                               "ladder": [{"backend": "ideal"}, LADDER[1], {"backend": "dynamic"}],
                               "failure": {"above": {"peak_grip_use": 0.9}}, "strategies": ["random", "multi_fidelity"],
                               "run_timeout_s": 120} | fields))


def test_a_killed_search_resumes_without_losing_or_repeating_a_run(tmp_path):
    spec = small_search(tmp_path)
    out = tmp_path / "killed"
    proc = simgap_command.start("search", spec, "--budget", "8", "--out", out, "--strategy", "random", "--workers", "2",
                                "--no-report", "--no-validate")
    rows_dir = out / "random" / "store" / "rows"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (rows_dir.exists() and len(list(rows_dir.glob("*.parquet"))) >= 2):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)          # the driver and its workers, mid-run
    proc.wait()
    before = {r["key"]: r for r in ResultsStore(out / "random").rows()}
    assert 2 <= len(before) < 8, "the kill came after the second and before the last run finished"

    (result,) = run_search(spec, out, Budget(runs=8), workers=2, strategies=["random"])
    rows = ResultsStore(out / "random").rows()
    keys = [r["key"] for r in rows]
    assert len(keys) == len(set(keys)) == 8 == result.runs                 # none lost, none twice
    after = {r["key"]: r for r in rows}
    assert all(after[k]["fingerprint"] == r["fingerprint"] and after[k]["elapsed_s"] == r["elapsed_s"]
               for k, r in before.items())                                  # kept as they were
    assert not list(out.rglob(".*.tmp"))
    candidates = sorted({int(r["candidate"]) for r in rows})
    assert candidates == list(range(len(candidates)))                      # no candidate skipped


def test_a_search_goes_on_with_a_larger_budget_and_reports(tmp_path):
    spec = small_search(tmp_path)
    out = tmp_path / "search"
    first = run_search(spec, out, Budget(runs=6), workers=2)          # the search's total: 3 runs each
    assert [r.name for r in first] == ["random", "multi_fidelity"]
    before = {r["key"]: r["fingerprint"] for r in ResultsStore(out / "multi_fidelity").rows()}
    assert len(before) == 3
    run_search(spec, out, Budget(runs=12), workers=2)
    build_search_report(search_results(out))
    findings = json.loads((out / "search.json").read_text())["findings"]      # what each found, beside the spec
    assert set(findings) == {"random", "multi_fidelity"} and findings["random"]["runs"] == 6
    assert all(isinstance(f["modes"], list) for f in findings.values())
    rows = ResultsStore(out / "multi_fidelity").rows()
    keys = [r["key"] for r in rows]
    assert len(keys) == len(set(keys)) == 6
    assert all({r["key"]: r["fingerprint"] for r in rows}[k] == v for k, v in before.items())
    assert {r["rung"] for r in rows} >= {1}                                # the screen ran
    results = search_results(out).strategies
    assert [r.name for r in results] == ["random", "multi_fidelity"] and all(r.runs == 6 for r in results)
    page = (out / "report" / "index.html").read_text()
    assert "distinct violated assumptions" in page and "multi_fidelity" in page
    assert (out / "report" / "failures_over_budget.png").stat().st_size > 10_000
    # another spec in the same directory is refused, naming what to do
    other = small_search(tmp_path, parameters={"radius": {"min": 10, "max": 40}})
    with pytest.raises(InputError, match="different spec"):
        run_search(other, out, Budget(runs=2), workers=1)
