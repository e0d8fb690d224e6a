"""The Frenetix motion planner (TUM-AVS; PyPI frenetix-motion-planner 2024.1.1) behind simgap's
planner protocol: the planner the MultiDrive paper validated, run unchanged in its own Python 3.10.

    simgap run SCENARIO.xml --out OUT --planner 'exec:examples/frenetix_motion_planner/.venv/bin/python examples/frenetix_motion_planner/serve.py'

Per agent (Initialize) this builds what Frenetix's own simulation builds for an agent: its
`FrenetPlannerInterface` on the scenario's lanelet network and the agent's planning problem, with
our configuration (PLANNER_CONFIG, SIM_CONFIG below: only the keys Frenetix reads on this path,
with the values of its defaults at release 2024.4, the version MultiDrive ran), the vehicle simgap
names and dt from the scenario; no log files or plots, one thread. Frenetix finds its reference
path (CommonRoad's route planner), goal area and desired speed (its velocity planner) itself;
simgap's route is not used.

Per cycle (Plan) it does what Frenetix's agent does, from simgap's inputs:

* the ego state: simgap's observed state, moved from the vehicle's centre to the rear axle
  (Frenetix plans the rear axle), its curvilinear state computed by the planner
  (``start: observed``); or, as in Frenetix's own loop and MultiDrive, where the planner never
  sees the simulated car, the state of its previous plan at this time (``start: planned``);
* the traffic: each participant's predicted centre states from t become a dynamic obstacle of the
  scenario (Frenetix's collision check with slow vehicles) and an entry of its prediction dict
  (its collision-probability cost), in the format of Frenetix's ground-truth predictions;
* one planning step (`update_planner`, `step_interface`), whose optimal Cartesian trajectory
  (rear axle) goes back as vehicle-centre states on the dt grid from t; none: no plan.

Settings (the protocol's settings JSON, or ``KEY=VALUE`` arguments of this script, e.g.
``planner.cost.cost_weights.prediction=200 start=planned``): ``start`` (observed | planned),
``planner`` (changes of PLANNER_CONFIG: planning, cost, debug) and ``simulation`` (of SIM_CONFIG
and the vehicle). An unknown key is an error.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
import sys
import tempfile
from copy import deepcopy
from pathlib import Path

import numpy as np
import simgap_planner
from commonroad.common.file_reader import CommonRoadFileReader
from commonroad.geometry.shape import Rectangle
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.state import CustomState, InitialState
from commonroad.scenario.trajectory import Trajectory as CRTrajectory
from cr_scenario_handler.planner_interfaces.frenet_interface import FrenetPlannerInterface
from cr_scenario_handler.utils.configuration import FrenetConfiguration, SimConfiguration
from frenetix_motion_planner.state import ReactivePlannerState
from omegaconf import OmegaConf

START_MODES = ("observed", "planned")
PREDICTION_VARIANCE = 0.1       # m^2 on the diagonal, as Frenetix's ground-truth predictions

# Our configuration of Frenetix: exactly the keys its code path here reads (FrenetPlannerInterface,
# ReactivePlannerCpp and their base classes; nothing else is read), with the values of Frenetix's
# defaults at release 2024.4, the version MultiDrive ran, except where a comment says otherwise.
# FrenetixPlanner.__init__ adds dt, the vehicle and the log folder; settings may change any key here.
PLANNER_CONFIG = {
    "planning": {
        # the horizon [s]; dt [s] comes from the scenario
        "planning_horizon": 3.0,
        # the samples: end times from t_min [s] to the horizon, end offsets from the reference path
        # from d_min to d_max [m] (and the current one), end speeds from what the acceleration
        # allows; the sets are built for sampling_max density levels, and a cycle samples level
        # sampling_min, then the denser ones below sampling_max while no sample passes (2, 3: one level)
        "t_min": 1.1, "d_min": -3, "d_max": 3, "sampling_min": 2, "sampling_max": 3,
        # below this speed [m/s] the lateral motion is sampled over the arc length, not time
        "low_vel_mode_threshold": 2.0,
        # no sample collision-free: take the feasible one of lowest end speed, earliest end time and
        # end offset nearest the current one
        # (the alternative, "min_risk", needs Frenetix's risk model parameters: not supported here)
        "emergency_mode": "stopping",
    },
    "cost": {
        # the weights of the C++ cost terms; a term of weight 0 is not evaluated (prediction, the
        # collision probability with the predicted traffic, is evaluated whenever it is present)
        "cost_weights": {
            "lateral_jerk": 0.2, "longitudinal_jerk": 0.2, "distance_to_reference_path": 5.0,
            "velocity_offset": 1.0, "prediction": 0.2,
            "acceleration": 0.0, "jerk": 0.0, "orientation_offset": 0.0, "lane_center_offset": 0.0,
            "distance_to_obstacles": 0.0,
        },
    },
    "debug": {
        "use_cpp": True,                # the C++ sampling planner, as Frenetix's main.py and MultiDrive
        "multiproc": False,             # one thread (ours; MultiDrive's multi-agent multiprocessing had the same effect)
        "num_workers": 6,               # threads of the Python planner only (unused here)
        "activate_logging": False,      # ours: no CSV/SQLite logs
        "draw_traj_set": False,         # ours: no copy of every sampled trajectory for plots
        "save_all_traj": False,
        "kinematic_debug": True,        # read by the Python planner only
        "log_risk": False,              # no risk of the chosen trajectory (needs the risk model)
        "msg_log_mode": "WARNING",      # ours: its per-cycle INFO lines would fill simgap's planner log
    },
}
SIM_CONFIG = {
    # one agent per planner process, in this process
    "simulation": {"use_multiagent": False, "multiprocessing": False},
    "visualization": {"ref_path_debug": False},     # no plot of the reference path's curvature
    "behavior": {"use_behavior_planner": False},     # reference path by CommonRoad's route planner
    "occlusion": {"use_occlusion_module": False},
}
# The only risk-model parameters Frenetix reads here: the logistic regression of the probability of a
# severe injury (MAIS 3+) over the impact speed [m/s], p = 1 / (1 + exp(-(const + speed * v))), with
# which it rates a sample that leaves the road; such a sample is rejected whatever p is (p > 0).
# Frenetix loads them, and its risk weights (none used here), from files in WORK/configurations/.
INJURY_REGRESSION = {"const": -4.591, "speed": 0.185}


def configuration(ours: dict, settings: dict | None):
    """``ours`` as an OmegaConf configuration, with the user's ``settings``, which may only change
    keys that exist."""
    config = OmegaConf.create(ours)
    OmegaConf.set_struct(config, True)
    return OmegaConf.merge(config, settings or {})


def write_risk_parameters(work_dir: Path) -> None:
    """The two JSON files Frenetix's planner loads from ``work_dir``/configurations when it starts."""
    folder = work_dir / "configurations"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "harm_parameters.json").write_text(json.dumps({"log_reg": {"ignore_angle": INJURY_REGRESSION}}))
    (folder / "risk.json").write_text("{}")


