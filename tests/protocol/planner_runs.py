"""What the protocol's tests share: a planner server of `servers.py` as a planner reference, and
the reasons a run's events give."""

from __future__ import annotations

import sys
from pathlib import Path

SERVERS = Path(__file__).with_name("servers.py")


def server(behaviour: str) -> str:
    """``exec:`` of `servers.py` behaving as ``behaviour`` says."""
    return f"exec:{sys.executable} {SERVERS} {behaviour}"


def reasons(run) -> str:
    """Every event's detail of ``run``, one a line."""
    return "\n".join(e.detail for e in run.history.events)
