"""A run as a rerun recording (``NAME.rrd``), to scrub in rerun's viewer (``rerun NAME.rrd``).

Everything is on one timeline, ``sim_time``, the run's simulated time:

- ``world/road/bounds`` and ``world/road/centre_lines``: the lanelets' bounds and centre lines,
  static (at the road's height where a 3D world drove on a relief)
- ``world/NAME/car`` per road user (``agent_ID``, and ``obstacle_ID`` for traffic, the names the
  OpenSCENARIO export gives them): its box, posed at every driven state (x, y, yaw; in a 3D world
  also z, pitch and roll from the record's attitudes); ``world/NAME/driven``: its whole path
- ``world/agent_ID/plan``: each plan at the time it was made; ``world/agent_ID/observed``: the
  state its planner observed at each call
- ``world/ideal/agent_ID/...``: with an ideal twin given, its car and path
- ``events`` (a text log) and ``world/events`` (points with labels): goal, off road, collision,
  ... at their time and place
- ``plots/agent_ID/QUANTITY/driven`` (and ``/ideal``): speed, acceleration, steering, yaw rate
  and, in a 3D world, pitch and roll, as time series

It reads the run's record (`simgap.record.read_run`) and its driven scenario, and computes
nothing: a pose is put in rerun's frame (z up; a quaternion of yaw, pitch and roll), nothing else.
The file is written beside its destination and renamed into place; no viewer is started.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simgap.cosim.history import Event
from simgap.errors import InputError
from simgap.files import atomic_write
from simgap.record import RunRecord, read_run
from simgap.scenario.ground import ground_of_file
from simgap.scenario.relief import RoadTilt, road_tilt
from simgap.trajectory import Attitude, Trajectory

SIM_TIME = "sim_time"
LINE_LIFT_M = 0.05          # lines drawn this far above the road, so that it does not hide them
ROAD_COLOUR = (150, 150, 150)
CENTRE_COLOUR = (90, 90, 90)
AGENT_COLOURS = [(0, 114, 178), (213, 94, 0), (0, 158, 115), (204, 121, 167), (230, 159, 0), (86, 180, 233)]
TRAFFIC_COLOUR = (120, 120, 120)
IDEAL_COLOUR = (200, 200, 200)
EVENT_COLOUR = (220, 40, 40)
_LEVELS = {"goal_reached": "INFO", "collision": "ERROR", "off_road": "ERROR", "diverged": "ERROR",
           "damage": "ERROR"}                       # other events (no plan, timeout, ...) are warnings

Ground = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass
class RecordingExport:
    """What one rerun export wrote."""

    name: str
    path: Path
    entities: list[str]                              # every entity path logged, sorted
    driven_poses: dict[str, int]                     # per car entity: the poses logged
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)


def recording_path(out: Path, name: str) -> Path:
    """``out`` itself if it names an ``.rrd`` file, else ``NAME.rrd`` in the directory ``out``."""
    return out if out.suffix == ".rrd" else out / f"{name}.rrd"


def export_recording(run_dir: str | Path, out: str | Path, ideal_dir: str | Path | None = None,
                     name: str | None = None) -> RecordingExport:
    """The run of ``run_dir`` as a rerun recording at ``out`` (an ``.rrd`` file, or a directory
    to write ``NAME.rrd`` into); ``ideal_dir``: a run of the same scenario whose cars are drawn
    beside as the ideal twin."""
    import rerun as rr
    import rerun.blueprint as rrb

    from simgap.export.openscenario import road_users
    from simgap.export.write import read_driven_scenario, safe_name

    started = time.perf_counter()
    run_dir = Path(run_dir)
    run = read_run(run_dir)
    ideal = None if ideal_dir is None else read_run(ideal_dir)
    if ideal is not None and ideal.scenario_id != run.scenario_id:
        raise InputError(f"the ideal twin ran scenario '{ideal.scenario_id}', the run '{run.scenario_id}'",
                         file=ideal_dir, field="--ideal", allowed="a run of the same scenario")
    scenario_xml, scenario, _ = read_driven_scenario(run_dir, run)
    name = safe_name(name or f"{run.scenario_id}_{run.history.backend}")
    path = recording_path(Path(out), name)
    three_d = any(a.attitudes for a in run.history.agents)
    ground = _ground(scenario_xml, scenario, road_tilt(run.settings.backend)) if three_d else None
    result = RecordingExport(name, path, [], {})

    def write(tmp: Path) -> None:
        rec = rr.RecordingStream("simgap", recording_id=f"{name}_{run.fingerprint}", send_properties=False)
        rec.save(tmp, default_blueprint=rrb.Blueprint(
            rrb.Horizontal(rrb.Spatial3DView(origin="/world", name="world"),
                           rrb.Vertical(rrb.TimeSeriesView(origin="/plots", name="plots"),
                                        rrb.TextLogView(origin="/events", name="events")),
                           column_shares=[2, 1])))
        rec.send_recording_name(f"{run.scenario_id} — {run.fidelity.label}")
        log = _Log(rec, rr, result, ground)
        log.static("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP)
        log.road(scenario.lanelet_network)
        users = road_users(run, scenario)
        agents = {f"agent_{a.id}": a for a in run.history.agents}
        for i, user in enumerate(users):
            agent = agents.get(user.name)
            colour = AGENT_COLOURS[i % len(AGENT_COLOURS)] if agent else TRAFFIC_COLOUR
            cg_height = agent.vehicle.physics.cg_height if agent and agent.vehicle.physics else None
            log.car(f"world/{user.name}", user.trajectory, user.length, user.width, user.height, colour,
                    agent.attitudes if agent else (), cg_height)
            if agent is None:
                continue
            log.plans(f"world/{user.name}/plan", agent.plans, colour)
            if agent.observed is not None and len(agent.observed):
                log.observed(f"world/{user.name}/observed", agent.observed, colour)
            log.scalars(f"plots/{user.name}", "driven", agent.driven, agent.attitudes)
        if ideal is not None:
            for twin in ideal.history.agents:
                v = twin.vehicle
                height = v.physics.height if v.physics is not None else 1.5
                log.car(f"world/ideal/agent_{twin.id}", twin.driven, v.length, v.width, height, IDEAL_COLOUR, (), None)
                log.scalars(f"plots/agent_{twin.id}", "ideal", twin.driven, ())
        log.events(run)
        rec.flush()
        rec.disconnect()

    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, write, keep_suffix=True)
    result.entities.sort()
    result.seconds = time.perf_counter() - started
    return result


def _ground(scenario_xml: Path, scenario, tilt: RoadTilt) -> Ground | None:
    """The road's height at points, ``tilt`` laid on it as the run did (None: flat)."""
    surface = ground_of_file(scenario_xml, scenario.lanelet_network, tilt)
    if surface is None:
        return None
    return lambda x, y: np.asarray(surface.surface(np.asarray(x, float), np.asarray(y, float)).z, float)


