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


def raw(version: str = "1.0", name_chars: int = 3, reason_chars: int = 7, id_shift: int = 0,
        output_bytes: int = 0, exit_code: int = -1) -> None:
    """Answers Initialize with Ready(``version``, a name of ``name_chars``), each Plan with a no_plan reason of
    ``reason_chars`` (its id shifted by ``id_shift``); writes ``output_bytes`` to stdout first (and then
    exits with ``exit_code`` when it is not -1)."""
    from simgap_planner import simgap_planner_pb2 as pb
    for _ in range(output_bytes >> 20):
        sys.stdout.write("x" * (1 << 20))
    print("the last line of the output", flush=True)
    if exit_code != -1:
        sys.exit(exit_code)
    socket = zmq.Context.instance().socket(zmq.REP)
    socket.bind(os.environ[ENDPOINT_VARIABLE])
    while True:
        request = pb.Request.FromString(socket.recv())
        reply = pb.Reply(id=request.id)
        kind = request.WhichOneof("body")
        if kind == "initialize":
            reply.ready.protocol_version, reply.ready.session, reply.ready.planner = version, 1, "n" * name_chars
        elif kind == "plan":
            reply.id += id_shift
            reply.plan.no_plan = "r" * reason_chars
        else:
            reply.closed.SetInParent()
        socket.send(reply.SerializeToString())
        if kind == "close":
            return


def fork_and_daemon() -> None:
    """Keeps its lane; it forked a child and a setsid daemon first (each writes its pid to a file and sleeps)."""
    folder = os.environ["SIMGAP_TEST_PIDS"]
    if os.fork() == 0:
        with open(os.path.join(folder, "child.pid"), "w") as f:
            f.write(str(os.getpid()))
        time.sleep(3600)
        os._exit(0)
    if os.fork() == 0:
        os.setsid()
        if os.fork() == 0:
            with open(os.path.join(folder, "daemon.pid"), "w") as f:
                f.write(str(os.getpid()))
            time.sleep(3600)
        os._exit(0)
    serve(KeepLane)


if __name__ == "__main__":
    if BEHAVIOUR == "garbage_bytes":
        garbage()
    elif BEHAVIOUR.startswith("raw"):        # raw,KEY=VALUE,...: the arguments of raw()
        options = dict(item.partition("=")[::2] for item in BEHAVIOUR.split(",")[1:])
        raw(**{k: (v if k == "version" else int(v)) for k, v in options.items()})
    elif BEHAVIOUR == "fork_and_daemon":
        fork_and_daemon()
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
