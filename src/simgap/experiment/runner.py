"""An experiment end to end: scenarios from the spec, every run (resuming where a previous
invocation stopped) and the results store. The report is drawn from them by `simgap.report`
(the CLI builds it)."""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from simgap.errors import InputError, validated
from simgap.evaluate.odds import Odds
from simgap.experiment.executors import make_executor
from simgap.experiment.explained_runs import ExplainedRun, explain_runs
from simgap.experiment.job import Job, JobContext
from simgap.experiment.repeats import odds_over_repeats, write_odds
from simgap.experiment.run_row import RunRow
from simgap.experiment.single_run import software_versions
from simgap.experiment.spec import Experiment, ExperimentSpec, checked_experiment, jobs, load_spec
from simgap.experiment.store import ResultsStore
from simgap.files import atomic_write_text, read_json_model, restore_directory, sole_writer
from simgap.scenario import write_scenario
from simgap.scenario.logical import load_logical
from simgap.sim.registry import preflight

META = "experiment.json"


class ExperimentMeta(BaseModel):
    """What an experiment's directory keeps of the spec it holds the results of (`META`): the spec as
    it was dumped (validated as an `ExperimentSpec` where it is used again), its logical scenario and
    file, the part of it that decides the results and their hash, and the versions that ran it."""

    model_config = ConfigDict(frozen=True)
    spec: dict[str, Any]
    logical_ref: str | None = None
    spec_file: Path | None = None
    spec_results: dict[str, Any] = Field(default_factory=dict)
    results_hash: str | None = None
    versions: dict[str, str] = Field(default_factory=dict)

    @classmethod
    def read(cls, root: Path) -> ExperimentMeta:
        """The meta of the experiment in ``root``, or an `InputError` naming the file and the field."""
        return read_json_model(root / META, cls, "experiment's record of its spec")


@dataclass
class Progress:
    total: int
    done: int = 0
    failed: int = 0
    skipped: int = 0                 # finished in an earlier invocation
    started: float = field(default_factory=time.monotonic)

    @property
    def remaining(self) -> int:
        return self.total - self.done - self.failed - self.skipped


@dataclass
class ExperimentResult:
    root: Path
    total: int
    ran: int
    failed: int
    skipped: int
    skipped_failed: int                 # of the skipped: runs that failed earlier (--retry-failed runs them again)
    wall_time_s: float
    failures: list[tuple[str, str]]
    unusable_rows: dict[Path, str]      # row files left out (`ResultsStore.unusable_rows`): their runs ran again
    odds: list[Odds] = field(default_factory=list)    # per scenario, fidelity and planner, over its repeats
    explained: list[ExplainedRun] = field(default_factory=list)   # the runs its spec's `explain` chose


def _diff(old: dict, new: dict, prefix: str = "") -> list[str]:
    keys = sorted(set(old) | set(new))
    out = []
    for k in keys:
        a, b = old.get(k), new.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            out += _diff(a, b, f"{prefix}{k}.")
        elif a != b:
            out.append(f"{prefix}{k}")
    return out


def _claim(root: Path, spec: ExperimentSpec, logical_ref: str, spec_file: Path) -> None:
    """Record the spec in ``root``, or refuse if ``root`` holds results of a different one."""
    meta_path = root / META
    relevant = spec.results_relevant()
    if meta_path.exists():
        meta = ExperimentMeta.read(root)
        if meta.results_hash != spec.results_hash():
            changed = ", ".join(_diff(meta.spec_results, relevant)) or "the spec"
            raise InputError(f"this directory holds results of a different spec (changed: {changed}); "
                             "mixing them would make the results meaningless", file=root,
                             allowed="the same spec, or a new --out directory")
        return
    root.mkdir(parents=True, exist_ok=True)
    meta = ExperimentMeta(spec=json.loads(spec.model_dump_json()), logical_ref=logical_ref, spec_file=spec_file.resolve(),
                          spec_results=relevant, results_hash=spec.results_hash(), versions=software_versions())
    atomic_write_text(meta_path, meta.model_dump_json(indent=2))


def _check_experiment_directory(root: Path) -> None:
    """``root`` is new, empty (but for hidden files) or an experiment's directory: a folder of the
    user's files is not one to fill with scenarios, runs and a store."""
    if (root / META).exists() or not root.is_dir():
        return
    theirs = sorted(p.name for p in root.iterdir() if not p.name.startswith("."))
    if theirs:
        more = f" (and {len(theirs) - 1} more)" if len(theirs) > 1 else ""
        raise InputError(f"holds {theirs[0]}{more} and no {META}, so it is not an experiment's directory",
                         file=root, allowed="a new or empty folder, or an experiment's own to resume it")


