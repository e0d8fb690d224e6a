"""A candidate's runs up the ladder of a search: the job of a candidate in a rung (its scenario
file, the rung's settings with the candidate's reality knobs, its identity), and the ideal runs
that candidates share (`SharedIdealRuns`): the ideal world takes no reality knob, so candidates
that differ only in their knobs share one ideal run, and the later ones get a copy of its row."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from pydantic import BaseModel

from simgap.cosim import REFERENCE, CosimSettings, Fidelity
from simgap.experiment.job import Job, JobId
from simgap.experiment.knobs import with_knobs
from simgap.experiment.search.ledger import SearchLedger
from simgap.experiment.search.rows import SearchRow
from simgap.experiment.search.space import Candidate, Strategy
from simgap.experiment.search.spec import Search
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.scenario import write_scenario
from simgap.sim.settings import realism_of
from simgap.vehicles import load_vehicle


def scenario_name(index: int) -> str:
    return f"c{index:05d}"


def rung_name(rung: int, ladder_len: int) -> str:
    return REFERENCE if rung == 0 else "high" if rung == ladder_len - 1 else f"screen{rung}"


class Ladder:
    """The jobs of candidates in the rungs of a search's ladder, written under ``root``."""

    def __init__(self, search: Search, root: Path):
        self.search, self.root = search, Path(root)
        self.high = len(search.rungs) - 1

    def scenario(self, c: Candidate, name: str | None = None) -> str:
        """``c``'s CommonRoad scenario file (written on first use), under ``name`` (default: its
        index's)."""
        folder = self.root / "scenarios" / (name or scenario_name(c.index))
        existing = sorted(folder.glob("*.xml"))
        if existing:
            return str(existing[0])
        return str(write_scenario(self.search.logical.build(c.params), folder, preview=False))

    def settings(self, c: Candidate, rung: int) -> tuple[BaseModel | None, CosimSettings]:
        """(backend settings, loop settings) of ``c`` in ``rung``: the rung's with ``c``'s knobs."""
        r = self.search.rungs[rung]
        return with_knobs(r.settings, r.cosim, c.knobs)

    def job(self, c: Candidate, rung: int, name: str | None = None) -> Job:
        """``c``'s run in ``rung``, named ``name`` (default: its index's; a probe of a failure names
        its own, with the failure's index and seed)."""
        settings, cosim = self.settings(c, rung)
        r = self.search.rungs[rung]
        return Job(self._id(c, rung, Fidelity(r.backend, load_vehicle(c.vehicle).name, r.controller,
                                              realism_of(r.settings)),
                            self.search.spec.seed + c.index, name),
                   c.params, c.vehicle, settings, cosim, self.scenario(c, name), self.search.planners[c.planner])

    def _id(self, c: Candidate, rung: int, fidelity: Fidelity, seed: int, name: str | None = None) -> JobId:
        return JobId(name or scenario_name(c.index), fidelity, seed=seed, planner=c.planner,
                     stage=rung_name(rung, len(self.search.rungs)))

    def ideal_key(self, c: Candidate) -> str:
        """Everything an ideal run of ``c`` depends on: the scenario's parameters, the vehicle, the
        planner and the rung's settings (the ideal world observes the exact state: no seed)."""
        settings, cosim = self.settings(c, 0)
        driver = [c.vehicle] if c.planner == DEFAULT_PLANNER else [c.vehicle, c.planner]
        return json.dumps([c.params, *driver, settings.model_dump(mode="json") if settings is not None else None,
                           cosim.model_dump(mode="json")],
                          sort_keys=True, default=str)

    def copied_ideal(self, c: Candidate, source: SearchRow, elapsed_s: float) -> SearchRow:
        """The row of ``c``'s ideal run as a copy of ``source``'s: the same run, under ``c``'s key and
        point, at no cost (zero times), marked as ``source``'s."""
        run = source.run
        copied = replace(run, id=self._id(c, 0, Fidelity(REFERENCE, load_vehicle(c.vehicle).name), run.id.seed),
                         job_time_s=0.0, wall_time_s=0.0, timings={k: 0.0 for k in run.timings})
        return replace(source, run=copied, candidate=c.index, elapsed_s=elapsed_s, unit=tuple(c.unit),
                       knobs=dict(c.knobs), promote=False, ideal_of=source.candidate)


class SharedIdealRuns:
    """The ideal runs candidates share, keyed by what an ideal run depends on (`Ladder.ideal_key`):
    the verdicts known (the candidate that ran it), the runs in flight, and the candidates waiting
    for them. A candidate whose ideal run is known, or comes in, gets a copy of its row, told to
    the strategy and kept in the ledger."""

    def __init__(self, ladder: Ladder, ledger: SearchLedger, strategy: Strategy) -> None:
        self.ladder, self.ledger, self.strategy = ladder, ledger, strategy
        self.verdicts: dict[str, int] = {}
        self.running: dict[str, int] = {}
        self.waiting: dict[str, list[int]] = {}

    def known(self, index: int) -> None:
        """Candidate ``index`` ran its ideal run, and it finished."""
        self.verdicts.setdefault(self._key(index), index)

    def settle(self, index: int) -> bool:
        """Settle ``index``'s ideal check without running it, if its ideal verdict is known (copied
        now) or being run (copied when it comes in); False if it has to run."""
        key = self._key(index)
        if key in self.verdicts:
            self._copy(index, self.verdicts[key])
            return True
        if key in self.running:
            self.waiting.setdefault(key, []).append(index)
            return True
        self.running[key] = index
        return False

    def finished(self, index: int, ok: bool) -> list[int]:
        """``index``'s ideal run finished: the candidates that waited for it get a copy of its row;
        if it failed, they are returned, each to run its own."""
        key = self._key(index)
        self.running.pop(key, None)
        waiting = self.waiting.pop(key, [])
        if not ok:
            return waiting
        self.verdicts.setdefault(key, index)
        for other in waiting:
            self._copy(other, index)
        return []

    def _key(self, index: int) -> str:
        return self.ladder.ideal_key(self.ledger.candidates[index])

    def _copy(self, index: int, source: int) -> None:
        c = self.ledger.candidates[index]
        row = self.ladder.copied_ideal(c, self.ledger.rows[(source, 0)], self.ledger.elapsed())
        self.strategy.observe(c, 0, row.judged, row.failed)
        self.ledger.record(row)
