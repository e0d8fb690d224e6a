"""The results store: a row file that cannot be read, or whose run directory is gone or damaged,
is named, left out of every count and query, and its run runs again on resume; so does a run the
machine failed (a full disk, no memory)."""

from __future__ import annotations

import errno
import shutil

import pytest
import yaml

from simgap.errors import InputError
from simgap.experiment.executors import _crashed_row
from simgap.experiment.runner import experiment_status, run_experiment
from simgap.experiment.spec import jobs, load_spec
from simgap.experiment.store import ResultsStore, row_file_name
from simgap.files import sole_writer

THREE_RUNS = {"name": "three", "logical": "curve",
              "parameters": {"radius": {"values": [20, 50, 100]}, "angle": {"values": [30]}},
              "fidelities": [{"backend": "ideal"}], "cosim": {"replan_every": 3}}


def test_a_cut_short_row_and_a_deleted_run_are_named_left_out_and_run_again(tmp_path):
    spec, out = tmp_path / "spec.yaml", tmp_path / "out"
    spec.write_text(yaml.safe_dump(THREE_RUNS))
    run_experiment(spec, out, workers=1)
    store = ResultsStore(out)
    first, second = store.rows()[:2]
    truncated, deleted = (store.rows_dir / row_file_name(row["key"]) for row in (first, second))
    truncated.write_bytes(truncated.read_bytes()[:100])                # a full disk cut it short
    run_of_deleted = second["run_dir"]
    shutil.rmtree(out / run_of_deleted)

    status = experiment_status(out)
    assert (len(status.ok), len(status.left)) == (1, 2)
    assert set(status.unusable_rows) == {truncated, deleted}
    assert "cannot be read" in status.unusable_rows[truncated]
    assert f"run directory {run_of_deleted} is gone" in status.unusable_rows[deleted]
    assert store.query("SELECT count(*) FROM runs")[1] == [(1,)]

    again = run_experiment(spec, out, workers=1)
    assert (again.ran, again.skipped, again.failed) == (2, 1, 0)
    assert set(again.unusable_rows) == {truncated, deleted}
    after = experiment_status(out)
    assert (len(after.ok), after.unusable_rows) == (3, {})
    assert (out / run_of_deleted / "run.json").is_file()


def test_a_second_experiment_run_on_the_same_directory_is_refused_before_it_runs(tmp_path):
    spec, out = tmp_path / "spec.yaml", tmp_path / "out"
    spec.write_text(yaml.safe_dump(THREE_RUNS))
    with sole_writer(out, "simgap experiment run"):          # the first one, still running
        with pytest.raises(InputError, match="another simgap experiment run is writing to this directory"):
            run_experiment(spec, out, workers=1)
    assert not (out / "experiment.json").exists() and not (out / "runs").exists()


def test_a_query_reads_the_runs_and_nothing_else(tmp_path):
    spec, out = tmp_path / "spec.yaml", tmp_path / "out"
    spec.write_text(yaml.safe_dump(THREE_RUNS | {"parameters": {"radius": {"values": [50]}, "angle": {"values": [30]}}}))
    run_experiment(spec, out, workers=1)
    store = ResultsStore(out)
    assert store.query("SELECT status FROM runs")[1] == [("ok",)]
    for sql in (f"COPY runs TO '{tmp_path / 'leak.csv'}'", "SELECT * FROM read_csv('/etc/hostname')",
                "SET enable_external_access = true", f"ATTACH '{tmp_path / 'other.db'}'"):
        with pytest.raises(InputError, match="query failed"):
            store.query(sql)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "spec.yaml"]


def test_an_experiment_is_refused_in_a_folder_of_the_users_files(tmp_path):
    spec, out = tmp_path / "spec.yaml", tmp_path / "thesis"
    spec.write_text(yaml.safe_dump(THREE_RUNS))
    out.mkdir()
    (out / "chapter1.tex").write_text("mine")
    with pytest.raises(InputError, match=r"holds chapter1.tex and no experiment.json"):
        run_experiment(spec, out, workers=1)
    assert sorted(p.name for p in out.iterdir()) == ["chapter1.tex"]


TWO_RUNS = THREE_RUNS | {"parameters": {"radius": {"values": [50, 100]}, "angle": {"values": [30]}},
                        "cosim": {"replan_every": 3, "max_time_s": 3}}         # short runs


def test_a_damaged_run_directory_is_not_done_and_runs_again_on_resume(tmp_path):
    spec, out = tmp_path / "spec.yaml", tmp_path / "out"
    spec.write_text(yaml.safe_dump(TWO_RUNS))
    run_experiment(spec, out, workers=1)
    store = ResultsStore(out)
    first, second = store.rows()
    meta = out / first["run_dir"] / "run.json"
    meta.write_text(meta.read_text()[:300])                               # cut short
    (out / second["run_dir"] / "trajectories.parquet").write_bytes(b"garbage" * 40)

    status = experiment_status(out)
    assert (len(status.ok), len(status.left)) == (0, 2)
    reasons = sorted(status.unusable_rows.values())
    assert f"its run directory {first['run_dir']} is damaged (run.json: cannot read the run's record" in reasons[0]
    assert f"its run directory {second['run_dir']} is damaged (trajectories.parquet: cannot read" in reasons[1]

    again = run_experiment(spec, out, workers=1)
    assert (again.ran, again.skipped, again.failed) == (2, 0, 0)
    after = experiment_status(out)
    assert (len(after.ok), after.unusable_rows) == (2, {})


def test_a_run_the_machine_failed_is_no_result_and_runs_again_on_resume(tmp_path):
    spec, out = tmp_path / "spec.yaml", tmp_path / "out"
    spec.write_text(yaml.safe_dump(TWO_RUNS))
    run_experiment(spec, out, workers=1)
    job = next(runs[0] for _, runs in jobs(load_spec(spec)))
    assert _crashed_row(job, MemoryError()).failure.startswith("the machine failed: out of memory")
    assert _crashed_row(job, OSError(errno.ENOENT, "gone")).failure.startswith("FileNotFoundError")   # an input's
    row = _crashed_row(job, OSError(errno.ENOSPC, "No space left on device"))
    assert row.status == "failed" and row.failure.startswith("the machine failed: no space left on the device")
    ResultsStore(out).write_row(row)
    status = experiment_status(out)
    assert (len(status.ok), len(status.failed), status.left) == (1, 0, [job.key])
    again = run_experiment(spec, out, workers=1)
    assert (again.ran, again.skipped, again.failed) == (1, 1, 0)
