"""The fork server's warm-up, run by importing this module (the last of its preloads: an import is
the one thing multiprocessing lets a fork server do before it forks): what every worker would
otherwise do on its first MuJoCo world, done once here — the tyre kernel loaded from numba's
on-disk cache (about 0.4 s of CPU, most of a first world's extra time). A process that imports
this module pays that once itself; nothing else imports it."""

import warnings

from simgap.sim.mujoco.plant import compile_tyres

try:
    compile_tyres()
except Exception as exc:  # noqa: BLE001 - a fork server that dies takes every worker of every batch with it
    warnings.warn(f"the fork server could not load MuJoCo's tyre kernel ({type(exc).__name__}: {exc}); "
                  "each worker loads it on its first MuJoCo world", RuntimeWarning, stacklevel=1)
