"""Reality knobs: what the 2D world assumes and the real world does not, as parameters a search
can vary in the higher fidelities. Each knob's default is the ideal world's assumption, so a
knob left out of a search spec changes nothing.

=================  ======  =======  ===================  ==========================================
knob               unit    default  fidelities           meaning
=================  ======  =======  ===================  ==========================================
road_friction      -       1.0      dynamic, mujoco      road friction, scales the tyres' (dry 1.0,
                                                         wet about 0.6, snow about 0.3)
steer_delay        s       0        dynamic, mujoco,     steering actuator dead time
                                    beamng
pedal_delay        s       0        dynamic, mujoco,     throttle and brake dead time
                                    beamng
position_noise     m       0        dynamic, mujoco,     std. dev. of the noise on the x and y the
                                    beamng               planner observes
yaw_noise          deg     0        dynamic, mujoco,     ... on the heading it observes
                                    beamng
speed_noise        m/s     0        dynamic, mujoco,     ... on the speed it observes
                                    beamng
road_bank          deg     0        mujoco               cross slope; positive falls to the right
road_grade         deg     0        mujoco               grade; positive uphill
=================  ======  =======  ===================  ==========================================

The ideal fidelity never takes a knob: it is the world of the planner's assumptions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping


@dataclass(frozen=True)
class Knob:
    name: str
    unit: str
    default: float
    low: float                  # the widest range a spec may ask for
    high: float
    backends: tuple[str, ...]
    setting: str                # a backend setting, or cosim.<section>.<field>
    meaning: str


KNOBS: dict[str, Knob] = {k.name: k for k in (
    Knob("road_friction", "-", 1.0, 0.1, 1.5, ("dynamic", "mujoco"), "road_friction",
         "road friction, scales the tyres' (dry 1.0, wet about 0.6, snow about 0.3)"),
    Knob("steer_delay", "s", 0.0, 0.0, 1.0, ("dynamic", "mujoco", "beamng"), "steer_delay", "steering actuator dead time"),
    Knob("pedal_delay", "s", 0.0, 0.0, 1.0, ("dynamic", "mujoco", "beamng"), "pedal_delay", "throttle and brake dead time"),
    Knob("position_noise", "m", 0.0, 0.0, 5.0, ("dynamic", "mujoco", "beamng"), "cosim.observation_noise.position_m",
         "std. dev. of the noise on the x and y the planner observes"),
    Knob("yaw_noise", "deg", 0.0, 0.0, 30.0, ("dynamic", "mujoco", "beamng"), "cosim.observation_noise.yaw_deg",
         "std. dev. of the noise on the heading the planner observes"),
    Knob("speed_noise", "m/s", 0.0, 0.0, 5.0, ("dynamic", "mujoco", "beamng"), "cosim.observation_noise.speed_mps",
         "std. dev. of the noise on the speed the planner observes"),
    Knob("road_bank", "deg", 0.0, -15.0, 15.0, ("mujoco",), "road_bank",
         "cross slope; positive: the road falls to the right of the way of travel"),
    Knob("road_grade", "deg", 0.0, -15.0, 15.0, ("mujoco",), "road_grade", "grade; positive: uphill"),
)}


def apply_knobs(backend: str, values: Mapping[str, float]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(backend settings, cosim settings) that put the knob ``values`` into ``backend``; knobs
    that do not apply to it are left out."""
    settings: dict[str, Any] = {}
    cosim: dict[str, Any] = {}
    for name, value in values.items():
        knob = KNOBS[name]
        if backend not in knob.backends or value == knob.default:
            continue
        if knob.setting.startswith("cosim."):
            section, field = knob.setting.split(".")[1:]
            cosim.setdefault(section, {})[field] = float(value)
        else:
            settings[knob.setting] = float(value)
    return settings, cosim
