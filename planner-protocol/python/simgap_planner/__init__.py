"""Serve a motion planner to simgap, from its own process and interpreter.

    from simgap_planner import serve

    class KeepLane:
        def __init__(self, setup): self.route = setup.route
        def plan(self, observed, t, world): ...   # a Trajectory, or None

    if __name__ == "__main__":
        serve(KeepLane)

The same file runs in simgap's process too (``--planner keep_lane.py:KeepLane``): simgap's own
types carry the field names of these (`messages`). The protocol (ZeroMQ request/reply, protobuf
messages) is in ``simgap_planner.proto``.
"""

from simgap_planner.messages import (
                                     PROTOCOL_VERSION,
                                     STATE_FIELDS,
                                     Participant,
                                     Setup,
                                     State,
                                     Trajectory,
                                     Vehicle,
                                     VehicleLimits,
                                     World,
)
from simgap_planner.server import ENDPOINT_VARIABLE, Adapter, serve

__all__ = ["PROTOCOL_VERSION", "STATE_FIELDS", "ENDPOINT_VARIABLE", "Adapter", "Participant", "Setup", "State",
           "Trajectory", "Vehicle", "VehicleLimits", "World", "serve"]
