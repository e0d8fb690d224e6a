"""Physics backends as a tracker and their physics (nuPlan's ``TwoStageController``: tracker +
motion model). A physics backend supplies only its `Physics` — the world that measures, actuates
and advances its cars; `TrackedBackend` owns what every such backend shares: a tracking
controller per agent (with its actuator delays), the controller rate, and the inner loop that
runs, for each scenario dt,

    for every controller period k:   measure each car -> its controller's command -> its actuators
                                     (dead time, lag) -> actuate it;
                                     then the physics advances one period (its own sub-steps)

The actuators are the vehicle's (`simgap.vehicles.actuators`), with the settings' knobs over
them, or none under ``realism: ideal``; the controller compensates their delays unless
``delay_compensation`` is off (`simgap.control.delay`). A plan that reaches a car during the step
(`PlanHandover`, after the planner's compute latency) is followed from its time on.

and times the phases (``control`` here; ``physics`` and anything finer in the physics). Per
control tick it keeps, for each car, what its controller asked and what the car did (its
`ControlTrace`: steering requested and at the road wheels, acceleration requested and achieved),
which the loop puts into the run's history.

(A *plant* is one car alone — ``reset(state)``, ``step(command, period)`` — see
`simgap.sim.dynamic.closed_loop.Plant`.)
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import Protocol

from commonroad.scenario.scenario import Scenario

from simgap.control import make_controller
from simgap.control.delay import compensated
from simgap.control.longitudinal import LongitudinalMap
from simgap.control.protocol import COMMAND_FIELDS, Command, Controller
from simgap.errors import InputError
from simgap.scenario.relief import Surface
from simgap.sim.protocol import Agent, BackendEvent, PlanInForce, Realism, enters_at, plan_at
from simgap.sim.rates import is_multiple, nearest_multiple
from simgap.sim.settings import TrackingSettings
from simgap.trajectory import DEFAULT_TIME_STEP_S, Attitude, ControlTrace, State
from simgap.vehicles.actuators import ActuatorResponses, Actuators


class Physics(Protocol):
    """The physical world of a physics backend with all its cars, driven one controller period at
    a time."""

    timings: dict[str, float]       # seconds per phase it spent (``physics``, ...)
    notes: list[str]                # what it did that the run record should say

    def load(self, scenario: Scenario, agents: Sequence[Agent], relief: Surface | None = None) -> None: ...

    def reset(self, t0: float) -> None:
        """Put every agent that is present at ``t0`` at its initial state and keep the others out of
        the world until they `enter`; the clock starts at ``t0``."""
        ...

    def enter(self, agent_id: int, t: float) -> None:
        """Put an agent that was out of the world at its initial state (its time ``t`` has come)."""
        ...

    def begin_step(self, t: float) -> None:
        """A scenario step starts at ``t``: forget the last step's events, check the state."""
        ...

    def measure(self, agent_id: int, t: float) -> State: ...

    def attitude(self, agent_id: int) -> Attitude | None:
        """The car's height, pitch and roll now (None: this world has no third dimension for it)."""
        ...

    def actuate(self, agent_id: int, command: Command, period: float) -> None:
        """Hold ``command`` on the car's actuators for the next ``period`` seconds."""
        ...

    def advance(self, t: float, period: float) -> None:
        """Advance every car from ``t`` by ``period`` seconds."""
        ...

    def events(self) -> list[BackendEvent]: ...

    def close(self) -> None: ...


