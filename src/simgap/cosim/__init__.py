"""The synchronous multi-agent co-simulation loop and the `Run` record it produces."""

from simgap.cosim.loop import CosimSettings, simulate
from simgap.cosim.record import AgentOutcome, Event, Run

__all__ = ["AgentOutcome", "CosimSettings", "Event", "Run", "simulate"]