def _quaternions(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray) -> np.ndarray:
    """(x, y, z, w) of the body turned by ``yaw`` about z, then pitched (positive: nose up) and
    rolled (positive: right side down), in rerun's right-handed, z-up frame."""
    half_yaw, half_pitch, half_roll = 0.5 * yaw, -0.5 * pitch, 0.5 * roll    # nose up: a negative turn about y
    cy, sy = np.cos(half_yaw), np.sin(half_yaw)
    cp, sp = np.cos(half_pitch), np.sin(half_pitch)
    cr, sr = np.cos(half_roll), np.sin(half_roll)
    return np.column_stack([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy])


class _Log:
    """What is logged, in rerun's terms, with the entity paths and poses kept for the report."""

    def __init__(self, rec, rr, result: RecordingExport, ground: Ground | None):
        self.rec, self.rr, self.result, self.ground = rec, rr, result, ground

    def _height(self, x, y) -> np.ndarray:
        x = np.asarray(x, float)
        return np.zeros_like(x) if self.ground is None else self.ground(x, np.asarray(y, float))

    def _points(self, x, y) -> np.ndarray:
        return np.column_stack([x, y, self._height(x, y) + LINE_LIFT_M])

    def _entity(self, path: str) -> None:
        if path not in self.result.entities:
            self.result.entities.append(path)

    def static(self, path: str, what) -> None:
        self._entity(path)
        self.rec.log(path, what, static=True, strict=True)

    def columns(self, path: str, t, columns) -> None:
        self._entity(path)
        self.rec.send_columns(path, indexes=[self.rr.TimeColumn(SIM_TIME, duration=np.asarray(t, float))],
                              columns=columns, strict=True)

    def road(self, network) -> None:
        bounds = [b for lanelet in network.lanelets for b in (lanelet.left_vertices, lanelet.right_vertices)]
        centres = [lanelet.center_vertices for lanelet in network.lanelets]
        for path, strips, colour, radius in (("world/road/bounds", bounds, ROAD_COLOUR, 0.08),
                                             ("world/road/centre_lines", centres, CENTRE_COLOUR, 0.03)):
            if strips:
                self.static(path, self.rr.LineStrips3D(
                    [np.column_stack([s[:, 0], s[:, 1], self._height(s[:, 0], s[:, 1])]) for s in strips],
                    colors=colour, radii=radius))

    def car(self, path: str, driven: Trajectory, length: float, width: float, height: float, colour,
            attitudes: tuple[Attitude, ...], cg_height: float | None) -> None:
        """The road user's box posed at every driven state and its whole path (none: it never drove)."""
        rr = self.rr
        if not len(driven):
            return
        x, y, yaw = np.asarray(driven.x), np.asarray(driven.y), np.asarray(driven.yaw)
        if attitudes:
            z = np.array([a.z for a in attitudes])
            pitch, roll = np.array([a.pitch for a in attitudes]), np.array([a.roll for a in attitudes])
            centre_z = 0.5 * height - (cg_height if cg_height is not None else 0.5 * height)   # z: the centre of gravity's
        else:
            z, pitch, roll = self._height(x, y), np.zeros_like(x), np.zeros_like(x)
            centre_z = 0.5 * height
        self.static(f"{path}/car", rr.Boxes3D(half_sizes=[[0.5 * length, 0.5 * width, 0.5 * height]],
                                              centers=[[0.0, 0.0, centre_z]], colors=colour, fill_mode="solid"))
        self.columns(f"{path}/car", driven.t, rr.Transform3D.columns(
            translation=np.column_stack([x, y, z]), quaternion=_quaternions(yaw, pitch, roll)))
        self.result.driven_poses[f"{path}/car"] = len(driven)
        if len(driven) > 1:
            self.static(f"{path}/driven", rr.LineStrips3D([self._points(x, y)], colors=colour, radii=0.05))

    def plans(self, path: str, plans: tuple[Trajectory, ...], colour) -> None:
        """Each plan at the time it was made (its first state's)."""
        made = [p for p in plans if len(p)]
        if not made:
            return
        strips = self.rr.LineStrips3D.columns(strips=[self._points(p.x, p.y) for p in made],
                                              colors=[colour] * len(made), radii=[0.04] * len(made))
        self.columns(path, [float(p.t[0]) for p in made], strips)

    def observed(self, path: str, observed: Trajectory, colour) -> None:
        points = self.rr.Points3D.columns(positions=self._points(observed.x, observed.y),
                                          colors=[colour] * len(observed), radii=[0.15] * len(observed))
        self.columns(path, observed.t, points)

    def scalars(self, path: str, which: str, driven: Trajectory, attitudes: tuple[Attitude, ...]) -> None:
        series = {"speed": driven.v, "acceleration": driven.a, "steering": driven.steer, "yaw_rate": driven.yaw_rate}
        if attitudes:
            series |= {"pitch": [a.pitch for a in attitudes], "roll": [a.roll for a in attitudes]}
        for quantity, values in series.items():
            self.columns(f"{path}/{quantity}/{which}", driven.t,
                         self.rr.Scalars.columns(scalars=np.asarray(values, float)))

    def events(self, run: RunRecord) -> None:
        """Each event as a text log entry at its time, and where it has a place, a labelled point there."""
        rr = self.rr
        events = sorted(run.history.events, key=lambda e: e.t)
        if not events:
            return
        texts = [_text(e) for e in events]
        self.columns("events", [e.t for e in events], rr.TextLog.columns(
            text=texts, level=[_LEVELS.get(e.kind.value, "WARN") for e in events]))
        placed = [(e, text) for e, text in zip(events, texts) if _placed(e)]
        if placed:
            self.columns("world/events", [e.t for e, _ in placed], rr.Points3D.columns(
                positions=self._points([e.x for e, _ in placed], [e.y for e, _ in placed]),
                labels=[text for _, text in placed], radii=[0.3] * len(placed), colors=[EVENT_COLOUR] * len(placed)))


def _text(event: Event) -> str:
    text = f"agent {event.agent_id}: {event.kind.value}"
    if event.other_id is not None:
        text += f" with {event.other_id}"
    return text + (f" ({event.detail})" if event.detail else "")


def _placed(event: Event) -> bool:
    return event.x is not None and event.y is not None and math.isfinite(event.x) and math.isfinite(event.y)
