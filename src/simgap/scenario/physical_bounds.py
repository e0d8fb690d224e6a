"""What a scenario file may state and still describe a road on which vehicles can drive: a
time step, planning problems and lanelets outside these bounds are refused when the file is read,
naming the file and the field, before anything runs."""

from __future__ import annotations

import math
from pathlib import Path

from simgap.errors import InputError

TIME_STEP_ALLOWED = "a finite number of seconds > 0, e.g. 0.1"


def check_time_step(dt: float, *, file: str | Path | None, field: str) -> None:
    """Refuse a scenario time step that is not a finite positive number of seconds."""
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(f"time step {dt:g} s", file=file, field=field, allowed=TIME_STEP_ALLOWED)
