"""What a co-simulation leaves behind: its `History`, frozen.

`simulate` (`simgap.cosim.loop`) returns one: per agent the states it drove, the plans its planner
made, the states its planner observed, how its run ended and when; the events of the run; the
wall time of every planning call and the latency of every plan; in a physical world, what each
car's controller asked and what the car did per control tick; the timings of the loop's phases.
A History holds what happened and nothing computed from it: every metric and score of a run is
`simgap.evaluate.run_evaluation.evaluate`'s, and the record on disk is `simgap.record`'s.
"""

from __future__ import annotations

import hashlib
import traceback
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from simgap.planning.protocol import RemotePlannerError
from simgap.sim.protocol import EventKind, Outcome, Realism, event_kind
from simgap.trajectory import STATE_FIELDS, Attitude, ControlTrace, Trajectory
from simgap.vehicles import Vehicle

AGENT_ID_OFFSET = 100_000       # agent i is obstacle AGENT_ID_OFFSET + i in the driven scenario (driven.xml)


@dataclass(frozen=True)
class Event:
    """Something that happened to an agent at a time and place."""

    t: float
    agent_id: int
    kind: Outcome | EventKind
    x: float | None = None
    y: float | None = None
    detail: str = ""
    other_id: int | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", event_kind(self.kind))


@dataclass(frozen=True)
class PlannerError:
    """An exception a planner raised: in its constructor (``t`` None) or in a planning cycle."""

    agent_id: int
    t: float | None
    exception: str          # the exception's type
    message: str
    traceback: str

    @classmethod
    def of(cls, exc: BaseException, agent_id: int, t: float | None) -> PlannerError:
        trace = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
        remote = exc.remote_traceback if isinstance(exc, RemotePlannerError) else ""   # its process's own too
        return cls(agent_id, t, type(exc).__name__, str(exc),
                   trace + (f"\nThe planner's process reported:\n{remote}" if remote else ""))


@dataclass(frozen=True)
class AgentHistory:
    """One agent's part of a run: what it drove, planned and saw, and how its run ended."""

    id: int
    vehicle: Vehicle                            # the model it drove
    outcome: Outcome
    driven: Trajectory                          # its states until its outcome (the first: where it started)
    plans: tuple[Trajectory, ...] = ()          # every plan its planner made, in order
    observed: Trajectory | None = None          # the state its planner observed at each planning call
                                                # (None: it never planned - it had not entered the world
                                                # when the run ended - or a run of format 1)
    attitudes: tuple[Attitude, ...] = ()        # beside each driven state, where the world is 3D
    standing: Trajectory | None = None          # its states after its outcome while it stayed in the world
                                                # (other agents still driving; None: none)
    planning_call_s: tuple[float, ...] = ()     # wall time of every planning call
    plan_latency_s: tuple[float, ...] = ()      # how long after its planning time each plan reached the car
    planner_failures: int = 0                   # planning cycles without a plan (None or an exception)
    planner_exceptions: int = 0                 # ... of them, cycles in which the planner raised
    controls: ControlTrace | None = None        # what its controller asked and its car did, per control tick
                                                # until its outcome (None: a world that executes plans exactly)

    @property
    def time_to_goal_s(self) -> float | None:
        """When it reached its goal (None: it did not)."""
        return float(self.driven.t[-1]) if self.outcome == Outcome.GOAL_REACHED and len(self.driven) else None


