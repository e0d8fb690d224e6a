"""Slip-based tyres for the MuJoCo cars: Magic Formula forces applied at each contact patch.

MuJoCo's own contact would make a Coulomb tyre (no slip below the friction limit, so a car
corners on the kinematic steering angle and breaks away all at once). Here MuJoCo keeps the
rigid bodies, suspension, steering, drive and brakes; the tyre-road forces come from this module,
every physics step, for all wheels of all cars at once:

1. **Vertical load** from a radial spring-damper between the wheel centre and the ground
   (``vertical_stiffness``, ``vertical_damping``): the suspension's motion, and so load transfer in
   braking and cornering, changes each tyre's load. The ground is a plane at z = 0, or, on a road
   with a relief, the plane tangent to the terrain under the wheel (`ground_at`: height and slope
   on a grid, interpolated bilinearly); the load acts along its normal, the deflection is the
   wheel centre's distance from it.
2. **Slip** from the contact-patch velocity in the wheel frame (the upright's heading, projected
   onto the ground's tangent plane; the lateral axis in that plane) and the wheel's spin, through first-order *transient slip* (Pacejka, *Tire and
   Vehicle Dynamics*, ch. 7): the tyre deflections u, v obey
   ``du/dt = -|V_x| u / sigma_kappa - V_sx`` and ``dv/dt = -|V_x| v / sigma_alpha + V_sy``, with
   ``kappa = u / sigma_kappa`` and ``tan(alpha) = v / sigma_alpha``. At speed they lag the
   slip by the relaxation length; at standstill they become springs, so a braked car holds on a
   slope without creeping. They are updated implicitly in their own decay, stable at any speed.
3. **Forces** by the Magic Formula, pure and combined slip (`simgap.vehicles.tyres`), the peak
   friction falling with load (the tyre's load sensitivity), changed by camber (the wheel leans
   with the body, less what the suspension linkage turns it in its travel: ``camber_gain``) and
   scaled by the friction of the surface under the tyre (road, verge, the ``road_friction`` knob).
4. **Low speed**: below ``low_speed`` of the contact patch over the ground (forward and
   sideways: a wheel sliding sideways in a spin is not slow, its force is the Magic Formula's) a
   damping force on the slip velocity fades in (as MF-Tyre's low-speed damping), its coefficient
   capped for the explicit step (the wheel's spin inertia reflected to the patch, and critical
   damping of the tyre spring). The total force never exceeds the tyre's peak friction times its
   load.

The force (longitudinal and lateral in the ground's tangent plane, the load along its normal;
gravity stays vertical, MuJoCo's) and its moment are applied to the wheel body (``xfrc_applied``)
at a point one rolling radius below the wheel centre along the ground's normal, so the
longitudinal force brakes or drives the wheel's spin and the lateral force rolls the body, as at a
real contact patch. On the flat plane every product with the normal's zero components adds an
exact zero: a flat world's tyres compute bit for bit what they did before the ground could tilt. Forces enter between ``mj_step1`` (which
computes positions and velocities) and ``mj_step2`` (which integrates), so they belong to the
state they are integrated from. The kernel is compiled by numba (cached on disk): one call for
every wheel of the world costs a few microseconds.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
from numba import njit

from simgap.vehicles.constants import GRAVITY
from simgap.vehicles.physics import VehiclePhysics

# columns of the per-wheel parameter table
(R_ROLL, R_FREE, K_Z, C_Z, SIGMA_X, SIGMA_Y, P_CX1, P_DX1, P_DX3, P_EX1, P_KX1, P_CY1, P_DY1, P_DY3,
 P_EY1, P_KY1, P_KY2, F_Z0, R_BX1, R_BX2, R_CX1, R_EX1, R_BY1, R_BY2, R_CY1, R_EY1, V_LOW, C_LOW_X,
 C_LOW_Y, P_DX2, P_DY2, CAMBER_GAIN) = range(32)
N_PARAMS = 32
# columns of the per-wheel output table
OUT_FZ, OUT_KAPPA, OUT_ALPHA, OUT_FX, OUT_FY, OUT_CAMBER = range(6)
MAX_SLIP_RATIO = 2.0        # |kappa| bound of the transient state (a locked wheel is -1)
MAX_TAN_SLIP_ANGLE = 1.5    # |tan alpha| bound of the transient state (about 56 deg)
SETTLE_MIN_SPEED = 0.5     # m/s: `settle` leaves slower tyres undeflected
LOW_SPEED_DAMPING_SHARE = 0.3   # of the largest damping one explicit physics step can take
EPS = 1e-9


@njit(cache=True)
def _magic(b: float, c: float, d: float, e: float, x: float) -> float:
    bx = b * x
    return d * math.sin(c * math.atan(bx - e * (bx - math.atan(bx))))


@njit(cache=True)
def _weight(b: float, c: float, e: float, x: float) -> float:
    bx = b * x
    return math.cos(c * math.atan(bx - e * (bx - math.atan(bx))))


FLAT_GROUND = np.zeros((3, 0, 0))      # no terrain grid: the plane z = 0
FLAT_FRAME = np.zeros(3)


@njit(cache=True)
def ground_at(grid, frame, x, y):     # pragma: no cover - compiled
    """Height and unit normal (z, nx, ny, nz) of the ground at (x, y): the plane z = 0 when ``grid``
    is empty, else the terrain's ``grid`` (3, rows, columns: height, dz/dx, dz/dy at nodes
    ``frame[0] + column / frame[2]``, ``frame[1] + row / frame[2]``) interpolated bilinearly;
    beyond its edge the edge's height continues level."""
    rows, cols = grid.shape[1], grid.shape[2]
    if rows == 0:
        return 0.0, 0.0, 0.0, 1.0
    fx = (x - frame[0]) * frame[2]
    fy = (y - frame[1]) * frame[2]
    inside = 0.0 <= fx <= cols - 1 and 0.0 <= fy <= rows - 1
    fx = min(max(fx, 0.0), cols - 1.000001)
    fy = min(max(fy, 0.0), rows - 1.000001)
    j, i = int(fx), int(fy)
    u, w = fx - j, fy - i
    w00, w01, w10, w11 = (1.0 - u) * (1.0 - w), u * (1.0 - w), (1.0 - u) * w, u * w
    z = w00 * grid[0, i, j] + w01 * grid[0, i, j + 1] + w10 * grid[0, i + 1, j] + w11 * grid[0, i + 1, j + 1]
    if not inside:
        return z, 0.0, 0.0, 1.0
    gx = w00 * grid[1, i, j] + w01 * grid[1, i, j + 1] + w10 * grid[1, i + 1, j] + w11 * grid[1, i + 1, j + 1]
    gy = w00 * grid[2, i, j] + w01 * grid[2, i, j + 1] + w10 * grid[2, i + 1, j] + w11 * grid[2, i + 1, j + 1]
    norm = math.sqrt(1.0 + gx * gx + gy * gy)
    return z, -gx / norm, -gy / norm, 1.0 / norm


