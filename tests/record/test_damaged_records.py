"""A damaged run directory is refused by `read_run` in one `InputError` naming the file and the
field — so every reader (report, compare, export, render, an experiment's resume) refuses it — never
read as NaN or raised as a traceback. The run is the ideal run of ``tests/data/format1-study``
rewritten in the current format."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import simgap_command

from simgap.errors import InputError
from simgap.record import RunFiles, read_run, write_run

FORMAT_1_RUN = Path(__file__).parents[1] / "data" / "format1-study" / "runs"


@pytest.fixture(scope="module")
def sound_run(tmp_path_factory) -> Path:
    ideal = next(p.parent for p in FORMAT_1_RUN.rglob("run.json") if p.parent.name == "ideal")
    return write_run(RunFiles(read_run(ideal)), tmp_path_factory.mktemp("runs") / "sound")


def _edit_json(change: Callable[[dict], object]) -> Callable[[Path], None]:
    def damage(run: Path) -> None:
        meta = json.loads((run / "run.json").read_text())
        replaced = change(meta)
        (run / "run.json").write_text(json.dumps(meta if replaced is None else replaced))
    return damage


def _edit_states(change: Callable[[pa.Table], pa.Table]) -> Callable[[Path], None]:
    def damage(run: Path) -> None:
        path = run / "trajectories.parquet"
        pq.write_table(change(pq.read_table(path)), path)
    return damage


def _nan_x(table: pa.Table) -> pa.Table:
    x = table.column("x").to_numpy().copy()
    x[3] = np.nan
    return table.set_column(table.schema.get_field_index("x"), "x", pa.array(x))


DAMAGES = [  # name, damage, the file and the field the refusal names
    ("run.json null", _edit_json(lambda m: "null"), "run.json", None),
    ("run.json a list", _edit_json(lambda m: [1, 2]), "run.json", None),
    ("history a list", _edit_json(lambda m: m.update(history=[])), "run.json", "history"),
    ("dt NaN", _edit_json(lambda m: m["history"].update(dt=float("nan"))), "run.json", "history.dt"),
    ("dt zero", _edit_json(lambda m: m["history"].update(dt=0)), "run.json", "history.dt"),
    ("score NaN", _edit_json(lambda m: m["evaluation"]["agents"][0].update(score=float("nan"))), "run.json",
     "evaluation.agents[0].score"),
    ("score 7", _edit_json(lambda m: m["evaluation"]["agents"][0].update(score=7)), "run.json",
     "evaluation.agents[0].score"),
    ("distance a string", _edit_json(lambda m: m["evaluation"]["agents"][0].update(distance_m="far")), "run.json",
     "evaluation.agents[0].distance_m"),
    ("planning call Infinity", _edit_json(lambda m: m["history"]["agents"][0].update(planning_call_s=[float("inf")])),
     "run.json", "history.agents[0].planning_call_s[0]"),
    ("a NaN state", _edit_states(_nan_x), "trajectories.parquet", "x"),
    ("no rows", _edit_states(lambda t: t.slice(0, 0)), "trajectories.parquet", "kind"),
    ("no yaw column", _edit_states(lambda t: t.drop(["yaw"])), "trajectories.parquet", "yaw"),
    ("empty parquet", lambda run: (run / "trajectories.parquet").write_bytes(b""), "trajectories.parquet", None),
    ("garbage parquet", lambda run: (run / "trajectories.parquet").write_bytes(b"PAR1 garbage" * 50),
     "trajectories.parquet", None),
]


@pytest.mark.parametrize("name, damage, file, field", DAMAGES, ids=[d[0] for d in DAMAGES])
def test_a_damaged_run_is_refused_naming_its_file_and_field(sound_run, tmp_path, name, damage, file, field):
    read_run(sound_run)                                  # the sound run reads
    run = tmp_path / "run"
    run.mkdir()
    for f in sound_run.iterdir():
        (run / f.name).write_bytes(f.read_bytes())
    damage(run)
    with pytest.raises(InputError) as refused:
        read_run(run)
    assert refused.value.file == str(run / file)
    assert refused.value.field == field
    assert "\n" not in refused.value.describe()


def test_every_reader_refuses_a_damaged_run_in_one_line(sound_run, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    for f in sound_run.iterdir():
        (run / f.name).write_bytes(f.read_bytes())
    _edit_json(lambda m: m["history"].update(dt=float("nan")))(run)
    for args in (["compare", run, sound_run], ["export", run, "--out", tmp_path / "x"]):
        proc = simgap_command.simgap(*args, timeout=120)
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.strip().count("\n") == 0 and "run.json: field 'history.dt'" in proc.stderr
    assert not (tmp_path / "x").exists()


def test_rows_that_are_not_states_are_not_held_to_a_states_rules(tmp_path):
    from simgap.record.integrity import check_states
    from simgap.trajectory import STATE_FIELDS

    nan = float("nan")
    table = pa.table({"kind": ["driven", "controls"], "agent_id": [1, 1], "plan_t": [nan, nan], "k": [0, 0]}
                     | {f: [0.0, nan] for f in STATE_FIELDS})      # e.g. per control tick: only its time
    check_states(table, tmp_path / "trajectories.parquet")
    with pytest.raises(InputError, match="in the driven states of agent 1"):
        check_states(table.set_column(table.schema.get_field_index("x"), "x", pa.array([nan, 0.0])), tmp_path)