class FrenetixPlanner:
    """One agent's Frenetix planner: built from a `simgap_planner.Setup`, planning each cycle."""

    def __init__(self, setup: simgap_planner.Setup, defaults: dict | None = None):
        settings = OmegaConf.merge(OmegaConf.create(defaults or {}), OmegaConf.create(setup.settings))
        settings = OmegaConf.to_container(settings)
        unknown = set(settings) - {"start", "planner", "simulation"}
        if unknown:
            raise ValueError(f"unknown settings {sorted(unknown)}; known: start, planner, simulation")
        self.start = settings.get("start", "observed")
        if self.start not in START_MODES:
            raise ValueError(f"start is {self.start!r}, one of {START_MODES}")
        self.dt, self.agent_id = setup.dt, setup.agent_id
        self.rear_to_centre = setup.vehicle.rear_axle_to_center

        v, limits = setup.vehicle, setup.vehicle.limits
        vehicle = {"cr_vehicle_id": v.commonroad_vehicle_type or 2, "length": v.length, "width": v.width,
                   "wheelbase": v.wheelbase, "wb_rear_axle": v.rear_axle_to_center,
                   "wb_front_axle": v.wheelbase - v.rear_axle_to_center, "a_max": limits.max_accel,
                   "v_max": limits.max_speed, "v_switch": limits.v_switch, "delta_min": -limits.max_steer,
                   "delta_max": limits.max_steer, "v_delta_min": -limits.max_steer_rate,
                   "v_delta_max": limits.max_steer_rate}
        mass = v.data.get("physics", {}).get("mass")
        if mass:
            vehicle["mass"] = mass
        self.log_path = tempfile.mkdtemp(prefix="frenetix-")
        config_plan = configuration(OmegaConf.merge(PLANNER_CONFIG, {"planning": {"dt": setup.dt}}),
                                    settings.get("planner"))
        if config_plan.planning.emergency_mode != "stopping" or config_plan.debug.log_risk:
            raise ValueError("Frenetix's risk model is not configured here: emergency_mode must be "
                             "'stopping' and log_risk false")
        config_plan = FrenetConfiguration(config_plan)
        config_sim = SimConfiguration(configuration(
            OmegaConf.merge(SIM_CONFIG, {"vehicle": vehicle, "simulation": {"log_path": self.log_path}}),
            settings.get("simulation")))
        write_risk_parameters(Path(self.log_path))

        scenario_file = Path(self.log_path) / "scenario.xml"
        scenario_file.write_text(setup.commonroad_xml)
        self.scenario, problems = CommonRoadFileReader(str(scenario_file)).open(lanelet_assignment=False)
        if setup.agent_id not in problems.planning_problem_dict:
            raise ValueError(f"the scenario has no planning problem {setup.agent_id} "
                             f"(it has {sorted(problems.planning_problem_dict)})")
        problem = problems.planning_problem_dict[setup.agent_id]
        self.interface = FrenetPlannerInterface(setup.agent_id, config_plan, config_sim, self.scenario, problem,
                                                self.log_path, self.log_path)
        self.planner = self.interface.planner
        self.traffic: list[DynamicObstacle] = []
        self.failure_reason = ""
        self._last = None           # (time step, trajectory pair) of the last plan

    # ---- one cycle ----------------------------------------------------------------------------

    def plan(self, observed: simgap_planner.State, t: float, world: simgap_planner.World):
        step = int(round(t / self.dt))
        predictions = self._set_traffic(world.traffic, t, step)
        try:
            self.interface.x_0, self.interface.x_cl = self._initial_state(observed, step)
        except Exception as exc:        # off the reference path's domain, or heading backwards along it
            self.failure_reason = f"Frenetix cannot place the vehicle on its reference path: {exc}"
            return None
        self.planner.predictionsForCpp = {}     # set_predictions adds to it: drop traffic that has left
        self.interface.update_planner(self.scenario, predictions)
        cartesian = self.interface.step_interface(step)
        if cartesian is None:
            self.failure_reason = "Frenetix found no kinematically feasible trajectory"
            return None
        self._last = (step, self.planner.trajectory_pair)
        return self._centre_trajectory(cartesian.state_list, t)

    def _initial_state(self, observed: simgap_planner.State, step: int):
        """The ego state Frenetix plans from (rear axle) and its curvilinear (lon, lat) state."""
        if self.start == "planned" and self._last is not None:
            last_step, (cartesian, _, lon, lat) = self._last
            k = step - last_step
            if 0 <= k < len(lon):
                state = deepcopy(cartesian.state_list[k])
                state.time_step = step
                return state, (lon[k], lat[k])
        yaw = observed.yaw
        x = observed.x - self.rear_to_centre * math.cos(yaw)
        y = observed.y - self.rear_to_centre * math.sin(yaw)
        # Frenetix compares the heading with its reference path's unwrapped one: take the turn nearest it
        s, _ = self.planner.coordinate_system.convert_to_curvilinear_coords(x, y)
        cosy = self.planner.coordinate_system
        ref = float(np.interp(s, cosy.ref_pos, np.unwrap(cosy.ref_theta)))
        yaw = ref + math.remainder(yaw - ref, 2 * math.pi)
        state = ReactivePlannerState(time_step=step, position=np.array([x, y]), orientation=yaw,
                                     velocity=max(observed.v, 0.0), acceleration=observed.a,
                                     yaw_rate=observed.yaw_rate, steering_angle=observed.steer)
        self.planner.set_x_0(state)                 # its low-velocity mode decides the lateral state's form
        return state, self.planner._compute_initial_states(state)

    def _centre_trajectory(self, states, t: float) -> simgap_planner.Trajectory:
        yaw = np.array([s.orientation for s in states])
        rear = np.array([s.position for s in states])
        return simgap_planner.Trajectory(
            self.dt, t=t + self.dt * np.arange(len(states)),
            x=rear[:, 0] + self.rear_to_centre * np.cos(yaw), y=rear[:, 1] + self.rear_to_centre * np.sin(yaw),
            yaw=yaw, v=[s.velocity for s in states], a=[s.acceleration for s in states],
            yaw_rate=[s.yaw_rate for s in states], steer=[s.steering_angle for s in states])

    # ---- traffic ------------------------------------------------------------------------------

    def _set_traffic(self, traffic, t: float, step: int) -> dict:
        """Replace the scenario's dynamic obstacles by ``traffic`` from time step ``step`` on; return
        Frenetix's prediction dict of them (positions, orientations, speeds, covariances, shape)."""
        if self.traffic:
            self.scenario.remove_obstacle(self.traffic)
        self.traffic, predictions = [], {}
        for p in traffic:
            keep = p.prediction.t >= t - self.dt / 2
            columns = {name: getattr(p.prediction, name)[keep] for name in ("x", "y", "yaw", "v", "a")}
            n = len(columns["x"])
            if n < 2:
                continue
            states = [CustomState(time_step=step + i, position=np.array([columns["x"][i], columns["y"][i]]),
                                  orientation=float(columns["yaw"][i]), velocity=float(columns["v"][i]),
                                  acceleration=float(columns["a"][i])) for i in range(n)]
            initial = InitialState(time_step=step, position=states[0].position, orientation=states[0].orientation,
                                   velocity=states[0].velocity, acceleration=states[0].acceleration,
                                   yaw_rate=0.0, slip_angle=0.0)
            shape = Rectangle(p.length, p.width)
            obstacle_id = p.id
            try:
                obstacle = DynamicObstacle(obstacle_id, ObstacleType.CAR, shape, initial,
                                           TrajectoryPrediction(CRTrajectory(step + 1, states[1:]), shape))
                self.scenario.add_objects(obstacle)
            except ValueError:          # the id names a lanelet or another object of the scenario
                obstacle_id = self.scenario.generate_object_id()
                obstacle = DynamicObstacle(obstacle_id, ObstacleType.CAR, shape, initial,
                                           TrajectoryPrediction(CRTrajectory(step + 1, states[1:]), shape))
                self.scenario.add_objects(obstacle)
            self.traffic.append(obstacle)
            predictions[obstacle_id] = {
                "pos_list": np.column_stack([columns["x"], columns["y"]]),
                "orientation_list": columns["yaw"], "v_list": columns["v"],
                "cov_list": np.tile(np.eye(2) * PREDICTION_VARIANCE, (n, 1, 1)),
                "shape": {"length": p.length, "width": p.width}}
        return predictions

    def close(self) -> None:
        logger = logging.getLogger(f"Message_logger_{self.agent_id}")
        for handler in list(logger.handlers):
            handler.close()
            logger.removeHandler(handler)
        shutil.rmtree(self.log_path, ignore_errors=True)


def main(argv: list[str]) -> None:
    """``serve.py [--endpoint ENDPOINT] [KEY=VALUE ...]``: serve until simgap closes the last session
    (endpoint from simgap), or forever (an endpoint given here, e.g. tcp://*:5555)."""
    endpoint = None
    if argv[:1] == ["--endpoint"] and len(argv) > 1:
        endpoint, argv = argv[1], argv[2:]
    defaults = OmegaConf.to_container(OmegaConf.from_dotlist(argv))
    simgap_planner.serve(lambda setup: FrenetixPlanner(setup, defaults), endpoint, name="frenetix-motion-planner")


if __name__ == "__main__":
    main(sys.argv[1:])