@dataclass(frozen=True)
class History:
    """A run as it happened (frozen): its agents, events, timings and how it ended."""

    scenario_id: str
    backend: str
    dt: float
    realism: Realism
    agents: tuple[AgentHistory, ...]
    events: tuple[Event, ...] = ()
    timings: Mapping[str, float] = field(default_factory=dict)     # seconds per loop phase and backend part
    wall_time_s: float = 0.0
    failure: str | None = None                  # why the run failed as a whole (None: it did not)
    planner_errors: tuple[PlannerError, ...] = ()    # the first few exceptions, with tracebacks
    backend_notes: tuple[str, ...] = ()         # what the backend said about how it built the world
    traffic: Mapping[int, Trajectory] = field(default_factory=dict)   # the road users the loop drove (IDM),
                                                                      # as they drove (replayed ones: none)

    def __post_init__(self) -> None:
        object.__setattr__(self, "timings", dict(self.timings))
        object.__setattr__(self, "traffic", dict(self.traffic))

    def agent(self, agent_id: int) -> AgentHistory:
        return next(a for a in self.agents if a.id == agent_id)

    @property
    def driven(self) -> dict[int, Trajectory]:
        return {a.id: a.driven for a in self.agents}

    @property
    def plans(self) -> dict[int, list[Trajectory]]:
        return {a.id: list(a.plans) for a in self.agents}

    @property
    def vehicles(self) -> dict[int, Vehicle]:
        return {a.id: a.vehicle for a in self.agents}

    def vehicle_of(self, agent_id: int) -> Vehicle:
        return self.agent(agent_id).vehicle

    @property
    def outcome(self) -> Outcome:
        """The first agent outcome that is not reaching the goal."""
        return Outcome.worst([a.outcome for a in self.agents])

    @property
    def fingerprint(self) -> str:
        """The run's identity on any machine: SHA-256 over every agent's driven states quantised to
        `FINGERPRINT_QUANTA` (`quantised_states`). Runs that differ only in the last bits of their
        floats (another BLAS kernel, another CPU) share it; any change of a state by a quantum or
        more changes it."""
        h = hashlib.sha256(b"q1")
        for a in sorted(self.agents, key=lambda a: a.id):
            h.update(str(a.id).encode())
            for f in STATE_FIELDS:
                h.update(quantised_states(getattr(a.driven, f), FINGERPRINT_QUANTA[f]).tobytes())
        return h.hexdigest()[:16]

    @property
    def machine_fingerprint(self) -> str:
        """SHA-256 over the raw float64 bits of every agent's driven states: equal iff the runs drove
        bit for bit identically, which holds on one machine (one CPU, one BLAS kernel) only."""
        h = hashlib.sha256()
        for a in sorted(self.agents, key=lambda a: a.id):
            h.update(str(a.id).encode())
            for f in STATE_FIELDS:
                h.update(np.ascontiguousarray(getattr(a.driven, f), dtype="<f8").tobytes())
        return h.hexdigest()[:16]


#: the quantum of each driven-state field in a run's `History.fingerprint`: 1 us, 1 um, 1 urad,
#: 1e-6 m/s, 1e-6 m/s^2, 1e-6 rad/s. Runs of one scenario, settings and seed on machines whose
#: floating-point kernels differ part by ~1e-13 to 1e-11 (measured on the r = 20 m curve in the
#: ideal, dynamic and MuJoCo worlds, OpenBLAS's SkylakeX against its Haswell kernel), far below these.
FINGERPRINT_QUANTA: Mapping[str, float] = {"t": 1e-6, "x": 1e-6, "y": 1e-6, "yaw": 1e-6, "v": 1e-6, "a": 1e-6,
                                           "yaw_rate": 1e-6, "steer": 1e-6}
_NOT_FINITE = np.iinfo(np.int64).min       # NaN and infinities (a diverged run) quantise to this one integer


def quantised_states(values: np.ndarray, quantum: float) -> np.ndarray:
    """``values`` as little-endian int64 multiples of ``quantum``, the fingerprint's input.

    The rule: ``round(value / quantum)``, a tie (exactly half a quantum) to the even multiple (IEEE
    754's round-half-to-even, numpy's ``rint``); -0.0 and 0.0 are the same multiple; NaN and +-inf are
    one reserved integer, as is a value too large for an int64 multiple (beyond ~4.6e12 quanta). Two machines can still disagree where a value lies within their float
    difference (~1e-11) of a rounding boundary: for a run of ~2 000 state values that is a chance of
    about 1e-4 (each value's |difference| / quantum, summed)."""
    values = np.asarray(values, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        multiples = np.rint(values / quantum)
        representable = np.isfinite(multiples) & (np.abs(multiples) < 2.0 ** 62)
    return np.where(representable, multiples, float(_NOT_FINITE)).astype("<i8")