@njit(cache=True)
def tyre_forces(xipos, xmat, cvel, subtree_com, qpos, qvel, xfrc, wheel, upright, root, spin, travel,
                par, mu, u, v, dt, settle, out, grid, frame):     # pragma: no cover - compiled
    for i in range(wheel.shape[0]):
        wb, ub, rb = wheel[i], upright[i], root[i]
        p = par[i]
        re = p[R_ROLL]
        cz = xipos[wb, 2]
        zg, nx, ny, nz = ground_at(grid, frame, xipos[wb, 0], xipos[wb, 1])
        deflection = p[R_FREE] - (cz - zg) * nz
        m = xmat[ub]
        hx, hy, hz = m[0], m[3], m[6]            # upright x axis (wheel heading), onto the ground's plane
        hn = hx * nx + hy * ny + hz * nz
        hx, hy, hz = hx - hn * nx, hy - hn * ny, hz - hn * nz
        norm = math.sqrt(hx * hx + hy * hy + hz * hz) + EPS
        ex_x, ex_y, ex_z = hx / norm, hy / norm, hz / norm
        ey_x, ey_y, ey_z = ny * ex_z - nz * ex_y, nz * ex_x - nx * ex_z, nx * ex_y - ny * ex_x    # n x e_x
        # the wheel leans from the ground's normal with the body, less what its linkage turns it in its travel
        lean = m[1] * nx + m[4] * ny + m[7] * nz
        camber = math.asin(min(max(lean, -1.0), 1.0)) + p[CAMBER_GAIN] * qpos[travel[i]]
        # velocity of the upright at the contact point (world frame)
        rx = xipos[wb, 0] - re * nx - subtree_com[rb, 0]
        ry = xipos[wb, 1] - re * ny - subtree_com[rb, 1]
        rz = cz - re * nz - subtree_com[rb, 2]
        w0, w1, w2 = cvel[ub, 0], cvel[ub, 1], cvel[ub, 2]
        vpx = cvel[ub, 3] + w1 * rz - w2 * ry
        vpy = cvel[ub, 4] + w2 * rx - w0 * rz
        vpz = cvel[ub, 5] + w0 * ry - w1 * rx
        vx = vpx * ex_x + vpy * ex_y + vpz * ex_z
        vy = vpx * ey_x + vpy * ey_y + vpz * ey_z
        ax = abs(vx)
        fz = p[K_Z] * deflection - p[C_Z] * (vpx * nx + vpy * ny + vpz * nz)
        if deflection <= 0.0 or fz <= 0.0:       # wheel in the air: the deflections relax
            u[i] /= 1.0 + dt * max(ax, 1.0) / p[SIGMA_X]
            v[i] /= 1.0 + dt * max(ax, 1.0) / p[SIGMA_Y]
            for k in range(6):
                xfrc[wb, k] = 0.0
            out[i, OUT_FZ] = 0.0
            out[i, OUT_FX] = 0.0
            out[i, OUT_FY] = 0.0
            continue
        if settle:          # a free-rolling wheel, deflected as if it had long been rolling so
            qvel[spin[i]] = vx / re
            u[i] = 0.0
            v[i] = p[SIGMA_Y] * vy / ax if ax > SETTLE_MIN_SPEED else 0.0
        vsx = vx - qvel[spin[i]] * re
        u_max = MAX_SLIP_RATIO * p[SIGMA_X]
        v_max = MAX_TAN_SLIP_ANGLE * p[SIGMA_Y]
        if not settle:
            u[i] = (u[i] - dt * vsx) / (1.0 + dt * ax / p[SIGMA_X])
            v[i] = (v[i] + dt * vy) / (1.0 + dt * ax / p[SIGMA_Y])
        u[i] = min(max(u[i], -u_max), u_max)
        v[i] = min(max(v[i], -v_max), v_max)
        kappa = u[i] / p[SIGMA_X]
        alpha = math.atan(v[i] / p[SIGMA_Y])
        # pure slip
        g2 = camber * camber
        lam = mu[i]
        dfz = (fz - p[F_Z0]) / p[F_Z0] if p[F_Z0] > 0.0 else 0.0
        dx = lam * (p[P_DX1] + p[P_DX2] * dfz) * (1.0 - p[P_DX3] * g2) * fz
        bx = p[P_KX1] * fz / (p[P_CX1] * dx + EPS)
        fx0 = _magic(bx, p[P_CX1], dx, p[P_EX1], kappa)
        dy = lam * (p[P_DY1] + p[P_DY2] * dfz) * (1.0 - p[P_DY3] * g2) * fz
        if p[P_KY2] > 0.0:
            ky = p[P_KY1] * p[F_Z0] * math.sin(2.0 * math.atan(fz / (p[P_KY2] * p[F_Z0])))
        else:
            ky = p[P_KY1] * fz
        by = ky / (p[P_CY1] * dy + EPS)
        fy0 = _magic(by, p[P_CY1], dy, p[P_EY1], alpha)
        # combined slip
        bxa = p[R_BX1] * math.cos(math.atan(p[R_BX2] * kappa))
        byk = p[R_BY1] * math.cos(math.atan(p[R_BY2] * alpha))
        fx = fx0 * _weight(bxa, p[R_CX1], p[R_EX1], alpha)
        fy = fy0 * _weight(byk, p[R_CY1], p[R_EY1], kappa)
        # low-speed damping, then the friction limit
        patch_speed = math.sqrt(vx * vx + vy * vy)   # a wheel sliding sideways is not slow
        if patch_speed < p[V_LOW]:
            blend = 1.0 - patch_speed / p[V_LOW]
            fx -= blend * p[C_LOW_X] * vsx
            fy -= blend * p[C_LOW_Y] * vy
        limit = max(dx, dy)
        mag = math.sqrt(fx * fx + fy * fy)
        if mag > limit:
            fx *= limit / mag
            fy *= limit / mag
        fwx = fx * ex_x + fy * ey_x + fz * nx
        fwy = fx * ex_y + fy * ey_y + fz * ny
        fwz = fx * ex_z + fy * ey_z + fz * nz
        xfrc[wb, 0] = fwx
        xfrc[wb, 1] = fwy
        xfrc[wb, 2] = fwz
        xfrc[wb, 3] = re * (nz * fwy - ny * fwz)      # (-re n) x F: the force acts at the patch
        xfrc[wb, 4] = re * (nx * fwz - nz * fwx)
        xfrc[wb, 5] = re * (ny * fwx - nx * fwy)
        out[i, OUT_FZ] = fz
        out[i, OUT_KAPPA] = kappa
        out[i, OUT_ALPHA] = alpha
        out[i, OUT_FX] = fx
        out[i, OUT_FY] = fy
        out[i, OUT_CAMBER] = camber


