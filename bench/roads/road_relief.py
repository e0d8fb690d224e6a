"""Physics on 3D roads against closed form: the MuJoCo sedan on a road's relief.

Every car is `MujocoPlant` on a proving ground shaped by a relief (`simgap.scenario.relief`:
physics 500 Hz, road friction 1.0 x each tyre's); drivers run every 10 ms (braking: every physics
step) and see only the measured state.

* braking — a straight of grade -10, 0 and +10 %, 100 km/h held for 0.5 s, then an ideal ABS to
  standstill: every wheel held at the slip of its tyre's peak longitudinal force (`peak_slip`: the
  Magic Formula's maximum, its spin set every physics step). Drag and rolling resistance are taken
  off the car, as the closed form has none: distance along the road from the onset against
  v^2 / (2 g (mu cos(theta) + sin(theta))), mu the tyre's peak friction (p_dx1), theta the grade's
  angle (positive uphill), v the speed at the onset.
* crest — a straight rising at +g %, over a crest of radius R to -g %, driven at constant speed:
  the sum of the four tyre loads while the centre of gravity passes the top (mean over +-0.1 s)
  against m (g - v^2 / R). The vertical curve is long (60-64 m): entering it steps the road's
  curvature, and the body's bounce on its springs (about 1.5 Hz, damping ratio 0.37) has died
  down by the top.
* bank — a circle of R = 50 m banked by phi (positive: into the turn), driven by pure pursuit at
  constant speed; over the last 4 of 10 s the tyre forces' sum in the road's plane towards the
  centre against the normal one (the friction the turn uses) against the textbook
  (v^2 / (g R) - tan(phi)) / (1 + v^2 / (g R) tan(phi)), R and v the car's measured radius (v over
  its yaw rate) and speed.
* hold — a car braked (full pedal) on a 20 % slope, facing uphill and downhill: how far it moves
  between 1 s (settled on its springs) and 6 s.
* flat — a relief that is flat everywhere against no relief (MuJoCo's plane): the terrain path of
  the tyre kernel, driven 10 s on a circle; largest distance between the two cars' positions.
* realtime — physics + control of one car (pure pursuit, R = 50 m circle at 15 m/s, 20 s; no
  planner) on the flat proving ground and on a 3D one (the circle banked 6 deg): simulated / wall
  time, best of ``--rounds``.

Usage: python bench/roads/road_relief.py [--sections braking crest bank hold flat realtime] [--rounds 3]
       [--json-out bench/results/road_relief.json]
Prints a table per section (measured, closed form, error %); no pass/fail.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from simgap.control import LongitudinalMap, make_controller, manoeuvres
from simgap.control.protocol import Command
from simgap.files import BenchmarkResults
from simgap.scenario.geometry import Arc, Straight, centre_line
from simgap.scenario.relief import BankKnot, ElevationProfile, ReliefProfile, RoadRelief, VerticalCurve
from simgap.sim.dynamic import track_plans
from simgap.sim.mujoco.plant import AGENT, MujocoPlant
from simgap.trajectory import State
from simgap.vehicles import Vehicle, load_vehicle
from simgap.vehicles.constants import GRAVITY

PERIOD = 0.01                   # s, drivers
PHYSICS_STEP = 0.002            # s, the plant's physics step (500 Hz)
BRAKING_SPEED = 100.0 / 3.6
SECTIONS = ("braking", "crest", "bank", "hold", "flat", "realtime")
RESULTS = Path(__file__).resolve().parents[1] / "results" / "road_relief.json"
CIRCLE_RADIUS = 50.0


def straight_relief(profile: ReliefProfile, length: float = 600.0) -> RoadRelief:
    """``profile`` on a straight reference line along +x from x = -100 m."""
    return RoadRelief(profile, centre_line([Straight(length=length)], start=(-100.0, 0.0), max_step=0.2))


def circle_relief(bank_into_turn: float) -> RoadRelief:
    """A counter-clockwise circle of `CIRCLE_RADIUS` through the origin (the manoeuvre's), banked
    into the turn (falling to its left) by ``bank_into_turn`` degrees."""
    return RoadRelief(ReliefProfile(superelevation=(BankKnot(s=0.0, bank=-bank_into_turn),)),
                      centre_line([Arc(radius=CIRCLE_RADIUS, angle=360.0)], max_step=0.2))


def straight_ahead(state: State) -> float:
    """The drivers' steering on a straight: keep the heading and the line y = 0."""
    return -1.0 * state.yaw - 0.05 * state.y


def hold_speed(pedals: LongitudinalMap, target: float, state: State) -> Command:
    """Straight ahead, a P driver on speed."""
    return Command(straight_ahead(state), *pedals.pedals(2.0 * (target - state.v), max(state.v, 0.0)))


def speed_3d(plant: MujocoPlant) -> float:
    car = plant.world.cars[AGENT]
    return float(np.linalg.norm(plant.world.data.qvel[car.qvel:car.qvel + 3]))


def position_3d(plant: MujocoPlant) -> np.ndarray:
    car = plant.world.cars[AGENT]
    return plant.world.data.qpos[car.qpos:car.qpos + 3].copy()


# --- braking ------------------------------------------------------------------------------------
def peak_slip(vehicle: Vehicle) -> float:
    """The slip ratio of the tyre's peak longitudinal force (pure slip, the Magic Formula's
    maximum; the same at every load when mu does not change with it)."""
    mf = vehicle.physics.tyres.magic_formula
    stiffness = mf.p_kx1 / (mf.p_cx1 * mf.p_dx1)

    def force(kappa: float) -> float:
        bx = stiffness * kappa
        return math.sin(mf.p_cx1 * math.atan(bx - mf.p_ex1 * (bx - math.atan(bx))))

    return float(minimize_scalar(lambda k: -force(k), bounds=(0.0, 1.0), method="bounded").x)


def without_resistance(vehicle: Vehicle) -> Vehicle:
    """``vehicle`` without aerodynamic drag and rolling resistance (the closed forms have none)."""
    physics = vehicle.physics.model_copy(update={"drag_coefficient_area": 0.0, "rolling_resistance": 0.0})
    return vehicle.model_copy(update={"physics": physics})


@dataclass(frozen=True)
class Check:
    """A figure measured in the MuJoCo world beside its closed form (each check's own unit)."""

    measured: float
    closed_form: float

    @property
    def error_percent(self) -> float:
        return 100.0 * (self.measured / self.closed_form - 1.0)

    def cells(self) -> list[str]:
        """The row of the check's table (its columns: `Check.columns`)."""
        return [f"{self.measured:.4g}", f"{self.closed_form:.4g}", f"{self.error_percent:+.2f}%"]

    columns = ("measured", "closed form", "error")


@dataclass(frozen=True)
class Braking(Check):
    """Stopping distance [m] from ``speed`` [m/s] on a grade."""

    grade_percent: float = 0.0
    speed: float = 0.0

    def cells(self) -> list[str]:
        return [f"{self.grade_percent:+.0f}%", f"{self.speed:.2f}"] + super().cells()

    columns = ("grade", "v0 [m/s]") + Check.columns


def braking(grade_percent: float, vehicle: Vehicle) -> Braking:
    """An ideal-ABS stop from 100 km/h on a straight of ``grade_percent`` (see the module doc)."""
    car = without_resistance(vehicle)
    plant = MujocoPlant(car, straight_relief(ReliefProfile(elevation=ElevationProfile(grade=grade_percent))))
    pedals = LongitudinalMap.for_vehicle(car)
    state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=BRAKING_SPEED))
    for _ in range(round(0.5 / PERIOD)):
        state = plant.step(hold_speed(pedals, BRAKING_SPEED, state), PERIOD)
    spin_dofs, radius = plant.world.cars[AGENT].spin_dofs, car.physics.wheel_radius
    wheel_speed = 1.0 - peak_slip(car)
    v0 = speed = speed_3d(plant)
    previous, distance = position_3d(plant), 0.0
    while speed > 0.02:
        plant.world.data.qvel[spin_dofs] = wheel_speed * speed / radius
        state = plant.step(Command(straight_ahead(state), 0.0, 0.0), PHYSICS_STEP)
        now = position_3d(plant)
        distance += float(np.linalg.norm(now - previous))
        previous, speed = now, speed_3d(plant)
    theta = math.atan(grade_percent / 100.0)
    mu = car.physics.tyres.magic_formula.p_dx1
    return Braking(distance, v0 ** 2 / (2.0 * GRAVITY * (mu * math.cos(theta) + math.sin(theta))), grade_percent, v0)


