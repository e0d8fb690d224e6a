"""The real car, measured: each vehicle's actuator step responses against their sources — of the
actuator model, and of the MuJoCo car through it (the road-wheel angle for a 0.02 rad steering
step at 10 m/s; the longitudinal acceleration for a drive step of 0.3 and a brake step of 0.2
from 10 m/s: the tyres, wheels and body add their own response there) — and the sedan's lateral
tracking on the paper's r = 10 m curve and on a 3.5 m offset manoeuvre at 60 and 80 km/h, per
controller, with and without delay compensation, beside the perfect machine.

The offset manoeuvre is the s-curve template with r = 60 m and 14 degrees: 3.5 m of lateral offset
(ISO 3888-1's lane offset) over 29 m, not the standard's cone track. Tracking error: the lateral
gap between the driven and the promised (planned) centre position, RMS and peak over the run.

Usage: MUJOCO_GL=egl python bench/vehicles/realism.py [--backend mujoco] [--json results.json]
Prints tables; no pass/fail.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from simgap.control import controller_names
from simgap.control.protocol import COMMAND_FIELDS, Command
from simgap.cosim import CosimSettings, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.evaluate.errors import frenet_tracking_errors
from simgap.evaluate.route_centre import route_centre
from simgap.files import BenchmarkResults
from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup
from simgap.scenario import build_scenario
from simgap.sim.mujoco.plant import MujocoPlant
from simgap.sim.registry import backend_settings, make_backend
from simgap.trajectory import State
from simgap.vehicles import load_vehicle, vehicle_names
from simgap.vehicles.actuators import ActuatorResponses
from simgap.vehicles.channels import CHANNELS

STEP_PERIOD = 0.001
CAR_PERIOD = 0.01       # the controllers' period
STEP_AT = 0.5           # s into the manoeuvre
SCENARIOS = {
    "curve r10 90deg": ("curve", {"radius": 10, "angle": 90}),
    "offset 3.5 m, 60 km/h": ("s-curve", {"radius": 60, "angle": 14, "initial_speed": 60 / 3.6}),
    "offset 3.5 m, 80 km/h": ("s-curve", {"radius": 60, "angle": 14, "initial_speed": 80 / 3.6}),
}
# the car: perfect, its actuators alone (exact sensing, no latency), and everything real (the default)
CARS = {
    "ideal car": ({"realism": "ideal"}, {}),
    "actuators, naive": ({"delay_compensation": False}, {"sensing": {"profile": "perfect"}, "latency": 0.0}),
    "actuators, compensated": ({}, {"sensing": {"profile": "perfect"}, "latency": 0.0}),
    "real (default), naive": ({"delay_compensation": False}, {}),
    "real (default)": ({}, {}),
}


def _rise(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Dead time (first move beyond 5 % of the step) and 63 % rise after it, of a step at STEP_AT."""
    base, final = y[t < STEP_AT].mean(), y[-20:].mean()
    share = (y - base) / (final - base)
    after = t >= STEP_AT
    moved = t[after][np.argmax(share[after] > 0.05)] - STEP_AT
    risen = t[after][np.argmax(share[after] >= 1 - math.exp(-1))] - STEP_AT
    return float(moved), float(risen - moved)


def car_step(vehicle_name: str, channel: str) -> tuple[float, float]:
    """The MuJoCo car's response to a step of ``channel`` through its actuators."""
    vehicle = load_vehicle(vehicle_name)
    plant = MujocoPlant(vehicle)
    state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=10.0))
    responses = ActuatorResponses(vehicle.actuators, CAR_PERIOD, state, COMMAND_FIELDS)
    hold = {"steering": 0.12, "drive": 0.0, "brake": 0.0}[channel]     # throttle that about holds 10 m/s
    t, y = [], []
    for k in range(int(2.5 / CAR_PERIOD)):
        now = k * CAR_PERIOD
        on = now >= STEP_AT
        steer = 0.02 if channel == "steering" and on else 0.0
        throttle = 0.3 if channel == "drive" and on else hold
        brake = 0.2 if channel == "brake" and on else 0.0
        state = plant.step(Command(*responses.respond(Command(steer, throttle, brake))), CAR_PERIOD)
        t.append(now + CAR_PERIOD)
        y.append(state.steer if channel == "steering" else state.a)
    return _rise(np.array(t), np.array(y))


