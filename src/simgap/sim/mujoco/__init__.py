"""The 3D physics backend on MuJoCo: the world (`world`), the road in it (`road`), the cars
(`car`) and the backend that drives them with tracking controllers (`backend`)."""

__all__ = ["MujocoBackend"]


def __getattr__(name: str):
    """``MujocoBackend`` is imported on first use: the settings (`simgap.sim.mujoco.settings`)
    load without MuJoCo."""
    if name == "MujocoBackend":
        from simgap.sim.mujoco.backend import MujocoBackend

        return MujocoBackend
    raise AttributeError(f"module 'simgap.sim.mujoco' has no attribute {name!r}")
