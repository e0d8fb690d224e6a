"""Planners in a process of their own, behind simgap's planner protocol.

The protocol (``planner-protocol/simgap_planner.proto``) is ZeroMQ request/reply with protobuf
messages: the planner binds a REP socket, simgap connects a REQ socket and, per agent, sends
Initialize, then one Plan per planning cycle, then Close. ZeroMQ rather than gRPC: a round trip
costs tens of microseconds (the per-cycle budget is milliseconds), the library is one system
package in every language (libzmq), a planner needs no generated service stubs, only the
messages, and the request/reply pattern with a deadline is the one Autoware's
scenario_simulator_v2 uses to hold simulators in lockstep.

A `RemotePlanner` is a `Planner` like any other to the loop, which waits for each answer before
simulated time moves on (lockstep). It reaches its planner in one of two ways
(`PlannerTarget`): a command that simgap starts (any interpreter, virtual environment or
language; it gets its endpoint in ``SIMGAP_PLANNER_ENDPOINT``), or the address of a planner that
runs on its own. What a planner may do wrong, and what follows:

* no Ready within ``startup_timeout_s``, an Error for Initialize, another protocol major version:
  the constructor raises `PlannerStartFailed` (the run fails, recorded, before it starts);
* no answer within ``deadline_s``: that cycle fails ("missed its deadline"); the late answer is
  dropped when it comes (every send and receive waits at most until its deadline; a reply over
  `MAX_REPLY_BYTES` is not read and counts as none);
* an Error reply: the cycle fails as a planner that raised (`RemotePlannerError`, with the
  planner's own traceback);
* a reply that is not a valid plan (not a protobuf Reply, another request's id, columns of unequal length, more than
  `MAX_PLAN_STATES` states; NaNs, wrong grid and wrong start are the loop's `executable_plan`
  checks): the cycle fails ("invalid plan");
* its process ends (an exit, a crash, a segfault): the cycle fails and the planner is restarted
  (``restarts`` times per agent and run), after which `PlannerUnavailable` ends the agent as a
  planner failure;
* names, reasons and tracebacks it sends are cut to `MAX_NAME`, `MAX_REASON` and `MAX_TRACE`
  characters before anything keeps them; of its output, the last `STDERR_TAIL` characters.

A started planner runs below `simgap.planning.supervisor`, which ends whatever the planner starts
(forked children, ``setsid`` daemons) and removes its temporary folder, when simgap closes it and
when simgap's process ends, however it ends.

`simgap.planning.registry.IsolatedPlannerClass` runs a Python planner class of simgap's registry
the same way, in a child process of simgap's own interpreter (`simgap.planning.isolated`): a hang
or a segfault in a plugin costs its agent, never the batch.
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import json
import math
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import zmq
from pydantic import BaseModel, ConfigDict, Field
from simgap_planner import simgap_planner_pb2 as pb
from simgap_planner.messages import (
    PROTOCOL_VERSION,
    column_bytes,
    trajectory_columns,
    trajectory_message,
)
from simgap_planner.server import ENDPOINT_VARIABLE, compatible

from simgap.errors import InputError
from simgap.planning.protocol import Planner, PlannerReport, PlannerSetup, PlannerUnavailable, RemotePlannerError, World
from simgap.trajectory import STATE_FIELDS, State, Trajectory

EXEC_PREFIX = "exec:"
ADDRESS_SCHEMES = ("tcp://", "ipc://")
MAX_PLAN_STATES = 100_000           # a reply with more states is refused, not cut
MAX_REPLY_BYTES = 16 << 20         # a larger reply is not read (a plan of MAX_PLAN_STATES states: 6.4 MB)
POLL_SLICE_S = 0.05                 # how often a wait checks that a started planner still runs [s]
STDERR_TAIL = 2000                  # characters of a dead planner's output kept in the reason
MAX_NAME = 200                      # characters kept of a planner's name, version or error type
MAX_REASON = 1000                   # … of a reason for no plan or an error's message
MAX_TRACE = 20_000                  # … of an error's traceback
OUTPUT_TAIL_BYTES = 4 * STDERR_TAIL  # bytes of its output kept while it runs (UTF-8: up to 4 per character)


class ProcessLimits(BaseModel):
    """How long a planner in a process of its own may take, and how often it may be restarted."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    deadline_s: float = Field(1.0, gt=0, le=60, description="wall time a planning call may take before its cycle "
                              "fails [s] (the answer, when it comes, is dropped)")
    startup_timeout_s: float = Field(60.0, gt=0, le=600, description="wall time from starting (or connecting to) "
                                     "the planner to its Ready [s]")
    restarts: int = Field(1, ge=0, le=10, description="times a started planner whose process ended is restarted, "
                          "per agent and run, before its agent is given up")


