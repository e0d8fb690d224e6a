"""The fork server a batch's worker processes are forked from: a process that has imported what a
run imports (seconds of CPU: the planners, MuJoCo, the route planner, the ride-comfort filter, the
solution's cost and feasibility) and loaded MuJoCo's tyre kernel (`warm_up`), and nothing else, so
that each worker starts with them loaded instead of loading them again. Never a fork of the driver itself: a fork of a process whose
threads have run (GNU OpenMP's, frenetix's) can deadlock."""

from __future__ import annotations

import multiprocessing as mp
from multiprocessing import forkserver
from multiprocessing.context import BaseContext

#: what a run imports, some of it only on its first call, loaded once by the fork server
RUN_IMPORTS = ("simgap.experiment.worker", "simgap.experiment.attribution", "simgap.planning.frenet",
               "simgap.sim.dynamic.backend", "simgap.sim.mujoco.backend", "simgap.evaluate.run_evaluation",
               "commonroad_route_planner.reference_path_planner", "commonroad_route_planner.route_planner",
               "commonroad_dc.costs.evaluation", "commonroad_dc.feasibility.solution_checker",
               "commonroad_dc.feasibility.feasibility_checker", "scipy.signal",
               "simgap.experiment.warm_up")      # last: the warm-up, once the rest is loaded


def start() -> None:
    """Start the fork server (if it is not running) to load `RUN_IMPORTS` while the caller goes on."""
    forkserver.set_forkserver_preload(list(RUN_IMPORTS))
    forkserver.ensure_running()


def context() -> BaseContext:
    """The multiprocessing context whose processes are forked from the fork server."""
    start()
    return mp.get_context("forkserver")
