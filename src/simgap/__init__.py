"""simgap: validate motion planners across simulation fidelities."""

import os

# MuJoCo renders offscreen on the CPU through EGL unless the user chose otherwise; this must be
# set before mujoco is first imported, wherever that happens.
os.environ.setdefault("MUJOCO_GL", "egl")

__version__ = "0.1.0"
