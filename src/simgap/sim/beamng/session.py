"""The one place simgap talks to BeamNG.tech, through beamngpy.

`BeamngSession` is what the backend needs of a running server — build a scenario of decal
roads and vehicles, step it paused, poll and drive each vehicle — and nothing more, so the
backend can be exercised without a server by any object with the same methods (the tests' fake
server). `connect` first checks that something listens on the port, so an absent server is a
clear error at once, before beamngpy is imported or any run is written.
"""

from __future__ import annotations

import socket
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from simgap.errors import InputError
from simgap.sim.beamng.roads import DecalRoad
from simgap.sim.beamng.settings import ENV, BeamngSettings


@dataclass(frozen=True)
class Spawn:
    """A vehicle to spawn: BeamNG id and model, reference-node position and rotation (x, y, z, w)."""

    vid: str
    model: str
    pos: tuple[float, float, float]
    rot_quat: tuple[float, float, float, float]


@dataclass
class Poll:
    """One vehicle's messages after a poll, as beamngpy returns them."""

    state: dict[str, Any]
    bbox: dict[str, Any]
    electrics: dict[str, Any] = field(default_factory=dict)
    imu: Any = None
    damage: dict[str, Any] = field(default_factory=dict)


class Session(Protocol):
    def build(self, name: str, roads: Sequence[DecalRoad], spawns: Sequence[Spawn], sensors: Sequence[str]
              ) -> None: ...

    def step(self, physics_steps: int) -> None: ...

    def poll(self, vid: str) -> Poll: ...

    def control(self, vid: str, steering: float, throttle: float, brake: float) -> None: ...

    def set_script(self, vid: str, script: list[dict[str, float]]) -> None: ...

    def teleport(self, vid: str, pos: tuple[float, float, float], rot_quat: tuple[float, float, float, float],
                 reset: bool) -> None: ...

    def set_velocity(self, vid: str, speed: float, over_s: float) -> None: ...

    def close(self) -> None: ...


class ServerUnreachable(InputError):
    """No BeamNG.tech server answers where the settings say it runs."""


def probe(host: str, port: int, timeout: float) -> None:
    """Raise `ServerUnreachable` unless a TCP connection to ``host:port`` opens in ``timeout``."""
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
    raise ServerUnreachable(f"no BeamNG.tech server answers at {host}:{port} ({reason})",
                            field="backend_settings.host/port",
                            allowed=f"the address of a running BeamNG.tech server: set host and port in the backend "
                                    f"settings or {ENV['host']} / {ENV['port']}, and start the server first")


def scenario_objects(level: str, name: str, roads: Sequence[DecalRoad], spawns: Sequence[Spawn]):
    """The beamngpy scenario (roads and vehicles with their electrics and damage sensors) and its
    vehicles by id, not yet sent to any server."""
    import beamngpy as bp
    from beamngpy.sensors import Damage, Electrics

    scenario = bp.Scenario(level, name)
    for r in roads:
        road = bp.Road(r.material, rid=r.rid, interpolate=True, drivability=1 if r.drivable else -1,
                       render_priority=r.render_priority)
        road.add_nodes(*r.nodes)
        scenario.add_road(road)
    vehicles = {}
    for s in spawns:
        vehicle = bp.Vehicle(s.vid, model=s.model)
        vehicle.sensors.attach("electrics", Electrics())
        vehicle.sensors.attach("damage", Damage())
        scenario.add_vehicle(vehicle, pos=s.pos, rot_quat=s.rot_quat, cling=True)
        vehicles[s.vid] = vehicle
    return scenario, vehicles


def check_server(settings: BeamngSettings) -> None:
    """Raise `ServerUnreachable` unless the server the backend ``settings`` name answers."""
    probe(settings.host, settings.port, settings.connect_timeout)


class BeamngSession:
    """A scenario in a running BeamNG.tech, through beamngpy (``pip install simgap[beamng]``)."""

    def __init__(self, settings: BeamngSettings):
        probe(settings.host, settings.port, settings.connect_timeout)
        try:
            import beamngpy
        except ImportError:
            raise InputError("beamngpy is not installed", field="backend",
                             allowed="install the extra: pip install 'simgap[beamng]'") from None
        self.settings = settings
        self.bng = beamngpy.BeamNGpy(settings.host, settings.port, home=settings.home, quit_on_close=False)
        self.bng.open(launch=False)
        self.vehicles: dict[str, Any] = {}
        self.imus: dict[str, Any] = {}

    def build(self, name, roads, spawns, sensors) -> None:
        from beamngpy.sensors import AdvancedIMU

        scenario, self.vehicles = scenario_objects(self.settings.level, name, roads, spawns)
        scenario.make(self.bng)
        self.bng.settings.set_deterministic(self.settings.physics_hz)
        self.bng.scenario.load(scenario)
        self.bng.scenario.start()
        self.bng.control.pause()
        for vid in sensors:
            self.imus[vid] = AdvancedIMU(f"imu_{vid}", self.bng, self.vehicles[vid],
                                         physics_update_time=1.0 / self.settings.physics_hz,
                                         is_send_immediately=True, is_visualised=False)

    def step(self, physics_steps: int) -> None:
        self.bng.control.step(physics_steps, wait=True)

    def poll(self, vid: str) -> Poll:
        vehicle = self.vehicles[vid]
        vehicle.sensors.poll()
        imu = self.imus[vid].poll() if vid in self.imus else None
        return Poll(state=dict(vehicle.state), bbox=vehicle.get_bbox(), electrics=dict(vehicle.sensors["electrics"]),
                    imu=imu, damage=dict(vehicle.sensors["damage"]))

    def control(self, vid, steering, throttle, brake) -> None:
        self.vehicles[vid].control(steering=steering, throttle=throttle, brake=brake)

    def set_script(self, vid, script) -> None:
        self.vehicles[vid].ai.set_script(script, cling=True)

    def teleport(self, vid, pos, rot_quat, reset) -> None:
        self.vehicles[vid].teleport(pos, rot_quat, reset=reset)

    def set_velocity(self, vid, speed, over_s) -> None:
        self.vehicles[vid].set_velocity(speed, dt=over_s)

    def close(self) -> None:
        for imu in self.imus.values():
            try:
                imu.remove()
            except Exception:   # the server may already be gone; closing must not hide the run's result
                pass
        try:
            self.bng.disconnect()
        except Exception:
            pass
