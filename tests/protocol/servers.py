"""Planner servers for the protocol's tests: `python servers.py BEHAVIOUR`, each a third party's
planner written with the client library alone (no simgap)."""

import math
import os
import signal
import sys
import time

import numpy as np
import zmq

from simgap_planner import Trajectory, serve
from simgap_planner.server import ENDPOINT_VARIABLE

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "examples", "remote_planner"))
from keep_lane import KeepLane  # noqa: E402

BEHAVIOUR = sys.argv[1]
CYCLE_OF_TROUBLE = 3        # the cycle from which a planner misbehaves (the car has started by then)


class Troubled(KeepLane):
    """Keeps its lane until cycle `CYCLE_OF_TROUBLE`, then misbehaves as BEHAVIOUR says."""

    def __init__(self, setup):
        super().__init__(setup)
        self.cycle = 0

    def plan(self, observed, t, world):
        self.cycle += 1
        if self.cycle < CYCLE_OF_TROUBLE:
            return super().plan(observed, t, world)
        if BEHAVIOUR == "hang":
            while True:
                time.sleep(1)
        if BEHAVIOUR == "segfault":
            os.kill(os.getpid(), signal.SIGSEGV)
        if BEHAVIOUR == "exit":
            os._exit(3)
        if BEHAVIOUR == "sys_exit":
            sys.exit(2)
        if BEHAVIOUR == "raise":
            raise RuntimeError("the planner's own bug")
        if BEHAVIOUR == "dict":
            return {"x": [1, 2, 3]}
        plan = super().plan(observed, t, world)
        if BEHAVIOUR == "nan":
            plan.x[5] = math.nan
        elif BEHAVIOUR == "off_grid":
            plan.t[4] += 0.03
        elif BEHAVIOUR == "late_start":
            plan.t += 1.0
        elif BEHAVIOUR == "huge":
            n = 200_000
            plan = Trajectory(self.dt, **{f: np.zeros(n) for f in ("t", "x", "y", "yaw", "v")})
        elif BEHAVIOUR == "slow_once" and self.cycle == CYCLE_OF_TROUBLE:
            time.sleep(1.0)
        elif BEHAVIOUR == "late_then_silent":      # a little over a 0.2 s deadline once, then no answer ever
            time.sleep(0.25 if self.cycle == CYCLE_OF_TROUBLE else 3600)
        elif BEHAVIOUR == "always_late":           # a little over a 0.2 s deadline, every cycle
            time.sleep(0.25)
        return plan


def garbage() -> None:
    """Answers every request with bytes that are not a protobuf Reply."""
    socket = zmq.Context.instance().socket(zmq.REP)
    socket.bind(os.environ[ENDPOINT_VARIABLE])
    while True:
        socket.recv()
        socket.send(b"\xff\xfe not a reply")


if __name__ == "__main__":
    if BEHAVIOUR == "garbage_bytes":
        garbage()
    elif BEHAVIOUR == "hang_init":
        time.sleep(3600)
    elif BEHAVIOUR == "refuse_init":
        def refuse(setup):
            raise ValueError("needs settings.map_name")
        serve(refuse)
    elif BEHAVIOUR.startswith("serve_at="):
        serve(KeepLane, BEHAVIOUR.partition("=")[2])
    else:
        serve(Troubled if BEHAVIOUR != "keep_lane" else KeepLane)