@dataclass(frozen=True)
class Wheel:
    """Where one tyre's wheel lives in the compiled model, and what it is."""

    body: int                   # the spinning wheel
    upright: int                # its upright (carries the heading and the lean)
    spin_dof: int
    travel_qpos: int            # its suspension slide (> 0: bump)
    physics: VehiclePhysics
    static_load: float          # N
    camber_gain: float          # rad/m of bump travel about the forward axis (the axle's, signed for the side)


def wheel_parameters(physics: VehiclePhysics, corner_loads: Sequence[float], timestep: float,
                     camber_gain: float = 0.0) -> np.ndarray:
    """The parameter table rows of one car's four wheels (`corner_loads`: static load per wheel, N)."""
    t, mf = physics.tyres, physics.tyres.magic_formula
    rows = np.zeros((len(corner_loads), N_PARAMS))
    spin_mass = physics.wheel_inertia / physics.wheel_radius ** 2
    for k, load in enumerate(corner_loads):
        row = rows[k]
        row[R_ROLL] = physics.wheel_radius
        row[R_FREE] = physics.wheel_radius + load / t.vertical_stiffness
        row[K_Z], row[C_Z] = t.vertical_stiffness, t.vertical_damping
        row[SIGMA_X], row[SIGMA_Y] = t.relaxation_length_longitudinal, t.relaxation_length_lateral
        row[P_CX1], row[P_DX1], row[P_DX3], row[P_EX1], row[P_KX1] = mf.p_cx1, mf.p_dx1, mf.p_dx3, mf.p_ex1, mf.p_kx1
        row[P_CY1], row[P_DY1], row[P_DY3], row[P_EY1], row[P_KY1] = mf.p_cy1, mf.p_dy1, mf.p_dy3, mf.p_ey1, mf.p_ky1
        row[P_KY2] = mf.p_ky2 or 0.0
        row[P_DX2], row[P_DY2] = mf.p_dx2, mf.p_dy2
        row[CAMBER_GAIN] = camber_gain
        row[F_Z0] = t.nominal_load or 0.0
        row[R_BX1], row[R_BX2], row[R_CX1], row[R_EX1] = mf.r_bx1, mf.r_bx2, mf.r_cx1, mf.r_ex1
        row[R_BY1], row[R_BY2], row[R_CY1], row[R_EY1] = mf.r_by1, mf.r_by2, mf.r_cy1, mf.r_ey1
        row[V_LOW] = t.low_speed
        # low-speed damping: critical for the tyre's spring at standstill, capped so that one
        # explicit step cannot overshoot (the spin inertia at the patch, the corner's mass)
        corner_mass = load / GRAVITY
        k_x = mf.p_kx1 * load / t.relaxation_length_longitudinal
        k_y = abs(t.cornering_stiffness(load)) / t.relaxation_length_lateral
        row[C_LOW_X] = min(2.0 * math.sqrt(k_x * corner_mass), LOW_SPEED_DAMPING_SHARE * spin_mass / timestep)
        row[C_LOW_Y] = min(2.0 * math.sqrt(k_y * corner_mass), LOW_SPEED_DAMPING_SHARE * corner_mass / timestep)
    return rows