# --- crest --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Crest(Check):
    """The sum of the tyre loads [N] at the top of a crest of ``radius`` between +-``grade_percent``,
    passed at ``speed`` [m/s]."""

    radius: float = 0.0
    grade_percent: float = 0.0
    speed: float = 0.0

    def cells(self) -> list[str]:
        return [f"{self.radius:.0f}", f"+-{self.grade_percent:g}%", f"{self.speed:.2f}"] + super().cells()

    columns = ("R [m]", "grades", "v [m/s]") + Check.columns


def crest(radius: float, speed: float, grade_percent: float, vehicle: Vehicle) -> Crest:
    """The tyres' load over a crest of ``radius`` between +-``grade_percent`` at ``speed``."""
    length = radius * 2.0 * grade_percent / 100.0
    top = 150.0 + length / 2                       # station of the vertex; the car starts 50 m before the curve
    plant = MujocoPlant(vehicle, straight_relief(ReliefProfile(elevation=ElevationProfile(
        grade=grade_percent, changes=(VerticalCurve(s=top, grade=-grade_percent, radius=radius),)))))
    pedals = LongitudinalMap.for_vehicle(vehicle)
    state = plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=speed))
    window = 0.1 * speed                             # +-0.1 s of road
    loads, speeds = [], []
    while state.x + 100.0 < top + window:
        state = plant.step(hold_speed(pedals, speed, state), PHYSICS_STEP)
        if abs(state.x + 100.0 - top) <= window:
            loads.append(float(plant.world.tyres.load.sum()))
            speeds.append(speed_3d(plant))
    v = float(np.mean(speeds))
    return Crest(float(np.mean(loads)), vehicle.physics.mass * (GRAVITY - v * v / radius), radius, grade_percent, v)


