"""The fork server's warm-up, run by importing this module (the last of its preloads: an import is
the one thing multiprocessing lets a fork server do before it forks): what every worker would
otherwise do on its first MuJoCo world, done once here — the tyre kernel loaded from numba's
on-disk cache (about 0.4 s of CPU, most of a first world's extra time). A process that imports
this module pays that once itself; nothing else imports it."""

from simgap.sim.mujoco.plant import compile_tyres

compile_tyres()