class SlipTyres:
    """The tyres of every car in one compiled world: parameters, transient state, forces.

    ``wheels`` in the order the backend's per-wheel arrays use; ``ground`` the terrain's grid and
    frame (`ground_at`; the default: the plane z = 0). ``mu`` scales each tyre's peak friction (the
    surface under it); `apply` computes and applies the forces for the current positions and
    velocities (call it between ``mj_step1`` and ``mj_step2``)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData,
                 wheels: Sequence[Wheel], ground: tuple[np.ndarray, np.ndarray] = (FLAT_GROUND, FLAT_FRAME)):
        self.model, self.data = model, data
        self.wheel = np.array([w.body for w in wheels], dtype=np.int64)
        self.upright = np.array([w.upright for w in wheels], dtype=np.int64)
        self.root = np.array([model.body_rootid[w.body] for w in wheels], dtype=np.int64)
        self.spin = np.array([w.spin_dof for w in wheels], dtype=np.int64)
        self.travel = np.array([w.travel_qpos for w in wheels], dtype=np.int64)
        self.params = np.vstack([wheel_parameters(w.physics, [w.static_load], model.opt.timestep, w.camber_gain)
                                 for w in wheels]) if wheels else np.zeros((0, N_PARAMS))
        self.mu = np.ones(len(wheels))
        self.u = np.zeros(len(wheels))
        self.v = np.zeros(len(wheels))
        self.out = np.zeros((len(wheels), 6))
        self._dt = float(model.opt.timestep)
        self._grid, self._frame = ground
        self.seconds = 0.0              # wall time spent in `apply`
        # views into MjData: its buffers never move, so they can be held
        self._views = (data.xipos, data.xmat, data.cvel, data.subtree_com, data.qpos, data.qvel, data.xfrc_applied)

    def reset(self) -> None:
        self.u[:] = 0.0
        self.v[:] = 0.0
        self.out[:] = 0.0

    def apply(self, settle: bool = False) -> None:
        """Compute and apply the forces; ``settle``: first set each tyre's deflections to the
        steady values of its present motion (for a car placed in motion, see `World.place`)."""
        start = time.perf_counter()
        xipos, xmat, cvel, com, qpos, qvel, xfrc = self._views
        tyre_forces(xipos, xmat, cvel, com, qpos, qvel, xfrc, self.wheel, self.upright, self.root, self.spin,
                    self.travel, self.params, self.mu, self.u, self.v, self._dt, settle, self.out, self._grid,
                    self._frame)
        self.seconds += time.perf_counter() - start

    def settle(self, wheels: slice) -> None:
        """Set the deflections of the ``wheels`` (a car's four) to the steady values of their present
        motion and apply their forces; the other tyres keep their state (a car entering the world)."""
        xipos, xmat, cvel, com, qpos, qvel, xfrc = self._views
        tyre_forces(xipos, xmat, cvel, com, qpos, qvel, xfrc, self.wheel[wheels], self.upright[wheels],
                    self.root[wheels], self.spin[wheels], self.travel[wheels], self.params[wheels], self.mu[wheels],
                    self.u[wheels], self.v[wheels], self._dt, True, self.out[wheels], self._grid, self._frame)

    # --- what the tyres do now, per wheel (for monitors, tests and benchmarks) -----------------
    @property
    def load(self) -> np.ndarray:
        return self.out[:, OUT_FZ]

    @property
    def slip_angle(self) -> np.ndarray:
        return self.out[:, OUT_ALPHA]
