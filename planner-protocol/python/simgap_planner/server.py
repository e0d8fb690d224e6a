"""Serve a planner over simgap's planner protocol: bind a ZeroMQ REP socket, answer each request.

``serve(MyPlanner)`` is all a planner author writes: simgap starts the program with the endpoint
in ``SIMGAP_PLANNER_ENDPOINT`` (the server then ends when simgap closes its last session), or the
program is started on its own with an endpoint to bind (``serve(MyPlanner, "tcp://*:5555")``) and
serves every run that connects until it is stopped.
"""

from __future__ import annotations

import os
import re
import traceback
from typing import Any, Callable, Dict, Optional, Tuple

import zmq
from google.protobuf.message import DecodeError

from simgap_planner import simgap_planner_pb2 as pb
from simgap_planner.messages import PROTOCOL_VERSION, setup_of, state_of, trajectory_message, world_of

ENDPOINT_VARIABLE = "SIMGAP_PLANNER_ENDPOINT"


class Adapter:
    """How requests become a planner's arguments: by default this package's plain types
    (`messages.Setup`, `State`, `World`); simgap's own host of Python planners gives simgap's."""

    def setup(self, message: pb.Initialize) -> Any:
        return setup_of(message)

    def observed(self, message: pb.State) -> Any:
        return state_of(message)

    def world(self, message: pb.PlanRequest, dt: float, setup: Any) -> Any:
        """The world of a planning request (``setup``: what `setup` made of the session's Initialize)."""
        return world_of(message, dt, setup)


def compatible(version: str) -> bool:
    """Whether a peer speaking ``version`` speaks ours: ``MAJOR.MINOR`` (digits) of the same major version."""
    match = re.fullmatch(r"(\d+)\.(\d+)", version)
    return match is not None and match.group(1) == PROTOCOL_VERSION.split(".")[0]


def serve(factory: Callable[[Any], Any], endpoint: Optional[str] = None, *, name: Optional[str] = None,
          adapter: Optional[Adapter] = None) -> None:
    """Answer simgap's requests with planners made by ``factory(setup)`` (a planner class taking a
    `messages.Setup`, or any callable), one per session, until the last session closes (when
    started by simgap) or forever (an ``endpoint`` given here)."""
    started_by_simgap = endpoint is None
    endpoint = endpoint or os.environ.get(ENDPOINT_VARIABLE)
    if not endpoint:
        raise SystemExit(f"simgap_planner.serve: no endpoint; simgap gives one in {ENDPOINT_VARIABLE}, "
                         "or pass one (e.g. tcp://*:5555)")
    adapter = adapter or Adapter()
    name = name or getattr(factory, "__name__", type(factory).__name__)
    context = zmq.Context.instance()
    socket = context.socket(zmq.REP)
    socket.setsockopt(zmq.LINGER, 0)
    socket.bind(endpoint)
    sessions: Dict[int, Tuple[Any, float, Any]] = {}
    served = 0
    try:
        while True:
            reply = _answer(socket.recv(), factory, adapter, sessions, served + 1, name)
            served += reply.HasField("ready")
            socket.send(reply.SerializeToString())
            if started_by_simgap and reply.HasField("closed") and not sessions:
                return
    finally:
        socket.close(linger=0)


def _answer(raw: bytes, factory: Callable[[Any], Any], adapter: Adapter, sessions: Dict[int, Tuple[Any, float, Any]],
            next_session: int, name: str) -> pb.Reply:
    reply = pb.Reply()
    try:
        request = pb.Request.FromString(raw)
    except DecodeError as exc:
        return _error(reply, "DecodeError", f"not a simgap planner request: {exc}")
    reply.id = request.id
    kind = request.WhichOneof("body")
    try:
        if kind == "initialize":
            init = request.initialize
            if not compatible(init.protocol_version):
                return _error(reply, "ProtocolVersion", f"simgap speaks protocol {init.protocol_version}, "
                              f"this planner {PROTOCOL_VERSION}")
            setup = adapter.setup(init)
            sessions[next_session] = (factory(setup), init.dt, setup)
            reply.ready.protocol_version = PROTOCOL_VERSION
            reply.ready.session = next_session
            reply.ready.planner = name
        elif kind == "plan":
            plan = request.plan
            if plan.session not in sessions:
                return _error(reply, "UnknownSession", f"no session {plan.session} (initialise first)")
            planner, dt, setup = sessions[plan.session]
            result = planner.plan(adapter.observed(plan.observed), plan.t, adapter.world(plan, dt, setup))
            if result is None:
                reply.plan.no_plan = str(getattr(planner, "failure_reason", "") or "no plan")
            else:
                try:
                    trajectory_message(result, reply.plan.trajectory)
                except (AttributeError, TypeError, ValueError) as exc:
                    return _error(reply, "InvalidPlan", f"a {type(result).__name__}, not a trajectory ({exc})")
        elif kind == "close":
            planner, _, _ = sessions.pop(request.close.session, (None, 0.0, None))
            if planner is not None and callable(getattr(planner, "close", None)):
                planner.close()
            reply.closed.SetInParent()
        else:
            return _error(reply, "EmptyRequest", "a request with no body")
    except KeyboardInterrupt:
        raise
    except BaseException as exc:    # the planner's own failure (SystemExit too): that request fails, the server goes on
        return _error(reply, type(exc).__name__, str(exc), traceback.format_exc())
    return reply


def _error(reply: pb.Reply, kind: str, message: str, trace: str = "") -> pb.Reply:
    reply.error.type, reply.error.message, reply.error.traceback = kind, message, trace
    return reply
