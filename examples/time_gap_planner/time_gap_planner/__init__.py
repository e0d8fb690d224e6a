"""An example simgap planner package: `TimeGapPlanner` (see planner.py)."""

from time_gap_planner.planner import TimeGapPlanner

__all__ = ["TimeGapPlanner"]
