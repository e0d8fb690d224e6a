"""A damaged run directory found before anything reads it: `read_run` checks a ``run.json`` (a JSON
object whose sections are objects, a finite positive time step, finite timings and scores) and its
``trajectories.parquet`` (the columns simgap writes, every state finite, driven states for every
agent the record names). What is damaged is refused as an `InputError` naming the file and the
field, so report, compare, export, render and an experiment's resume all refuse it in one line
instead of drawing, comparing or counting NaN.

Values a run may hold as NaN (run metrics and tracking aggregates without a sample, a 2D run's
``z``, ``pitch``, ``roll``) are not checked.
"""

from __future__ import annotations

import math
from collections.abc import Container, Iterable, Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from simgap.errors import InputError
from simgap.evaluate.run_evaluation import AgentEvaluation
from simgap.trajectory import STATE_FIELDS

RUN_AGAIN = "run the scenario again"
KEY_COLUMNS = ("kind", "agent_id", "plan_t", "k")
STATE_KINDS = ("driven", "planned", "observed", "standing", "traffic")      # the rows that are states
# an agent's evaluation's numbers (float or float | None): finite where present
#: a JSON object as parsed from a run.json or a store row, before it is read into typed values
JsonObject = dict[str, Any]

EVALUATION_NUMBERS = tuple(f.name for f in fields(AgentEvaluation)
                           if "float" in str(f.type) and "Mapping" not in str(f.type) and f.name != "tracking")


def record_object(meta: object, file: Path) -> JsonObject:
    """``meta``, a parsed ``run.json``, when it is a JSON object of objects where a run's record
    has them; an `InputError` naming ``file`` otherwise."""
    if not isinstance(meta, dict):
        raise InputError(f"holds {_kind(meta)}, not a run's record", file=file,
                         allowed=f"the JSON object simgap wrote; {RUN_AGAIN}")
    for section in ("settings", "history", "evaluation"):
        if section in meta and not isinstance(meta[section], Mapping):
            raise InputError(f"holds {_kind(meta[section])}, not an object", file=file, field=section,
                             allowed=RUN_AGAIN)
    return meta


def check_record(meta: JsonObject, file: Path) -> None:
    """Refuse a ``run.json`` (of the current format) whose time step, timings or scores are not
    numbers a run can have: the first such field named."""
    history, evaluation = _section(meta, "history", file), _section(meta, "evaluation", file)
    _positive(history.get("dt"), file, "history.dt")
    _finite(history.get("wall_time_s", 0.0), file, "history.wall_time_s")
    for i, agent in enumerate(_list(history, "agents", file, "history")):
        where = f"history.agents[{i}]"
        if not isinstance(agent, Mapping):
            raise InputError(f"holds {_kind(agent)}, not an agent", file=file, field=where, allowed=RUN_AGAIN)
        for name in ("planning_call_s", "plan_latency_s"):
            for k, value in enumerate(agent.get(name) or ()):
                _finite(value, file, f"{where}.{name}[{k}]")
    for i, agent in enumerate(_list(evaluation, "agents", file, "evaluation")):
        where = f"evaluation.agents[{i}]"
        if not isinstance(agent, Mapping):
            raise InputError(f"holds {_kind(agent)}, not an agent's evaluation", file=file, field=where,
                             allowed=RUN_AGAIN)
        for name in EVALUATION_NUMBERS:
            if agent.get(name) is not None:
                _finite(agent[name], file, f"{where}.{name}")
        score = agent.get("score")
        if score is not None and not 0.0 <= score <= 1.0:
            raise InputError(f"is {score}", file=file, field=f"{where}.score", allowed=f"0 to 1; {RUN_AGAIN}")


def check_states(table: pa.Table, file: Path) -> None:
    """Refuse a trajectories table without the columns simgap writes, or with a state that is not
    finite: the first such column named (with its kind and agent). Rows of other kinds (what else a
    run keeps beside its states, e.g. per control tick) are not states and are not checked here."""
    missing = [c for c in KEY_COLUMNS + STATE_FIELDS if c not in table.column_names]
    if missing:
        raise InputError(f"no column {missing[0]!r}", file=file, field=missing[0],
                         allowed=f"the columns simgap writes: {', '.join(KEY_COLUMNS + STATE_FIELDS)}; {RUN_AGAIN}")
    states = pc.is_in(table.column("kind"), value_set=pa.array(STATE_KINDS)).to_numpy(zero_copy_only=False)
    for name in STATE_FIELDS:
        values = table.column(name).to_numpy(zero_copy_only=False).astype(float, copy=False)
        bad = np.flatnonzero(~np.isfinite(values) & states)
        if bad.size:
            row = int(bad[0])
            kind, agent = table.column("kind")[row].as_py(), table.column("agent_id")[row].as_py()
            raise InputError(f"{values[row]} in the {kind} states of {'obstacle' if kind == 'traffic' else 'agent'} "
                             f"{agent} (row {row}, and {bad.size - 1} more)", file=file, field=name,
                             allowed=f"finite numbers; {RUN_AGAIN}")


def check_driven(agent_ids: Iterable[int], driven: Container[int], file: Path) -> None:
    """Refuse trajectories that lack the driven states of an agent its run's record names."""
    missing = [aid for aid in agent_ids if aid not in driven]
    if missing:
        raise InputError(f"no driven states of agent {missing[0]}, which the run's record names", file=file,
                         field="kind", allowed=f"the trajectories.parquet simgap wrote; {RUN_AGAIN}")


def _section(meta: JsonObject, name: str, file: Path) -> JsonObject:
    value = meta.get(name)
    if not isinstance(value, dict):
        raise InputError("missing" if value is None else f"holds {_kind(value)}, not an object", file=file,
                         field=name, allowed=RUN_AGAIN)
    return value


def _list(section: JsonObject, name: str, file: Path, where: str) -> list:
    value = section.get(name)
    if not isinstance(value, list):
        raise InputError("missing" if value is None else f"holds {_kind(value)}, not a list", file=file,
                         field=f"{where}.{name}", allowed=RUN_AGAIN)
    return value


def _finite(value: object, file: Path, field: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"is {value!r}", file=file, field=field, allowed=f"a finite number; {RUN_AGAIN}")
    return value


def _positive(value: object, file: Path, field: str) -> None:
    if _finite(value, file, field) <= 0:
        raise InputError(f"is {value!r}", file=file, field=field, allowed=f"a number above 0; {RUN_AGAIN}")


def _kind(value: object) -> str:
    names = {bool: "a boolean", int: "a number", float: "a number", str: "a string", list: "a list", dict: "an object"}
    return "null" if value is None else names.get(type(value), type(value).__name__)