# --- bank ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BankedTurn(Check):
    """The friction a steady turn uses (tyre forces in the road's plane towards the centre over
    those along its normal) on a bank of ``bank_deg`` into the turn, at the car's ``speed`` [m/s]
    and ``radius`` [m] (speed over yaw rate)."""

    bank_deg: float = 0.0
    speed: float = 0.0
    radius: float = 0.0

    def cells(self) -> list[str]:
        return [f"{self.bank_deg:+.0f} deg", f"{self.speed:.2f}", f"{self.radius:.2f}"] + super().cells()

    columns = ("bank", "v [m/s]", "R [m]") + Check.columns


class _TurnForces:
    """The plant, noting after every step past ``settled`` seconds the tyre forces' sum in the
    road's plane towards the circle's centre and along its normal, the speed and the yaw rate."""

    def __init__(self, plant: MujocoPlant, settled: float):
        self.plant, self.settled, self.samples = plant, settled, []

    def reset(self, initial: State) -> State:
        return self.plant.reset(initial)

    def step(self, command: Command, period: float) -> State:
        state = self.plant.step(command, period)
        if state.t > self.settled:
            world = self.plant.world
            car = world.cars[AGENT]
            force = world.data.xfrc_applied[car.wheel_bodies, :3].sum(axis=0)
            position = world.data.qpos[car.qpos:car.qpos + 3]
            normal = world.terrain.at(position[0], position[1])[1]
            inwards = np.array([-position[0], CIRCLE_RADIUS - position[1], 0.0])
            inwards -= inwards.dot(normal) * normal
            inwards /= np.linalg.norm(inwards)
            self.samples.append((force.dot(inwards), force.dot(normal), state.v, state.yaw_rate))
        return state


