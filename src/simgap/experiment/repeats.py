"""An experiment's repeats as odds: its runs grouped by scenario, fidelity, planner and stage over
their seeds (`simgap.evaluate.odds`), kept beside the results as ``store/odds.parquet``."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from simgap.cosim.history import Outcome
from simgap.evaluate.odds import Odds, odds
from simgap.experiment.run_row import RunRow
from simgap.files import atomic_write

ODDS_FILE = "odds.parquet"


def odds_over_repeats(rows: list[RunRow]) -> list[Odds]:
    """One `Odds` per scenario, fidelity, planner and stage, over its runs' seeds (a run that failed
    as a run counts as a failure), sorted by scenario, fidelity and planner."""
    groups: dict[tuple[str, str, str], list[RunRow]] = {}
    for row in rows:
        fidelity = row.id.fidelity.label + (f" ({row.id.stage})" if row.id.stage else "")
        groups.setdefault((row.id.scenario, fidelity, row.id.planner), []).append(row)
    return [odds(scenario, fidelity, planner,
                 [r.status == "ok" and r.outcome == Outcome.GOAL_REACHED for r in group],
                 [r.metrics.get("max_lateral_offset_m", float("nan")) for r in group])
            for (scenario, fidelity, planner), group in sorted(groups.items())]


def write_odds(store_dir: Path, table: list[Odds]) -> Path | None:
    """``store/odds.parquet``: a row per group, its rates and intervals flat (None: no runs)."""
    if not table:
        return None
    rows = []
    for o in table:
        row = {"scenario": o.scenario, "fidelity": o.fidelity, "planner": o.planner, "runs": o.runs}
        for name in ("goal", "failure"):
            rate = getattr(o, name)
            row |= {f"{name}_rate": rate.value, f"{name}_rate_low": rate.low, f"{name}_rate_high": rate.high}
        for name in ("max_d_median", "max_d_p90"):
            q = asdict(getattr(o, name))
            row |= {f"{name}_m": q["value"], f"{name}_low_m": q["low"], f"{name}_high_m": q["high"]}
        rows.append(row)
    return atomic_write(store_dir / ODDS_FILE, lambda tmp: pq.write_table(pa.Table.from_pylist(rows), tmp))