@dataclass(frozen=True)
class PlannerTarget:
    """Where a planner runs: a command simgap starts, or the address of a running planner."""

    command: tuple[str, ...] = ()
    address: str | None = None

    @classmethod
    def parse(cls, ref: str) -> PlannerTarget | None:
        """``exec:COMMAND ARGS`` or ``tcp://HOST:PORT`` / ``ipc://PATH``; None for any other reference."""
        if ref.startswith(EXEC_PREFIX):
            try:
                command = tuple(shlex.split(ref[len(EXEC_PREFIX):]))
            except ValueError as exc:
                raise InputError(f"'{ref}' is not a command ({exc})", field="planner",
                                 allowed="exec:PROGRAM ARGS, quoted as in a shell") from None
            if not command:
                raise InputError("'exec:' names no command", field="planner", allowed="exec:PROGRAM ARGS")
            return cls(command=command)
        if ref.startswith(ADDRESS_SCHEMES):
            return cls(address=ref)
        return None

    @property
    def label(self) -> str:
        """A name for job keys and reports: the script's, module's or program's name, or the address."""
        if self.address is not None:
            name = self.address.split("://", 1)[1]
        elif "-m" in self.command[1:-1]:
            name = self.command[self.command.index("-m", 1) + 1]
        else:
            scripts = [a for a in self.command[1:] if a.endswith(".py")]
            name = Path(scripts[0] if scripts else self.command[0]).stem
        return re.sub(r"[^A-Za-z0-9_.-]+", "-", name).strip("-.") or "remote"

    def check(self, file: str | Path | None = None, field_name: str = "planner") -> None:
        """A command's program exists (on PATH or as a file)."""
        if self.command and shutil.which(self.command[0]) is None:
            raise InputError(f"no program '{self.command[0]}' to start the planner with", file=file, field=field_name,
                             allowed="exec:PROGRAM ARGS with PROGRAM on PATH or a path to an executable file")


def capped(text: str, size: int) -> str:
    """``text``, or its first ``size`` characters and how many more it had (what a planner sends is
    stored in every event and record it reaches)."""
    return text if len(text) <= size else f"{text[:size]}… ({len(text) - size} more characters)"


class PlannerStartFailed(RuntimeError):
    """The planner did not become ready: it could not be started, did not answer, or refused."""


class _NoAnswer(Exception):
    """No reply within the time allowed (the planner may still be working)."""


class _Gone(Exception):
    """The started planner's process has ended."""


def initialize_message(setup: PlannerSetup, settings_json: str):
    """The Initialize request of ``setup`` (the planner's settings as a JSON object)."""
    request = pb.Request()
    init = request.initialize
    init.protocol_version = PROTOCOL_VERSION
    init.agent_id = setup.agent_id
    init.dt = setup.dt
    v, limits = setup.vehicle, setup.vehicle.limits
    init.vehicle.name, init.vehicle.length, init.vehicle.width = v.name, v.length, v.width
    init.vehicle.wheelbase, init.vehicle.rear_axle_to_center = v.wheelbase, v.rear_axle_to_center
    init.vehicle.max_steer, init.vehicle.max_steer_rate = limits.max_steer, limits.max_steer_rate
    init.vehicle.max_accel, init.vehicle.max_speed, init.vehicle.v_switch = \
        limits.max_accel, limits.max_speed, limits.v_switch
    init.vehicle.commonroad_vehicle_type = v.commonroad_vehicle_type or 0
    init.vehicle.json = v.model_dump_json()
    init.commonroad_xml = setup.commonroad_xml
    route = setup.route
    init.route.x, init.route.y = column_bytes(route[:, 0]), column_bytes(route[:, 1])
    init.settings_json = settings_json
    return request