def banked_turn(bank_deg: float, speed: float, vehicle: Vehicle, duration: float = 10.0) -> BankedTurn:
    """A steady turn on a circle of R = 50 m banked by ``bank_deg`` into the turn at ``speed``."""
    manoeuvre = manoeuvres.circle(vehicle, CIRCLE_RADIUS, speed, duration=duration)
    turn = _TurnForces(MujocoPlant(vehicle, circle_relief(bank_deg)), duration - 4.0)
    track_plans(turn, make_controller("pure_pursuit", vehicle, 1.0 / PERIOD), lambda t, s: manoeuvre.plan(t, 3.0),
                manoeuvre.initial_state(), manoeuvre.duration)
    inwards, normal, v, yaw_rate = np.mean(turn.samples, axis=0)
    radius = v / yaw_rate
    q, tan_bank = v * v / (GRAVITY * radius), math.tan(math.radians(bank_deg))
    return BankedTurn(float(inwards / normal), (q - tan_bank) / (1.0 + q * tan_bank), bank_deg, float(v), float(radius))


# --- holding on a slope ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Hold:
    grade_percent: float
    facing: str                     # uphill or downhill
    moved_m: float                  # between 1 s and 6 s on the brakes


def hold(grade_percent: float, heading: float, vehicle: Vehicle) -> Hold:
    plant = MujocoPlant(vehicle, straight_relief(ReliefProfile(elevation=ElevationProfile(grade=grade_percent))))
    plant.reset(State(t=0.0, x=0.0, y=0.0, yaw=heading, v=0.0))
    on_brakes = Command(0.0, 0.0, 1.0)
    for _ in range(round(1.0 / PERIOD)):
        plant.step(on_brakes, PERIOD)
    settled = position_3d(plant)
    for _ in range(round(5.0 / PERIOD)):
        plant.step(on_brakes, PERIOD)
    return Hold(grade_percent, "uphill" if math.cos(heading) > 0 else "downhill",
                float(np.linalg.norm(position_3d(plant) - settled)))


# --- a flat relief against the plane ----------------------------------------------------------------
def flat_against_plane(vehicle: Vehicle, duration: float = 10.0) -> float:
    """Largest distance [m] between the car on the plane and on a relief flat everywhere."""
    manoeuvre = manoeuvres.circle(vehicle, CIRCLE_RADIUS, 15.0, duration=duration)
    paths = []
    for relief in (None, circle_relief(0.0)):
        states = track_plans(MujocoPlant(vehicle, relief), make_controller("pure_pursuit", vehicle, 1.0 / PERIOD),
                             lambda t, s: manoeuvre.plan(t, 3.0), manoeuvre.initial_state(), manoeuvre.duration)
        paths.append(np.array([[s.x, s.y] for s in states]))
    return float(np.linalg.norm(paths[0] - paths[1], axis=1).max())


# --- real-time factor --------------------------------------------------------------------------------
def realtime_factor(vehicle: Vehicle, relief: RoadRelief | None, rounds: int, duration: float = 20.0) -> float:
    """Simulated over wall time of physics + control, best of ``rounds``."""
    manoeuvre = manoeuvres.circle(vehicle, CIRCLE_RADIUS, 15.0, duration=duration)
    best = 0.0
    for _ in range(rounds):
        plant = MujocoPlant(vehicle, relief)
        controller = make_controller("pure_pursuit", vehicle, 1.0 / PERIOD)
        state = plant.reset(manoeuvre.initial_state())          # the world is built outside the timing
        controller.reset(state)
        start = time.perf_counter()
        for k in range(round(duration / PERIOD)):
            if k % 10 == 0:
                plan = manoeuvre.plan(k * PERIOD, 3.0)
            state = plant.step(controller.command(state, plan, k * PERIOD), PERIOD)
        best = max(best, duration / (time.perf_counter() - start))
    return best


