"""A search's budget: wall-clock seconds or runs, the search's total, shared evenly among its
strategies (`Budget.shares`)."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from simgap.errors import InputError

CONFIRMATION_REPEATS = 5      # seeds a violation is confirmed over by default, its own included


@dataclass(frozen=True)
class Budget:
    seconds: float | None = None
    runs: int | None = None

    def spent(self, seconds: float, runs: int) -> bool:
        return (self.seconds is not None and seconds >= self.seconds) or (self.runs is not None and runs >= self.runs)

    def __str__(self) -> str:
        return f"{self.seconds:g} s" if self.seconds is not None else f"{self.runs} runs"

    def option(self) -> str:
        """This budget as ``--budget`` takes it: whole minutes (seconds under two) or runs."""
        if self.seconds is None:
            return str(self.runs)
        return f"{math.ceil(self.seconds / 60)}m" if self.seconds >= 120 else f"{math.ceil(self.seconds)}s"

    def __add__(self, other: Budget) -> Budget:
        if self.seconds is not None:
            return Budget(seconds=self.seconds + (other.seconds or 0.0))
        return Budget(runs=(self.runs or 0) + (other.runs or 0))

    def shares(self, names: list[str]) -> dict[str, Budget]:
        """This budget split evenly among the strategies ``names`` (they are compared on equal
        budgets): seconds divided, runs divided with the remainder to the first ones."""
        if self.seconds is not None:
            return {n: Budget(seconds=self.seconds / len(names)) for n in names}
        assert self.runs is not None
        if self.runs < len(names):
            raise InputError(f"{self.runs} runs cannot be shared among {len(names)} strategies", field="budget",
                             allowed=f"at least {len(names)} runs (the budget is the search's total), or fewer "
                                     "strategies (--strategy)")
        each, extra = divmod(self.runs, len(names))
        return {n: Budget(runs=each + (i < extra)) for i, n in enumerate(names)}


def parse_budget(text: str) -> Budget:
    """``20m``, ``90s``, ``1.5h`` (wall clock) or ``N`` (runs): the search's total, shared among
    its strategies (`Budget.shares`)."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d+)?)\s*([smh]?)\s*", str(text))
    if not m or float(m.group(1)) <= 0:
        raise InputError(f"'{text}' is not a budget", field="budget", allowed="a duration like 20m, 90s, 1.5h, or a run count like 200")
    value, unit = float(m.group(1)), m.group(2)
    if not unit:
        if value != int(value):
            raise InputError(f"'{text}' is not a whole number of runs", field="budget", allowed="200, or 20m")
        return Budget(runs=int(value))
    return Budget(seconds=value * {"s": 1, "m": 60, "h": 3600}[unit])
