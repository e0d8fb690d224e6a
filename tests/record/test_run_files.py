"""Run records on disk: what simgap wrote before the run record had a format version (an
experiment written by main at 1ec9884, 2026-11-27: two agents cross an intersection in the ideal
world and in MuJoCo; kept in ``tests/data/format1-study``) is read through `migrate`, its store's
rows too, and a report is made of it without writing into it; a newer format is refused."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from simgap.cosim import Outcome
from simgap.errors import InputError
from simgap.experiment.store import ResultsStore
from simgap.record import FORMAT_VERSION, migrate, read_run
from simgap.report.site import build_report
from simgap.sim.protocol import Realism

FORMAT_1 = Path(__file__).parents[1] / "data" / "format1-study"


@pytest.fixture
def study(tmp_path) -> Path:
    return Path(shutil.copytree(FORMAT_1, tmp_path / "study"))


def files_under(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_a_run_directory_of_format_1_reads_through_migrate_as_it_was_written(study):
    before = files_under(study)
    run_dirs = sorted(p.parent for p in study.rglob("run.json"))
    assert [d.name for d in run_dirs] == ["ideal", "mujoco-sedan"]
    for run_dir in run_dirs:
        old = json.loads((run_dir / "run.json").read_text())
        assert "format_version" not in old
        record = read_run(run_dir)
        assert record.format_version == FORMAT_VERSION
        assert record.machine_fingerprint == old["fingerprint"]    # the same driven states, bit for bit
        assert record.scenario_id == old["scenario_id"] and record.history.backend == old["backend"]
        for agent, was in zip(record.agents, old["agents"], strict=True):
            assert agent.id == was["id"] and agent.history.outcome == Outcome(was["outcome"])
            assert agent.history.vehicle.name == was["vehicle"] and agent.planner == "frenet"
            for name in ("time_to_goal_s", "distance_m", "min_distance_to_traffic_m", "max_road_excursion_m",
                         "planning_calls", "planning_mean_s", "plan_latency_mean_s", "score", "solution_cost",
                         "solution_valid", "solution_reason"):
                assert getattr(agent.evaluation, name) == was[name], name
            assert dict(agent.evaluation.score_components) == was["score_components"]
            assert {k: c.weighted for k, c in agent.evaluation.solution_partial_costs.items()} == \
                {k: c["cost"] * c["weight"] for k, c in was["solution_partial_costs"].items()}
            assert agent.evaluation.tracking is None            # format 1 did not keep it
            assert agent.history.planning_call_s == () and agent.history.observed is None
        assert dict(record.evaluation.metrics) == pytest.approx(old["metrics"], nan_ok=True)
        assert record.evaluation.solution_check == old["settings"]["solution_check"]
        assert record.all_timings == old["timings"]
        assert set(record.timings) == {"scoring", "io", "validation"}
        assert record.settings.cosim.latency == 0.1 and record.settings.planner_vehicle == "sedan"
        assert record.settings.evaluation.model_dump(mode="json") == \
            {k: old["settings"]["cosim"][k] for k in ("cost_function", "score")}     # the loop's then, apart now
        assert record.realism is (Realism.IDEAL if run_dir.name == "ideal" else Realism.REAL)
        assert record.fidelity.label == ("ideal" if run_dir.name == "ideal" else "mujoco/sedan")
        assert [e.kind for e in record.history.events] == [e["kind"] for e in old["events"]]
    assert files_under(study) == before                            # reading wrote nothing


def test_the_store_of_format_1_reads_typed_and_a_report_is_made_of_the_study(study, tmp_path):
    rows = sorted(ResultsStore(study).run_rows(), key=lambda r: r.id.key)
    assert [r.id.fidelity.label for r in rows] == ["ideal", "mujoco/sedan"]
    stored = {r["fidelity"]: r for r in pq.read_table(study / "store" / "results.parquet").to_pylist()}
    assert "stage" in stored["ideal"] and "format_version" not in stored["ideal"]
    for row in rows:
        assert row.id.stage is None and "format_version" not in row.extra
        assert row.fingerprint is None                             # format 1 hashed raw bits: that is its
        assert row.machine_fingerprint == read_run(study / row.run_dir).machine_fingerprint   # machine's
        was = stored[row.id.fidelity.label]
        assert row.outcome == was["outcome"] and row.score == was["score"] and row.min_distance_m == was["min_distance_m"]
    before = files_under(study / "runs")
    index = build_report(study / "runs", tmp_path / "report")
    page = next((tmp_path / "report" / "scenarios").glob("*.html")).read_text()
    assert "mujoco/sedan" in index.read_text() and "Against the ideal run" in page
    assert files_under(study / "runs") == before                   # the report computes nothing into the runs


def test_a_row_without_a_stage_column_takes_its_stage_from_its_key():
    from simgap.record import migrate_row

    row = migrate_row({"key": "curve_r20/screen/ideal", "fidelity": "ideal"})
    assert row["stage"] == "screen" and row["format_version"] == FORMAT_VERSION
    assert migrate_row({"key": "curve_r20/ideal", "fidelity": "ideal"})["stage"] == ""
    assert migrate_row({"key": "k", "stage": "high", "fidelity": "ideal"})["stage"] == "high"


def test_a_newer_format_is_refused_naming_the_file_and_the_field(study):
    run_dir = next(p.parent for p in study.rglob("run.json"))
    record = json.loads((run_dir / "run.json").read_text())
    (run_dir / "run.json").write_text(json.dumps(record | {"format_version": FORMAT_VERSION + 1}))
    with pytest.raises(InputError) as refused:
        read_run(run_dir)
    message = str(refused.value)
    assert "run.json" in message and "format_version" in message and "update simgap" in message
    assert migrate(record)["format_version"] == FORMAT_VERSION


def test_values_compare_as_plain_data_to_a_relative_tolerance_nan_equal_to_nan():
    from simgap.evaluate.solution import PartialCost
    from simgap.record.values import plain, same

    assert same(float("nan"), float("nan")) and same(1.0, 1.0 + 1e-12) and not same(1.0, 1.0 + 1e-6)
    assert same({"a": [1.0, PartialCost(2.0, 3.0)]}, {"a": (1.0, PartialCost(2.0, 3.0 + 1e-12))})
    assert not same({"a": 1.0}, {"a": 1.0, "b": 2.0}) and not same([1.0], [1.0, 2.0])
    assert plain(PartialCost(2.0, 3.0)) == {"cost": 2.0, "weight": 3.0}


def test_a_record_of_format_3_reads_its_evaluation_settings_from_the_loops(study):
    """Until format 4 the cost function and the score's settings were the loop's (``settings.cosim``)."""
    run_dir = next(p.parent for p in study.rglob("run.json"))
    current = migrate(json.loads((run_dir / "run.json").read_text()))
    evaluation = current["settings"].pop("evaluation")
    score = evaluation["score"] | {"min_progress_ratio": 0.4, "weights": evaluation["score"]["weights"] | {"comfort": 7.0}}
    current["settings"]["cosim"] |= {"cost_function": "MW1", "score": score}
    (run_dir / "run.json").write_text(json.dumps(current | {"format_version": 3}))
    settings = read_run(run_dir).settings
    assert settings.evaluation.cost_function.value == "MW1"
    assert settings.evaluation.score.min_progress_ratio == 0.4 and settings.evaluation.score.weights.comfort == 7.0
    assert "score" not in settings.cosim.model_dump() and "cost_function" not in settings.cosim.model_dump()


def test_backend_settings_are_read_typed_through_the_backend_settings_model(study, tmp_path):
    from simgap.record import RunFiles, write_run
    from simgap.sim.mujoco.settings import MujocoSettings

    runs = {p.parent.name: p.parent for p in study.rglob("run.json")}
    mujoco = read_run(runs["mujoco-sedan"])
    assert isinstance(mujoco.settings.backend, MujocoSettings) and mujoco.settings.backend.physics_hz == 500.0
    assert read_run(runs["ideal"]).settings.backend.model_dump() == {}
    # a physical run kept before realism was a setting of its world was an ideal car: so it reads
    meta = json.loads((runs["mujoco-sedan"] / "run.json").read_text())
    del meta["settings"]["backend"]["realism"], meta["settings"]["realism"]
    (runs["mujoco-sedan"] / "run.json").write_text(json.dumps(meta))
    old = read_run(runs["mujoco-sedan"])
    assert old.settings.backend.realism is Realism.IDEAL and old.fidelity.label == "mujoco/sedan/ideal-car"
    # written again (format 3) and read back: the same model
    again = read_run(write_run(RunFiles(old), tmp_path / "again"))
    assert again.settings.backend == old.settings.backend
    # a value the backend's model does not take is refused, naming the field
    meta = json.loads((tmp_path / "again" / "run.json").read_text())
    meta["settings"]["backend"]["road_friction"] = 9.0
    (tmp_path / "again" / "run.json").write_text(json.dumps(meta))
    with pytest.raises(InputError) as refused:
        read_run(tmp_path / "again")
    assert refused.value.field == "settings.backend.road_friction" and "run.json" in str(refused.value)


def test_the_settings_of_a_backend_not_installed_here_are_kept_as_recorded(study):
    run_dir = next(p.parent for p in study.rglob("run.json") if p.parent.name == "mujoco-sedan")
    meta = json.loads((run_dir / "run.json").read_text())
    meta["backend"] = "gone_world"
    (run_dir / "run.json").write_text(json.dumps(meta))
    record = read_run(run_dir)
    assert record.settings.backend.model_dump()["physics_hz"] == 500.0 and record.settings.controller is None
