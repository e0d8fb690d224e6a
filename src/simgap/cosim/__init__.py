"""The synchronous multi-agent co-simulation loop and the `Run` record it produces."""

from simgap.cosim.fidelity import REFERENCE, Fidelity
from simgap.cosim.loop import CosimSettings, not_started, simulate
from simgap.cosim.record import AgentOutcome, Event, Outcome, PlannerError, Run
from simgap.sim.protocol import EventKind

__all__ = ["AgentOutcome", "CosimSettings", "Event", "EventKind", "Fidelity", "Outcome", "PlannerError", "REFERENCE", "Run",
           "not_started", "simulate"]