# --- the tables ---------------------------------------------------------------------------------
def table(title: str, rows: list[Check]) -> list[dict]:
    """Print ``rows`` under ``title``; their figures for the JSON results."""
    print(f"\n## {title}")
    widths = [max(len(c), 9) for c in rows[0].columns]
    print(" ".join(f"{c:>{w}}" for c, w in zip(rows[0].columns, widths)))
    for row in rows:
        print(" ".join(f"{c:>{w}}" for c, w in zip(row.cells(), widths)))
    return [asdict(r) | {"error_percent": r.error_percent} for r in rows]


def run_sections(sections: list[str], rounds: int) -> dict:
    sedan = load_vehicle("sedan")
    results: dict = {}
    if "braking" in sections:
        results["braking"] = table("braking distance [m] from 100 km/h, ideal ABS (every wheel at its peak slip), no "
                                   "drag or rolling resistance, against v^2 / (2 g (mu cos(theta) + sin(theta)))",
                                   [braking(g, sedan) for g in (-10.0, 0.0, 10.0)])
    if "crest" in sections:
        results["crest"] = table("tyre load [N] at the top of a crest: the sum of the four against m (g - v^2 / R)",
                                 [crest(200.0, 25.0, 15.0, sedan), crest(150.0, 22.0, 20.0, sedan),
                                  crest(400.0, 25.0, 8.0, sedan)])
    if "bank" in sections:
        results["bank"] = table("friction a steady turn uses on a bank (R = 50 m), in-plane over normal tyre force, "
                                "against (v^2/gR - tan(phi)) / (1 + v^2/gR tan(phi))",
                                [banked_turn(b, v, sedan) for b, v in ((8.0, 16.0), (0.0, 16.0), (-5.0, 16.0), (12.0, 12.0))])
    if "hold" in sections:
        rows = [hold(20.0, 0.0, sedan), hold(20.0, math.pi, sedan)]
        print("\n## braked on a 20 % slope: movement between 1 s and 6 s")
        for r in rows:
            print(f"facing {r.facing:<8} {1000.0 * r.moved_m:8.3f} mm")
        results["hold"] = [asdict(r) for r in rows]
    if "flat" in sections:
        gap = flat_against_plane(sedan)
        print(f"\n## a relief flat everywhere against the plane: largest position difference over 10 s {gap:.3g} m")
        results["flat_relief_against_plane_m"] = gap
    if "realtime" in sections:
        flat, banked = realtime_factor(sedan, None, rounds), realtime_factor(sedan, circle_relief(6.0), rounds)
        print(f"\n## real-time factor, physics 500 Hz + control 100 Hz, one car, best of {rounds}: flat {flat:.1f}x, "
              f"banked 3D road {banked:.1f}x ({100.0 * (banked / flat - 1.0):+.0f} %)")
        results["realtime"] = {"flat": flat, "relief": banked, "rounds": rounds}
    return results


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sections", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    parser.add_argument("--rounds", type=int, default=3, help="real-time factor: the best of this many runs")
    parser.add_argument("--json-out", type=Path, default=RESULTS, help="where the figures are written")
    args = parser.parse_args(argv)
    results_file = BenchmarkResults()
    start = time.perf_counter()
    results = run_sections(args.sections, args.rounds)
    results_file.write(args.json_out, results)
    print(f"\n[wrote {args.json_out}; {time.perf_counter() - start:.1f} s wall]")


if __name__ == "__main__":
    main()