def _libc_prctl():
    with contextlib.suppress(Exception):
        return ctypes.CDLL(None).prctl if sys.platform.startswith("linux") else None
    return None


_PRCTL = _libc_prctl()      # looked up here: the child between fork and exec only calls it
SUPERVISOR = Path(__file__).with_name("supervisor.py")


def _end_with_parent() -> None:         # pragma: no cover - runs in the child before exec
    """The supervisor is told (SIGTERM) when simgap's process ends, however it ends, and then ends
    the planner and all it started."""
    _PRCTL(1, signal.SIGTERM)           # PR_SET_PDEATHSIG


class OutputTail:
    """The last bytes a process wrote to a pipe, read as it writes (it is never held up by a full
    pipe) without keeping more than about ``2 * size`` bytes in memory."""

    def __init__(self, fd: int, size: int):
        self._fd, self._size, self._kept = fd, size, bytearray()
        self._reader = threading.Thread(target=self._read, name="planner-output", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        with contextlib.suppress(OSError):
            while chunk := os.read(self._fd, 1 << 16):
                self._kept += chunk
                if len(self._kept) > 2 * self._size:
                    del self._kept[:-self._size]
        with contextlib.suppress(OSError):
            os.close(self._fd)

    def text(self, wait_s: float = 0.5) -> str:
        """What it wrote last (after the pipe's end, waited for up to ``wait_s``)."""
        self._reader.join(wait_s)
        return bytes(self._kept[-self._size:]).decode(errors="replace")


@dataclass
class _Connection:
    """A REQ socket to a planner, and the process simgap started for it (None for an address):
    the planner below a `simgap.planning.supervisor`, which ends whatever the planner started."""

    endpoint: str
    process: subprocess.Popen | None = None
    folder: Path | None = None
    output: OutputTail | None = None
    socket: Any = None
    monitor: Any = None                 # the socket's disconnections (a reply over MAX_REPLY_BYTES drops one)
    ids: Any = field(default_factory=lambda: itertools.count(1))

    @classmethod
    def open(cls, target: PlannerTarget) -> _Connection:
        if target.address is not None:
            connection = cls(target.address)
        else:
            folder = Path(tempfile.mkdtemp(prefix="simgap-planner-"))
            endpoint = f"ipc://{folder}/planner.sock"
            read_end, write_end = os.pipe()
            try:
                process = subprocess.Popen(
                    [sys.executable, "-I", "-S", str(SUPERVISOR), str(os.getpid()), str(folder), "--",
                     *target.command], stdin=subprocess.DEVNULL, stdout=write_end, stderr=write_end,
                    env={**os.environ, ENDPOINT_VARIABLE: endpoint}, start_new_session=True,
                    preexec_fn=_end_with_parent if _PRCTL is not None else None)
            except OSError as exc:
                os.close(read_end)
                shutil.rmtree(folder, ignore_errors=True)
                raise PlannerStartFailed(f"cannot start {shlex.join(target.command)}: {exc}") from None
            finally:
                os.close(write_end)
            connection = cls(endpoint, process, folder, OutputTail(read_end, OUTPUT_TAIL_BYTES))
        socket = zmq.Context.instance().socket(zmq.REQ)
        socket.setsockopt(zmq.REQ_RELAXED, 1)         # a new request after one that got no answer …
        socket.setsockopt(zmq.REQ_CORRELATE, 1)       # … whose late answer is then dropped
        socket.setsockopt(zmq.LINGER, 0)
        socket.setsockopt(zmq.MAXMSGSIZE, MAX_REPLY_BYTES)    # a larger reply drops the connection, unread
        connection.socket = socket
        connection.monitor = socket.get_monitor_socket(zmq.EVENT_DISCONNECTED)
        try:
            socket.connect(connection.endpoint)
        except zmq.ZMQError as exc:
            connection.close()
            raise PlannerStartFailed(f"cannot connect to {connection.endpoint}: {exc}") from None
        return connection

    def call(self, request, timeout_s: float):
        """The reply to ``request`` (its ``id`` set here) within ``timeout_s``; a reply that comes
        later is never returned (a later call drops it)."""
        request.id = next(self.ids)
        end = time.perf_counter() + timeout_s
        self._dropped()
        self._send(request.SerializeToString(), end)
        while True:
            left = end - time.perf_counter()
            if left <= 0:
                raise _NoAnswer(f"its connection dropped meanwhile (a reply over {MAX_REPLY_BYTES >> 20} MiB drops it "
                                "unread)" if self._dropped() else "")
            wait = left if self.process is None else min(left, POLL_SLICE_S)
            if self.socket.poll(max(1, math.ceil(wait * 1000)), zmq.POLLIN):
                try:
                    raw = self.socket.recv(zmq.NOBLOCK)
                except zmq.Again:           # the late answer to an earlier request, dropped: wait on
                    continue
                try:
                    reply = pb.Reply.FromString(raw)
                except Exception as exc:        # protobuf's DecodeError, or worse on garbage
                    raise ValueError(f"not a planner reply ({len(raw)} bytes: {type(exc).__name__})") from None
                if reply.id != request.id:
                    raise ValueError(f"a reply with the id {reply.id} to request {request.id} (a reply carries "
                                     "its request's id)")
                return reply
            if self.process is not None and self.process.poll() is not None:
                raise _Gone(self.exit_reason(self.process))

    def _dropped(self) -> bool:
        """Whether the connection dropped since this was last asked."""
        dropped = False
        while self.monitor.poll(0):
            self.monitor.recv_multipart()
            dropped = True
        return dropped

    def _send(self, data: bytes, end: float) -> None:
        """Send ``data`` by ``end`` (a REQ socket holds a request while it has no peer: the planner
        has not bound its socket yet, or its connection was dropped)."""
        while True:
            try:
                return self.socket.send(data, zmq.NOBLOCK)
            except zmq.Again:
                pass
            left = end - time.perf_counter()
            if left <= 0:
                raise _NoAnswer()
            self.socket.poll(max(1, math.ceil(min(left, POLL_SLICE_S) * 1000)), zmq.POLLOUT)
            if self.process is not None and self.process.poll() is not None:
                raise _Gone(self.exit_reason(self.process))

    def exit_reason(self, process: subprocess.Popen) -> str:
        """How the started ``process`` (this connection's, once it has ended) ended, and its output's end."""
        code = process.returncode
        how = f"was killed by {signal.Signals(-code).name}" if code < 0 and -code in signal.Signals._value2member_map_ \
            else f"exited with code {code}"
        text = self.output.text().strip() if self.output is not None else ""
        tail = f"; its output ends: {text[-STDERR_TAIL:]}" if text else ""
        return f"the planner process {how}{tail}"

    def close(self, request=None) -> None:
        """Send ``request`` (Close) when given and the peer lives; end a started process and
        every process it started."""
        if request is not None and (self.process is None or self.process.poll() is None):
            with contextlib.suppress(Exception):
                self.call(request, 0.5)
        self.socket.disable_monitor()
        self.monitor.close(linger=0)
        self.socket.close(linger=0)
        if self.process is not None:
            if self.process.poll() is None:
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self.process.wait(0.5)
            if self.process.poll() is None:                 # the supervisor ends the planner and its own
                with contextlib.suppress(ProcessLookupError):
                    self.process.terminate()
                with contextlib.suppress(subprocess.TimeoutExpired):
                    self.process.wait(5.0)
            if self.process.poll() is None:                 # it does not end: its group, killed
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        if self.folder is not None:                         # a started process's folder
            shutil.rmtree(self.folder, ignore_errors=True)


class RemotePlanner(Planner):
    """A planner in a process of its own (see the module): the loop's `Planner` on the protocol."""

    def __init__(self, setup: PlannerSetup, target: PlannerTarget, settings_json: str = "{}",
                 limits: ProcessLimits | None = None):
        self.setup, self.target, self.limits = setup, target, limits or ProcessLimits()
        self._init = initialize_message(setup, settings_json)
        self.restarts = self.deadline_misses = 0
        self.name = self.protocol_version = ""
        self.failure_reason = ""
        self._connection: _Connection | None = None
        self._session = 0
        self._start()

    def _start(self) -> None:
        connection = _Connection.open(self.target)
        try:
            reply = connection.call(self._init, self.limits.startup_timeout_s)
        except _NoAnswer:
            connection.close()
            raise PlannerStartFailed(f"no answer to Initialize within {self.limits.startup_timeout_s:g} s "
                                     f"(startup_timeout_s) from {self.where}") from None
        except (_Gone, ValueError) as exc:
            connection.close()
            raise PlannerStartFailed(f"{exc} before it was ready ({self.where})") from None
        body = reply.WhichOneof("body")
        if body != "ready":
            connection.close()
            detail = f"{capped(reply.error.type, MAX_NAME)}: {capped(reply.error.message, MAX_REASON)}" \
                if body == "error" else f"a {body} reply"
            trace = f"\n{capped(reply.error.traceback, MAX_TRACE)}" if body == "error" and reply.error.traceback else ""
            raise PlannerStartFailed(f"the planner refused Initialize: {detail}{trace}")
        version = reply.ready.protocol_version
        if not compatible(version):
            connection.close()
            raise PlannerStartFailed(f"the planner speaks protocol version '{capped(version, MAX_NAME)}', simgap "
                                     f"{PROTOCOL_VERSION}: another major version (or no MAJOR.MINOR) is refused")
        self._connection, self._session = connection, reply.ready.session
        self.name, self.protocol_version = capped(reply.ready.planner, MAX_NAME), version

    @property
    def where(self) -> str:
        return self.target.address or shlex.join(self.target.command)

    def plan(self, observed: State, t: float, world: World) -> Trajectory | None:
        if self._connection is None:
            raise PlannerUnavailable(self.failure_reason)
        request = self._plan_request(observed, t, world)
        try:
            reply = self._connection.call(request, self.limits.deadline_s)
        except _NoAnswer as exc:
            self.deadline_misses += 1
            why = f"; {exc}" if str(exc) else ""
            return self._fail(f"missed its deadline: no answer within {self.limits.deadline_s:g} s{why}")
        except ValueError as exc:
            return self._fail(f"invalid plan: {exc}")
        except _Gone as exc:
            return self._restart(str(exc))
        body = reply.WhichOneof("body")
        if body == "error" and reply.error.type == "InvalidPlan":
            return self._fail(f"invalid plan: {reply.error.message}")
        if body == "error":
            raise RemotePlannerError(capped(reply.error.type or "Error", MAX_NAME),
                                     capped(reply.error.message, MAX_REASON), capped(reply.error.traceback, MAX_TRACE))
        if body != "plan":
            return self._fail(f"invalid plan: a {body or 'empty'} reply to a planning request")
        if reply.plan.WhichOneof("result") != "trajectory":
            return self._fail(capped(reply.plan.no_plan, MAX_REASON) or "no plan")
        return self._trajectory(reply.plan.trajectory)

    def _plan_request(self, observed: State, t: float, world: World):
        request = pb.Request()
        plan = request.plan
        plan.session, plan.t = self._session, t
        for name in STATE_FIELDS:
            setattr(plan.observed, name, getattr(observed, name))
        for participant in world.traffic:
            message = plan.traffic.add()
            message.id, message.length, message.width = participant.id, participant.length, participant.width
            trajectory_message(participant.prediction, message.prediction)
        return request

    def _trajectory(self, message) -> Trajectory | None:
        if len(message.t) > MAX_PLAN_STATES * 8:
            return self._fail(f"invalid plan: {len(message.t) // 8} states (at most {MAX_PLAN_STATES})")
        try:
            columns = trajectory_columns(message)
        except ValueError as exc:
            return self._fail(f"invalid plan: {exc}")
        lengths = {name: len(values) for name, values in columns.items()}
        if len(set(lengths.values())) != 1:
            return self._fail("invalid plan: columns of unequal length (" +
                              ", ".join(f"{k} {n}" for k, n in lengths.items()) + ")")
        if lengths["t"] == 0:
            return self._fail("invalid plan: no states")
        self.failure_reason = ""
        return Trajectory(message.dt, **columns)

    def _fail(self, reason: str) -> Trajectory | None:
        """This cycle's plan when it fails: none, ``reason`` kept as the failure's."""
        self.failure_reason = reason
        return None

    def _restart(self, reason: str) -> Trajectory | None:
        """The planner's process ended: restart it when restarts are left (this cycle has no plan),
        else give the agent up."""
        if self._connection is not None:
            self._connection.close()
            self._connection = None
        if self.restarts >= self.limits.restarts:
            self.failure_reason = f"{reason} (restarted {self.restarts} time(s), no restart left)"
            raise PlannerUnavailable(self.failure_reason)
        self.restarts += 1
        try:
            self._start()
        except PlannerStartFailed as exc:
            self.failure_reason = f"{reason}; restarting it failed: {exc}"
            raise PlannerUnavailable(self.failure_reason) from None
        return self._fail(f"{reason}; restarted")

    def close(self) -> None:
        """Close the session and end a started process (the loop's runs call this once, at the end)."""
        if self._connection is not None:
            request = pb.Request()
            request.close.session = self._session
            self._connection.close(request)
            self._connection = None

    def report(self) -> PlannerReport:
        """What run.json keeps of the planner's process."""
        return PlannerReport(self.where, self.name, self.protocol_version, self.limits.deadline_s,
                             self.deadline_misses, self.restarts)


def not_json(value: Any, path: str = "") -> tuple[str, str] | None:
    """The first part of ``value`` that JSON cannot hold as it is — its dotted path and what it is —
    or None (an infinity or NaN, a date, any object but a finite number, a string, a bool, None, a
    list or a mapping with string or number keys)."""
    if value is None or isinstance(value, (str, bool, int)):
        return None
    if isinstance(value, float):
        return None if math.isfinite(value) else (path, f"{value} is not a finite number")
    if isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            if (problem := not_json(item, f"{path}[{i}]")) is not None:
                return problem
        return None
    if isinstance(value, Mapping):
        for key, item in value.items():
            where = f"{path}.{key}" if path else str(key)
            if not isinstance(key, (str, int, float, bool)) or isinstance(key, float) and not math.isfinite(key):
                return where, f"the key {key!r} (a {type(key).__name__}) is not a name"
            if (problem := not_json(item, where)) is not None:
                return problem
        return None
    return path, f"{value} (a {type(value).__name__}) is not a JSON value"


def json_settings(values: Mapping[str, Any] | None, *, file: str | Path | None = None,
                  prefix: str | None = None) -> dict[str, Any]:
    """A planner's settings as they are, once they are sure to be a JSON object: what a planner
    without a settings model gets in ``setup.settings`` (in its own process: sent as JSON)."""
    settings = dict(values or {})
    problem = not_json(settings)
    if problem is not None:
        path, what = problem
        raise InputError(f"{what}: the settings of a planner without a settings model are a JSON object", file=file,
                         field=".".join(p for p in (prefix, path) if p) or "settings",
                         allowed="finite numbers, strings, true/false, null, lists and mappings "
                         "(quote a date: '2024-01-01')")
    return settings


@dataclass(frozen=True)
class RemotePlannerClass:
    """An out-of-process planner as the registry hands it out: ``build`` starts (or connects to)
    it for one agent. Its settings go to the planner as they are given; it checks them itself."""

    ref: str
    target: PlannerTarget
    limits: ProcessLimits = ProcessLimits()
    origin: str = "process"

    @property
    def description(self) -> str:
        return f"a planner in its own process ({self.target.address or shlex.join(self.target.command)})"

    def settings(self, values: Mapping[str, Any] | None, *, file: str | Path | None = None,
                 prefix: str | None = None, **_: Any) -> dict[str, Any]:
        """``values`` as they are, once they are sure to be JSON (what the planner and run.json get)."""
        return json_settings(values, file=file, prefix=prefix)

    def build(self, setup: PlannerSetup, settings: Mapping[str, Any] | None) -> RemotePlanner:
        return RemotePlanner(setup, self.target, json.dumps(dict(settings or {})), self.limits)
