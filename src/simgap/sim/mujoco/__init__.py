"""The 3D physics backend on MuJoCo: the world (`world`), the road in it (`road`), the cars
(`car`) and the backend that drives them with tracking controllers (`backend`)."""

from simgap.sim.mujoco.backend import MujocoBackend

__all__ = ["MujocoBackend"]
