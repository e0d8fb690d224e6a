"""What a CI job asks of finished runs (``--fail-on`` and ``--min-score`` of `simgap run`,
`simgap experiment run` and `simgap search`): no agent ends in one of the outcomes it names, and
every score is at least the minimum. A run without a score (it drove no step, or it failed) is
below any minimum."""

from __future__ import annotations

import math
from dataclasses import dataclass

from simgap.cosim.history import Outcome
from simgap.errors import InputError

FAIL_ON_HELP = ("fail (exit 1) if an agent of a run ends in one of these outcomes, a comma list of "
                + ", ".join(o.value for o in Outcome))
MIN_SCORE_HELP = ("fail (exit 1) if an agent's closed-loop score is below this (0 to 1; a run without a score "
                  "is below any)")


@dataclass(frozen=True)
class CheckedRun:
    """One agent's (or one stored run's) result, as a check sees it: what to call it, how it
    ended, its score (None: none)."""

    label: str
    outcome: Outcome | None
    score: float | None


@dataclass(frozen=True)
class OutcomeCheck:
    """The outcomes that fail, and the lowest score that passes (None: any)."""

    fail_on: frozenset[Outcome] = frozenset()
    min_score: float | None = None

    @classmethod
    def of_options(cls, fail_on: str | None, min_score: float | None) -> OutcomeCheck:
        """The check ``--fail-on`` (a comma list of outcome values) and ``--min-score`` ask for."""
        allowed = ", ".join(o.value for o in Outcome)
        names = [item.strip() for item in (fail_on or "").split(",") if item.strip()]
        if fail_on is not None and not names:
            raise InputError("no outcome named", field="fail-on", allowed=allowed)
        outcomes = []
        for name in names:
            try:
                outcomes.append(Outcome(name.lower().replace("-", "_")))
            except ValueError:
                raise InputError(f"'{name}' is no outcome", field="fail-on", allowed=allowed) from None
        if min_score is not None and not (math.isfinite(min_score) and 0.0 <= min_score <= 1.0):
            raise InputError(f"{min_score:g} is no score", field="min-score", allowed="0 to 1 (a closed-loop score)")
        return cls(frozenset(outcomes), min_score)

    @property
    def asked(self) -> bool:
        return bool(self.fail_on) or self.min_score is not None

    def failures(self, runs: list[CheckedRun]) -> list[str]:
        """What fails the check, a line each (empty: it passes)."""
        out = []
        for run in runs:
            if run.outcome is not None and run.outcome in self.fail_on:
                out.append(f"{run.label} ended {run.outcome.value} (--fail-on)")
            if self.min_score is not None and (run.score is None or math.isnan(run.score)
                                               or run.score < self.min_score):
                score = "no score" if run.score is None or math.isnan(run.score) else f"score {run.score:.3f}"
                out.append(f"{run.label}: {score}, below --min-score {self.min_score:g}")
        return out