class TrackedBackend:
    """A `Backend`: a `Physics` whose cars each follow their plan under a tracking controller."""

    def __init__(self, name: str, physics: Physics, tracking: TrackingSettings):
        self.name = name
        self.physics = physics
        self.tracking = self._configured = tracking
        self.timings = physics.timings
        self.timings.setdefault("control", 0.0)
        self.notes = physics.notes
        self._agents: list[Agent] = []
        self._dt = DEFAULT_TIME_STEP_S          # the scenario's, once loaded
        self._step = 0
        self._present: list[Agent] = []
        self._actuators: dict[int, Actuators] = {}
        self._responses: dict[int, ActuatorResponses] = {}
        self._pedal_maps: dict[int, LongitudinalMap] = {}
        self._ticks_of: dict[int, list[tuple[State, Command]]] = {}    # per car and control tick: measured, asked

    @property
    def realism(self) -> Realism:
        return self.tracking.realism

    @property
    def control_period(self) -> float:
        return 1.0 / self.tracking.controller_hz

    def load(self, scenario: Scenario, agents: Sequence[Agent], relief: Surface | None = None) -> None:
        self._dt = float(scenario.dt)
        self.tracking = self.fit_rates(self._configured, self._dt)
        self._ticks = int(round(self._dt * self.tracking.controller_hz))
        self._agents = list(agents)
        self.physics.load(scenario, agents, relief)
        self._actuators = {a.id: self.tracking.actuators(a.vehicle) for a in agents}
        self._controllers = {a.id: c for a in agents if (c := self.make_controller(a)) is not None}
        self._pedal_maps = {a.id: LongitudinalMap.for_vehicle(a.vehicle) for a in agents if a.id in self._controllers}
        self._ticks_of = {}
        for a in agents:
            if a.id in self._controllers:
                self.notes.append(self._actuator_note(a))

    def _actuator_note(self, agent: Agent) -> str:
        """What ``agent``'s actuators were, for the run record."""
        act = self._actuators[agent.id]
        if act.ideal:
            missing = self.realism is Realism.REAL and agent.vehicle.actuators is None
            return (f"agent {agent.id}: actuators act at once"
                    + (f" (vehicle {agent.vehicle.name} has none in its data file)" if missing else ""))
        compensation = "compensated" if self.tracking.delay_compensation else "not compensated"
        return f"agent {agent.id}: actuators {act.summary()}; {compensation} by the controller"

    def fit_rates(self, settings: TrackingSettings, dt: float) -> TrackingSettings:
        """``settings`` with a controller rate that divides the scenario's step ``dt``: the one set,
        or, when none was set and the default does not fit (a 30 Hz recording), the multiple of the
        scenario's rate nearest the default (90 Hz), with a note for the run record. A rate that was
        set and does not fit is an `InputError`. A physics whose own rate must divide by the
        controller's adds it here (`MujocoBackend`)."""
        hz, scenario_hz = settings.controller_hz, 1.0 / dt
        if is_multiple(hz, scenario_hz):
            return settings
        if "controller_hz" in settings.model_fields_set:
            raise InputError(f"the scenario's dt {dt:g} s is not a whole number of controller periods at {hz:g} Hz",
                             field="backend_settings.controller_hz", allowed=f"a multiple of {scenario_hz:g} Hz")
        fitted = nearest_multiple(hz, scenario_hz)
        self.notes.append(f"controller at {fitted:g} Hz, the multiple of the scenario's {scenario_hz:g} Hz nearest "
                          f"the default {hz:g} Hz")
        return settings.model_copy(update={"controller_hz": fitted})

    def make_controller(self, agent: Agent) -> Controller | None:
        """The controller that drives ``agent``'s car: the tracking settings' controller,
        compensating its actuators' delays. A backend whose cars drive themselves (BeamNG's script
        AI) returns None: the loop then neither measures nor actuates that car between scenario
        steps."""
        t, v = self.tracking, agent.vehicle
        return compensated(make_controller(t.controller, v, t.controller_hz, t.controller_gains),
                           self._actuators[agent.id], v.wheelbase, v.rear_axle_to_center, t.delay_compensation)

    def _start(self, agent_id: int, state: State) -> None:
        """The car's controller and actuators start from ``state``."""
        if agent_id in self._controllers:
            self._controllers[agent_id].reset(state)
            self._responses[agent_id] = ActuatorResponses(self._actuators[agent_id], self.control_period, state,
                                                          COMMAND_FIELDS)

    def reset(self) -> dict[int, State]:
        self._step = 0
        self._ticks_of = {aid: [] for aid in self._controllers}
        self.physics.reset(0.0)
        self._present = [a for a in self._agents if enters_at(a, 0.0, self._dt)]
        states = {a.id: self.physics.measure(a.id, 0.0) for a in self._present}
        for aid, state in states.items():
            self._start(aid, state)
        return states

    def step(self, plans: Mapping[int, PlanInForce]) -> dict[int, State]:
        physics, timings = self.physics, self.timings
        ticks = self._ticks
        period = self._dt / ticks
        t0 = self._step * self._dt
        physics.begin_step(t0)
        driving = [(a.id, self._controllers[a.id], self._responses[a.id], self._ticks_of[a.id].append)
                   for a in self._present if a.id in self._controllers]
        for k in range(ticks):
            t = t0 + k * period
            start = time.perf_counter()
            for aid, controller, actuators, keep in driving:
                measured = physics.measure(aid, t)
                asked = controller.command(measured, plan_at(plans[aid], t), t)
                physics.actuate(aid, Command(*actuators.respond(asked)), period)
                keep((measured, asked))
            timings["control"] += time.perf_counter() - start
            physics.advance(t, period)
        self._step += 1
        t_end = self._step * self._dt
        self._enter_at(t_end)
        return {a.id: physics.measure(a.id, t_end) for a in self._present}

    def _enter_at(self, t: float) -> None:
        """Agents whose initial time is ``t`` enter the world now."""
        for a in self._agents:
            if a not in self._present and enters_at(a, t, self._dt):
                self.physics.enter(a.id, t)
                self._present.append(a)
                self._start(a.id, self.physics.measure(a.id, t))

    def control_traces(self) -> dict[int, ControlTrace]:
        """Per car its controller drives, what it asked and what the car did at each control tick
        since the last `reset`: the road wheels' angle and the acceleration as measured at the tick,
        the acceleration asked for as the vehicle's pedal map reads the pedals at the measured speed."""
        traces = {}
        for aid, ticks in self._ticks_of.items():
            if ticks:
                acceleration = self._pedal_maps[aid].acceleration
                traces[aid] = ControlTrace(
                    t=[m.t for m, _ in ticks], steer_requested=[c.steer for _, c in ticks],
                    steer_at_wheels=[m.steer for m, _ in ticks],
                    accel_requested=[acceleration(c.throttle, c.brake, m.v) for m, c in ticks],
                    accel_achieved=[m.a for m, _ in ticks])
        return traces

    def attitudes(self) -> dict[int, Attitude]:
        return {a.id: attitude for a in self._present if (attitude := self.physics.attitude(a.id)) is not None}

    def events(self) -> list[BackendEvent]:
        return self.physics.events()

    def close(self) -> None:
        self.physics.close()
