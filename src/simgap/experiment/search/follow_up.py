"""The follow-up of a strategy's violations, planned within its share of the search's budget.

Every distinct violation a search reports is followed up: probed (one high-fidelity run per
dimension it is off nominal in: `mode_probes`), confirmed over seeds (``repeats - 1`` more
high-fidelity runs: `confirmation`) and, unless asked not to, explained (its 2^n counterfactual
worlds: `simgap.experiment.attribution.explain`). All of it is paid from the strategy's share:

* while it searches, a strategy counts what following up each distinct violation found so far
  will cost (`FollowUpReserve`: the runs above, times the mean time of its high-fidelity runs over
  the workers) and stops proposing candidates once what it spent and that reserve reach its share;
* then its violations are followed up worst first (by the spec's objective in high fidelity),
  each while the share lasts (`FollowUpReserve.planned`; the follow-up of the one taken last may
  overrun it): all their probes, then all their confirmations, then their explanations. An
  explanation is left out where one alone would cost more than the whole share.

A violation is reported once probed (`results.StrategyResult.reported`); those the share did not
reach are counted, with the budget that would follow them up (a larger ``--budget`` on the same
directory resumes and does).
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from simgap.experiment.attribution import broken_assumptions, read_explanation
from simgap.experiment.replay import recorded_scenario, replay_request
from simgap.experiment.search.budget import CONFIRMATION_REPEATS, Budget
from simgap.experiment.search.failure_modes import ProbePlan
from simgap.experiment.search.ledger import SearchLedger
from simgap.experiment.search.results import Violation
from simgap.experiment.search.rows import SearchRow
from simgap.planning.registry import DEFAULT_PLANNER
from simgap.record import read_run


@dataclass(frozen=True)
class FollowUp:
    """What a search does with each distinct violation it reports: confirm it over ``repeats``
    seeds (its own included), and explain it (``explain``) where the budget allows."""

    repeats: int = CONFIRMATION_REPEATS
    explain: bool = True


def explanation_runs(run_dir: Path) -> int:
    """The runs explaining the run in ``run_dir`` takes: the ideal run and a world per non-empty
    subset of the assumptions it broke (2^n), as `explain` finds them."""
    record = read_run(run_dir)
    with tempfile.TemporaryDirectory(prefix="simgap-follow-up-") as scratch:
        request = replay_request(record, recorded_scenario(Path(run_dir), record, Path(scratch)))
        return 2 ** len(broken_assumptions(record, request))


@dataclass
class FollowUpReserve:
    """What following up a strategy's distinct violations found so far will cost, kept up as its
    ledger grows: the violations found (a high-fidelity failure whose ideal run passed, a distinct
    radius from every earlier one of the same vehicle and planner, as `results.summarise` counts
    them), the runs each needs, and what is done already (an earlier invocation's follow-up).
    An explanation is part of a violation's follow-up unless one alone costs more than the whole
    ``share``."""

    plan: ProbePlan
    follow_up: FollowUp
    share: Budget
    high: int                            # the ladder's high-fidelity rung
    radius: float
    workers: int
    done: set[int] = field(default_factory=set)   # candidates followed up already (nothing to reserve)
    made: int = 0                        # the follow-up runs made (an earlier invocation's included)
    runs: int = 0                        # the follow-up runs still to make
    kept: list[tuple[tuple[float, ...], str]] = field(default_factory=list)
    _seen: int = 0                       # rows of the ledger looked at
    _high_s: list[float] = field(default_factory=list)
    _explanations: dict[Path, int] = field(default_factory=dict)

    def update(self, ledger: SearchLedger) -> None:
        """Take in the rows the ledger recorded since the last call."""
        for index, rung in ledger.order[self._seen:]:
            row = ledger.rows.get((index, rung))
            if row is None:
                continue
            if rung == self.high and row.ok and row.ideal_of is None:
                self._high_s.append(float(row.run.job_time_s or row.run.wall_time_s or 0.0))
            high, ideal = ledger.rows.get((index, self.high)), ledger.rows.get((index, 0))
            if rung not in (0, self.high) or high is None or ideal is None or not high.ok or not high.failed \
                    or not ideal.ok or ideal.failed:
                continue
            driver = f"{high.run.id.fidelity.vehicle}|{high.run.id.planner or DEFAULT_PLANNER}"
            if any(d == driver and math.dist(high.unit, p) < self.radius for p, d in self.kept):
                continue
            self.kept.append((high.unit, driver))
            self.runs += self.still_to_run(high, ledger.root / str(high.run.run_dir))
        self._seen = len(ledger.order)

    def explanation(self, run_dir: Path) -> int:
        """The runs explaining the run in ``run_dir`` takes (`explanation_runs`, read once)."""
        if run_dir not in self._explanations:
            self._explanations[run_dir] = explanation_runs(run_dir)
        return self._explanations[run_dir]

    def explains(self, runs: int) -> bool:
        """Whether an explanation of ``runs`` runs is made: asked for, and not dearer than the share."""
        return self.follow_up.explain and not self.share.spent(self.seconds(runs), runs)

    def runs_of(self, violation: SearchRow, run_dir: Path) -> int:
        """The runs following up ``violation`` (its high-fidelity run in ``run_dir``) takes: its
        probes, its confirmations and its explanation."""
        explain = self.explanation(run_dir) if self.follow_up.explain else 0
        return len(self.plan.off_nominal(violation.unit)) + self.follow_up.repeats - 1 + \
            (explain if self.explains(explain) else 0)

    def still_to_run(self, violation: SearchRow, run_dir: Path) -> int:
        """The runs of ``violation``'s follow-up still to make: all of them, or (followed up by an
        earlier invocation) its explanation if it is due and not made."""
        if violation.candidate not in self.done:
            return self.runs_of(violation, run_dir)
        if not self.follow_up.explain or read_explanation(run_dir) is not None:
            return 0
        runs = self.explanation(run_dir)
        return runs if self.explains(runs) else 0

    def seconds(self, runs: int | None = None) -> float:
        """What ``runs`` (default: the reserve's) will take on the workers: each the mean time of
        the strategy's high-fidelity runs so far."""
        mean = sum(self._high_s) / len(self._high_s) if self._high_s else 0.0
        return (self.runs if runs is None else runs) * mean / max(1, self.workers)

    def planned(self, worst: list[Violation], spent_s: float, spent_runs: int) -> list[Violation]:
        """The violations to follow up, of ``worst`` (worst first), with ``spent_s`` and
        ``spent_runs`` spent: each while the share lasts, the follow-up of the one taken last
        perhaps beyond it (a violation is followed up whole or not reported)."""
        out, runs = [], 0
        for v in worst:
            if self.share.spent(spent_s + self.seconds(runs), spent_runs + runs):
                break
            out.append(v)
            runs += self.still_to_run(v.row, v.run_dir)
        return out
