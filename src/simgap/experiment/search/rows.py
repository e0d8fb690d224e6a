"""What a search records, typed when read: each run's store row with the search's columns
(`SearchRow`), and the rows of a strategy's directory (`read_search_rows`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from simgap.experiment.run_row import RunRow
from simgap.experiment.search.spec import SCORE_DROP
from simgap.experiment.store import ResultsStore

_COLUMNS = ("strategy", "candidate", "rung", "rung_backend", "failed", "failure_reason", "elapsed_s", "promote",
            "ideal_of", SCORE_DROP)


@dataclass(frozen=True)
class SearchRow:
    """A run of a search: its store row, and where it stands in the search — the candidate, its
    rung of the ladder (0 = ideal, last = high), whether it failed by the spec's rule and why, the
    strategy's clock when it finished, the candidate's point (``unit_*``, ``knob_*`` columns),
    whether it went up a rung, for a copied ideal run, the candidate that ran it, and what the
    search measures against the candidate's ideal run (``score_drop``: its ideal score minus this
    run's; 0 for the ideal run; None while that run is not in, or either has no score)."""

    run: RunRow
    strategy: str
    candidate: int
    rung: int
    rung_backend: str
    failed: bool
    failure_reason: str
    elapsed_s: float
    unit: tuple[float, ...]
    knobs: dict[str, float] = field(default_factory=dict)
    promote: bool = False
    ideal_of: int | None = None          # a copy of the ideal run of this candidate (no cost, no run)
    score_drop: float | None = None

    @property
    def judged(self) -> RunRow:
        """The run as the spec's failure rule and the strategy judge it: its row with what the search
        measures (``score_drop``), by name like any metric."""
        return self.run if self.score_drop is None else self.run.with_columns(**{SCORE_DROP: self.score_drop})

    @property
    def ok(self) -> bool:
        return self.run.status == "ok"

    def as_run_row(self) -> RunRow:
        """The store row: the run's, with the search's columns."""
        columns: dict[str, Any] = {"strategy": self.strategy, "candidate": self.candidate, "rung": self.rung,
                                   "rung_backend": self.rung_backend, "failed": self.failed,
                                   "failure_reason": self.failure_reason, "elapsed_s": self.elapsed_s}
        columns |= {f"unit_{i}": float(u) for i, u in enumerate(self.unit)}
        columns |= {f"knob_{k}": float(v) for k, v in self.knobs.items()} | {"promote": self.promote}
        columns |= {} if self.ideal_of is None else {"ideal_of": self.ideal_of}
        return self.run.with_columns(**columns, **({} if self.score_drop is None else {SCORE_DROP: self.score_drop}))

    @classmethod
    def of(cls, row: RunRow) -> SearchRow:
        """The search row a stored row is (its search columns taken out of ``extra``)."""
        extra = dict(row.extra)
        own = {k: extra.pop(k) for k in _COLUMNS if k in extra}
        unit = tuple(float(extra.pop(k)) for k in sorted((k for k in list(extra) if k.startswith("unit_")),
                                                         key=lambda k: int(k[len("unit_"):])))
        knobs = {k[len("knob_"):]: float(extra.pop(k)) for k in list(extra) if k.startswith("knob_")}
        ideal_of, drop = own.get("ideal_of"), own.get(SCORE_DROP)
        return cls(replace(row, extra=extra), own.get("strategy") or "", int(own["candidate"]), int(own["rung"]),
                   own.get("rung_backend") or row.id.fidelity.backend, bool(own.get("failed")),
                   own.get("failure_reason") or "", float(own.get("elapsed_s") or 0.0), unit, knobs,
                   bool(own.get("promote")), None if ideal_of is None else int(ideal_of),
                   None if drop is None or math.isnan(drop) else float(drop))


def read_search_rows(root: Path) -> list[SearchRow]:
    """The rows of a strategy's search directory, in the order they finished."""
    store = ResultsStore(root)
    rows = [SearchRow.of(r) for r in store.run_rows()] if store.rows_dir.exists() else []
    return sorted(rows, key=lambda r: r.elapsed_s)
