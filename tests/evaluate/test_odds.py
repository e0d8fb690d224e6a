"""Odds over repeats: Wilson intervals for rates, bootstrap intervals for quantiles, and an
experiment with repeats that reports them."""

from __future__ import annotations

import os

import pyarrow.parquet as pq
import pytest
import simgap_command
import yaml

from simgap.evaluate.odds import bootstrap_quantile, odds, wilson
from simgap.experiment.store import ResultsStore


@pytest.mark.parametrize("k, n, low, high", [(0, 5, 0.0, 0.4345), (5, 5, 0.5655, 1.0), (3, 10, 0.1078, 0.6032),
                                             (50, 100, 0.4038, 0.5962)])
def test_wilson_intervals_are_the_textbook_ones(k, n, low, high):
    rate = wilson(k, n)
    assert rate.low == pytest.approx(low, abs=1e-4) and rate.high == pytest.approx(high, abs=1e-4)
    assert rate.low <= rate.value <= rate.high


def test_wilson_refuses_more_successes_than_trials_and_knows_nothing_of_no_trials():
    with pytest.raises(ValueError):
        wilson(6, 5)
    assert (wilson(0, 0).low, wilson(0, 0).high) == (0.0, 1.0)


def test_a_bootstrap_interval_holds_the_quantile_narrows_with_more_runs_and_is_seeded():
    few = bootstrap_quantile([0.1, 0.3, 0.2, 0.5, 0.4], 0.5)
    assert few.value == pytest.approx(0.3) and few.low <= few.value <= few.high
    many = bootstrap_quantile([0.1, 0.3, 0.2, 0.5, 0.4] * 20, 0.5)
    assert many.high - many.low < few.high - few.low
    assert bootstrap_quantile([0.1, 0.3, 0.2, 0.5, 0.4], 0.5) == few
    assert bootstrap_quantile([float("nan")]).n == 0


def test_odds_count_goals_and_failures():
    o = odds("s", "mujoco/sedan", "frenet", [True, True, False, True], [0.1, 0.2, 0.9, 0.15])
    assert (o.goal.k, o.failure.k, o.runs) == (3, 1, 4) and o.max_d_p90.value > o.max_d_median.value


def test_an_experiment_with_repeats_reports_odds_in_the_cli_and_the_store(tmp_path):
    spec = tmp_path / "repeats.yaml"
    spec.write_text(yaml.safe_dump({"name": "repeats", "logical": "curve", "repeats": 3,
                                    "parameters": {"radius": {"values": [20]}, "angle": {"values": [90]}},
                                    "fidelities": [{"backend": "mujoco"}], "cosim": {"max_time_s": 3}}))
    out = tmp_path / "exp"
    proc = simgap_command.simgap("experiment", "run", spec, "--out", out, "--workers", "2", "--no-validate",
                                 env={**os.environ, "COLUMNS": "200"}, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "Wilson 95 %" in proc.stdout and "0/3" in proc.stdout      # 3 s is too short for the goal: 0 of 3
    table = pq.read_table(out / "store" / "odds.parquet").to_pylist()
    assert len(table) == 1 and table[0]["runs"] == 3 and table[0]["failure_rate"] == 1.0
    assert table[0]["goal_rate_high"] == pytest.approx(wilson(0, 3).high)
    rows = ResultsStore(out).rows()
    assert {r["seed"] for r in rows} == {0, 1, 2}                          # three seeds, three runs
    assert all(r["reproduce"] == f"simgap replay {(out / r['run_dir']).resolve()}" for r in rows)
    assert len({r["fingerprint"] for r in rows}) == 3                       # the sensing noise differs per seed
    index = (out / "report" / "index.html").read_text()
    assert "Odds over repeats" in index and str(wilson(0, 3)) in index and str(wilson(3, 3)) in index