def plan(experiment: Experiment, root: Path) -> tuple[list[Job], dict[str, str]]:
    """All the experiment's jobs, and the scenario file of each scenario (written if missing)."""
    all_jobs, scenarios = [], {}
    for params, runs in jobs(experiment):
        name = runs[0].scenario
        xml = root / "scenarios" / f"{name}.xml"
        if not xml.exists():
            xml = write_scenario(experiment.logical.build(params), root / "scenarios", preview=False)
        scenarios[name] = str(xml)
        all_jobs += runs
    return all_jobs, scenarios


def clean_partial_runs(root: Path) -> None:
    """Remove run directories a killed writer left half-built (they are never read), and put back
    a whole one it had set aside (`simgap.files.replace_directory`)."""
    runs = root / "runs"
    if runs.exists():
        for tmp in sorted(runs.rglob(".*")):
            if tmp.is_dir() and tmp.name.endswith(".old"):
                restore_directory(tmp.with_name(tmp.name[1:-len(".old")]))
            elif tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)


def run_experiment(spec_ref: str | Path, root: Path, workers: int | None, executor: str = "local",
                   address: str | None = None, on_progress: Callable[[Progress], None] | None = None,
                   retry_failed: bool = False, validate: bool = False) -> ExperimentResult:
    """Run (or resume) the experiment ``spec_ref`` in ``root``. A finished run — ok or failed — is
    never run again, unless ``retry_failed`` asks to run the failed ones once more; ``validate``
    checks each run's solution (slow: `simgap experiment run` asks for it unless --no-validate)."""
    root = Path(root)
    experiment = load_spec(spec_ref)
    spec, path = experiment.spec, experiment.file
    for variants in experiment.variants:
        preflight(variants[0].fidelity.backend, variants[0].settings)
    runner = make_executor(executor, workers, spec.run_timeout_s, address)
    logical_ref = spec.logical
    if logical_ref.endswith((".yaml", ".yml")) and not Path(logical_ref).is_absolute():
        logical_ref = str((path.parent / logical_ref).resolve())
    _check_experiment_directory(root)
    with sole_writer(root, "simgap experiment run"):
        _claim(root, spec, logical_ref, path)
        all_jobs, scenarios = plan(experiment, root)
        store = ResultsStore(root)
        store.prepare()
        clean_partial_runs(root)
        finished = store.finished_keys()
        unusable_rows = store.unusable_rows
        todo = [j for j in all_jobs if j.key not in finished or (retry_failed and finished[j.key] != "ok")]
        skipped_failed = 0 if retry_failed else sum(finished.get(j.key) == "failed" for j in all_jobs)
        progress = Progress(total=len(all_jobs), skipped=len(all_jobs) - len(todo))
        failures: list[tuple[str, str]] = []
        if on_progress:
            on_progress(progress)

        def on_result(job: Job, row: RunRow) -> None:
            store.write_row(row)
            if row.status == "ok":
                progress.done += 1
            else:
                progress.failed += 1
                failures.append((job.key, row.failure))
            if on_progress:
                on_progress(progress)

        start = time.perf_counter()
        context = JobContext(root, scenarios, experiment.planner_vehicle, validate=validate,
                             evaluation=experiment.evaluation)
        if todo:
            runner.run(todo, context, on_result)
        store.consolidate()
        rows = store.run_rows()
        odds = odds_over_repeats(rows)
        write_odds(root / "store", odds)
        explained = [] if spec.explain is None else explain_runs(root, rows, spec.explain, max(2, workers or 2))
        return ExperimentResult(root, len(all_jobs), progress.done + progress.failed, progress.failed,
                                progress.skipped, skipped_failed, time.perf_counter() - start, failures,
                                unusable_rows, odds, explained)


@dataclass
class Status:
    total: int
    ok: list[str]
    failed: list[tuple[str, str]]
    left: list[str]
    unusable_rows: dict[Path, str]      # row files left out (`ResultsStore.unusable_rows`): their runs are left


def experiment_status(root: Path) -> Status:
    root = Path(root)
    meta_path = root / META
    if not meta_path.exists():
        raise InputError("not an experiment directory (no experiment.json)", file=root)
    meta = ExperimentMeta.read(root)
    spec = validated(ExperimentSpec, meta.spec, file=meta_path, prefix="spec")
    logical = load_logical(meta.logical_ref or spec.logical)
    store = ResultsStore(root)
    rows = {r["key"]: r for r in store.finished_rows()}
    spec_file = meta.spec_file or root / "spec.yaml"    # (vehicle files are relative to it)
    keys = [j.key for _, runs in jobs(checked_experiment(spec, logical, spec_file)) for j in runs]
    ok = [k for k in keys if k in rows and rows[k]["status"] == "ok"]
    failed = [(k, rows[k].get("failure", "")) for k in keys if k in rows and rows[k]["status"] != "ok"]
    left = [k for k in keys if k not in rows]
    return Status(len(keys), ok, failed, left, store.unusable_rows)
