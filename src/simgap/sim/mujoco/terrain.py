"""The ground of a road with a relief in the MuJoCo world: the road's surface (a
`simgap.scenario.relief.Surface`, the verges included) sampled on a regular grid over the road and a margin around it — the height and
slope at every node — which the tyres read (`simgap.sim.mujoco.tyre.ground_at`: bilinear, in the
compiled tyre kernel) and which MuJoCo collides with and draws as a height field of the same nodes
(every `HFIELD_STRIDE`-th: a coarser mesh to draw, through the very same heights). Beyond the grid
the ground continues level at its edge's height (where a car waits before it enters the world).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from simgap.scenario.relief import Surface
from simgap.sim.mujoco.tyre import ground_at

CELL_M = 0.5                 # node spacing the tyres see [m]
MARGIN_M = 40.0              # ground around the road's bounding box [m]
MAX_NODES = 4_000_000        # a larger area takes larger cells
HFIELD_STRIDE = 2            # the drawn and colliding height field takes every second node
HFIELD_BASE_M = 2.0          # thickness of the height field below its lowest point [m]


@dataclass(frozen=True)
class Terrain:
    """The ground as a grid: ``grid[0]`` height, ``grid[1]`` dz/dx, ``grid[2]`` dz/dy at nodes
    ``x0 + column * cell``, ``y0 + row * cell``."""

    x0: float
    y0: float
    cell: float
    grid: np.ndarray

    @classmethod
    def of(cls, relief: Surface, bounds: tuple[float, float, float, float]) -> Terrain:
        """The ground of ``relief`` over ``bounds`` (x0, y0, x1, y1: the road) and its margin."""
        rx0, ry0, rx1, ry1 = relief.bounds()
        x0, y0 = min(bounds[0], rx0) - MARGIN_M, min(bounds[1], ry0) - MARGIN_M
        x1, y1 = max(bounds[2], rx1) + MARGIN_M, max(bounds[3], ry1) + MARGIN_M
        cell = max(CELL_M, math.sqrt((x1 - x0) * (y1 - y0) / MAX_NODES))
        # node counts of the form k * HFIELD_STRIDE + 1, so that the height field ends on the last node
        cols = math.ceil((x1 - x0) / cell / HFIELD_STRIDE) * HFIELD_STRIDE + 1
        rows = math.ceil((y1 - y0) / cell / HFIELD_STRIDE) * HFIELD_STRIDE + 1
        x, y = np.meshgrid(x0 + cell * np.arange(cols), y0 + cell * np.arange(rows))
        surface = relief.surface(x, y)
        n = surface.normal
        grid = np.stack([surface.z, -n[..., 0] / n[..., 2], -n[..., 1] / n[..., 2]])
        return cls(float(x0), float(y0), float(cell), np.ascontiguousarray(grid))

    @property
    def frame(self) -> np.ndarray:
        """(x0, y0, 1 / cell): where the grid lies, as `ground_at` takes it."""
        return np.array([self.x0, self.y0, 1.0 / self.cell])

    @property
    def lowest(self) -> float:
        return float(self.grid[0].min())

    def at(self, x: float, y: float) -> tuple[float, np.ndarray]:
        """Height and unit normal of the ground at (x, y), as the tyres see it."""
        z, nx, ny, nz = ground_at(self.grid, self.frame, float(x), float(y))
        return z, np.array([nx, ny, nz])

    def heights(self, xy: np.ndarray) -> np.ndarray:
        """Height of the ground at each point of ``xy`` (n, 2)."""
        frame = self.frame
        return np.array([ground_at(self.grid, frame, float(px), float(py))[0] for px, py in xy])

    def add_to(self, spec: mujoco.MjSpec, material: str, friction: float) -> None:
        """The ground as MuJoCo's height field ``terrain`` (colliding like the flat world's plane)."""
        heights = self.grid[0, ::HFIELD_STRIDE, ::HFIELD_STRIDE]
        low, high = float(heights.min()), float(heights.max())
        span = max(high - low, 1e-3)
        rows, cols = heights.shape
        half_x, half_y = (cols - 1) * HFIELD_STRIDE * self.cell / 2, (rows - 1) * HFIELD_STRIDE * self.cell / 2
        spec.add_hfield(name="terrain", size=[half_x, half_y, span, HFIELD_BASE_M], nrow=rows, ncol=cols,
                        userdata=((heights - low) / span).ravel().tolist())
        spec.worldbody.add_geom(name="terrain", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain",
                                pos=[self.x0 + half_x, self.y0 + half_y, low], material=material,
                                contype=1, conaffinity=1, friction=[friction, 0.005, 0.0001])