def step_responses() -> list[dict]:
    rows = []
    for name in vehicle_names():
        actuators = load_vehicle(name).actuators
        for channel in ("steering", "drive", "brake"):
            spec = actuators[CHANNELS[channel]]
            response = spec.response(STEP_PERIOD)
            out = np.array([response.step(1.0) for _ in range(int(2.0 / STEP_PERIOD))])
            t = STEP_PERIOD * np.arange(1, len(out) + 1)
            dead = float(t[np.argmax(out > 1e-9)] - STEP_PERIOD)
            rise = float(t[np.argmax(out >= 1 - math.exp(-1))] - dead)
            car_dead, car_rise = car_step(name, channel)
            rows.append({"vehicle": name, "channel": channel, "dead_time_s": spec.dead_time, "measured_dead_s": dead,
                         "time_constant_s": spec.time_constant, "measured_rise_s": rise,
                         "car_dead_s": car_dead, "car_rise_s": car_rise})
    return rows


def track(backend: str, scenario_name: str, params: dict, controller: str, settings: dict, cosim: dict) -> dict:
    concrete = build_scenario(scenario_name, params)
    scenario, problems = concrete.scenario, concrete.problems
    sedan = load_vehicle("sedan")
    agents = agents_from_problems(problems, scenario.dt, sedan)
    planners = {a.id: FrenetPlanner(PlannerSetup.for_problem(problems.planning_problem_dict[a.id], sedan,
                                                             scenario.lanelet_network)) for a in agents}
    start = time.perf_counter()
    history = simulate(scenario, problems,
                       make_backend(backend, backend_settings(backend, settings | {"controller": controller})),
                       agents, planners, CosimSettings(**cosim))
    frame = route_centre(scenario.lanelet_network, problems.planning_problem_dict[1])
    lateral = np.abs(frenet_tracking_errors(history.driven[1], history.plans[1], frame).lateral)
    return {"outcome": str(history.agents[0].outcome), "rms_m": float(np.sqrt(np.mean(lateral ** 2))),
            "peak_m": float(lateral.max()), "wall_s": time.perf_counter() - start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--backend", default="mujoco")
    parser.add_argument("--controllers", nargs="+", default=controller_names())
    parser.add_argument("--json", help="write the results here")
    parser.add_argument("--steps-only", action="store_true", help="only the step responses")
    args = parser.parse_args()
    results_file = BenchmarkResults()

    steps = step_responses()
    print("actuator step responses: dead time and 63 % rise after it [s] — the source's, the model's (1 kHz), "
          "the MuJoCo car's")
    print(f"{'vehicle':8} {'channel':9} {'dead':>6} {'model':>6} {'car':>6}   {'tau':>6} {'model':>6} {'car':>6}")
    for r in steps:
        print(f"{r['vehicle']:8} {r['channel']:9} {r['dead_time_s']:6.3f} {r['measured_dead_s']:6.3f} "
              f"{r['car_dead_s']:6.3f}   {r['time_constant_s']:6.3f} {r['measured_rise_s']:6.3f} {r['car_rise_s']:6.3f}")

    tracking = []
    if args.steps_only:
        args.controllers = []
    print(f"\nsedan, Frenet planner, {args.backend}: lateral tracking error RMS / peak [m], outcome")
    for scenario_label, (template, params) in SCENARIOS.items():
        for controller in args.controllers:
            for car, (settings, cosim) in CARS.items():
                r = track(args.backend, template, params, controller, settings, cosim)
                tracking.append({"scenario": scenario_label, "controller": controller, "car": car} | r)
                print(f"{scenario_label:22} {controller:13} {car:24} {r['rms_m']:6.3f} / {r['peak_m']:6.3f}  "
                      f"{r['outcome']:13} ({r['wall_s']:.1f} s)")
    if args.json:
        results_file.write(args.json, {"backend": args.backend, "step_responses": steps, "tracking": tracking})


if __name__ == "__main__":
    main()
