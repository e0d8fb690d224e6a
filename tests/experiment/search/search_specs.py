"""Search specs for the search tests: the three-rung ladder and a spec file written from fields."""

from __future__ import annotations

from pathlib import Path

import yaml

LADDER = [{"backend": "ideal"},
          {"backend": "dynamic", "settings": {"integration_step": 0.004, "controller_hz": 50},
           "cosim": {"replan_every": 10}},
          {"backend": "mujoco"}]


def write(tmp_path: Path, **fields) -> Path:
    spec = {"name": "t", "logical": "curve", "parameters": {"radius": {"min": 10, "max": 50}},
            "knobs": {"road_friction": {"min": 0.2, "max": 1.0}}, "ladder": LADDER} | fields
    path = tmp_path / "search.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path
