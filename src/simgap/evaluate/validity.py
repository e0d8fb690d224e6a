"""Whether a run's solution is valid, as the slow part of scoring is done: each verdict cached by the
hash of what was checked, and the check itself run in a process of its own.

The cache (`SolutionCheckCache`): a run that drives the same trajectory again — a rerun, a repeated
ideal run — is not checked twice.

The process (`CheckerProcess`): the drivability checker's compiled parts can crash the interpreter —
the ``triangle`` library, which commonroad-drivability-checker 2025.3.1 uses to triangulate a road's
boundary, dies of a segmentation fault on some roads (of the paper's 78 curves, seven: r = 10 m at
±150° and 60°, r = 20 m and 30 m at ±120°). In a process of its own a crash costs the run its verdict
(``solution_valid`` None, the reason naming the check it crashed in), not the run, the worker or the
experiment. One process serves every check of its parent: started at the first, again after a
crash, gone when the parent is. It is a fork of its parent, which has imported by then nearly all
the checker needs (commonroad-io, scipy, matplotlib, commonroad_dc's collision checker): a new
interpreter would import them again, about 2 s of a single `simgap run`'s 7–9 s. The fork keeps
none of its parent's files open but its two pipes (its output goes to /dev/null, off the parent's
stdout, which ``simgap run --json`` prints on), never runs its parent's exit handlers, and is sent
the scenario file and the solution XML; it answers with each check as it starts, each agent's
verdict, and the end.
"""

from __future__ import annotations

import atexit
import gc
import hashlib
import importlib.metadata
import json
import os
import signal
import tempfile
from dataclasses import asdict
from multiprocessing.connection import Connection
from pathlib import Path
from typing import ClassVar, NoReturn

import numpy as np
from commonroad.common.solution import CommonRoadSolutionReader, Solution
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.scenario.scenario import Scenario

from simgap.evaluate.solution import solution_xml
from simgap.evaluate.solution_check import SolutionCheck, check_agent
from simgap.files import atomic_write_text
from simgap.scenario import load_scenario
from simgap.scenario.files import write_xml


# ----------------------------------------------------------------------- the cache
def default_cache_dir() -> Path:
    """Where verdicts are cached: ``$SIMGAP_CACHE_DIR``, else ``$XDG_CACHE_HOME/simgap``, else
    ``~/.cache/simgap`` (each under ``solution-checks/``)."""
    root = os.environ.get("SIMGAP_CACHE_DIR") or \
        os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "simgap")
    return Path(root) / "solution-checks"


class SolutionCheckCache:
    """Verdicts by the hash of what was checked: the drivability checker's version, the scenario
    file (road, obstacles, planning problems) and every agent's solution (model, type, states)."""

    def __init__(self, folder: Path | None = None):
        self.folder = Path(folder) if folder is not None else default_cache_dir()

    @staticmethod
    def key(solution: Solution, scenario_file: str | Path) -> str:
        h = hashlib.sha256()
        h.update(importlib.metadata.version("commonroad-drivability-checker").encode())
        h.update(Path(scenario_file).read_bytes())
        for pps in sorted(solution.planning_problem_solutions, key=lambda p: p.planning_problem_id):
            h.update(f"{pps.planning_problem_id}:{pps.vehicle_model.name}:{pps.vehicle_type.value}".encode())
            states = pps.trajectory.state_list
            h.update(np.array([[s.time_step, *s.position, s.steering_angle, s.velocity, s.orientation]
                               for s in states], dtype="<f8").tobytes())
        return h.hexdigest()

    def _path(self, key: str) -> Path:
        return self.folder / key[:2] / f"{key}.json"

    def get(self, key: str) -> dict[int, SolutionCheck] | None:
        try:
            raw = json.loads(self._path(key).read_text())
        except (OSError, ValueError):
            return None
        return {int(aid): SolutionCheck(**v) for aid, v in raw.items()}

    def put(self, key: str, checks: dict[int, SolutionCheck]) -> None:
        path = self._path(key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_text(path, json.dumps({str(aid): asdict(c) for aid, c in checks.items()}))
        except OSError:       # a read-only or full cache only costs the next run its check
            pass


# ----------------------------------------------------------------------- the process
class CheckerProcess:
    """A process that checks the solutions it is sent (`simgap.evaluate.solution_check`)."""

    _shared: ClassVar[CheckerProcess | None] = None

    def __init__(self) -> None:
        self._pid: int | None = None
        self._status: int | None = None      # its wait status, once reaped
        self._send: Connection | None = None
        self._receive: Connection | None = None

    @classmethod
    def shared(cls) -> CheckerProcess:
        if cls._shared is None:
            cls._shared = cls()
            atexit.register(cls._shared._stop)      # none left behind when simgap ends
        return cls._shared

    def _start(self) -> None:
        child_reads, parent_writes = os.pipe()
        parent_reads, child_writes = os.pipe()
        pid = os.fork()
        if pid == 0:
            _serve_forked(child_reads, child_writes)
        os.close(child_reads)
        os.close(child_writes)
        self._pid, self._status = pid, None
        self._send = Connection(parent_writes, readable=False)
        self._receive = Connection(parent_reads, writable=False)

    def _running(self) -> bool:
        if self._pid is None or self._status is not None:
            return False
        pid, status = os.waitpid(self._pid, os.WNOHANG)
        if pid:
            self._status = status
        return not pid

    def _wait(self) -> int:
        """Its exit code, as `subprocess` gives one (-N: ended by signal N)."""
        if self._status is None:
            assert self._pid is not None, "_start() comes first"
            self._status = os.waitpid(self._pid, 0)[1]
        return os.waitstatus_to_exitcode(self._status)

    def _stop(self) -> None:
        for conn in (self._send, self._receive):
            if conn is not None:
                conn.close()
        if self._pid is not None:
            if self._running():
                os.kill(self._pid, signal.SIGKILL)
            self._wait()
        self._pid = self._status = self._send = self._receive = None

    def check(self, scenario_file: str | Path, solution_xml: str, agent_ids: list[int]) -> dict[int, SolutionCheck]:
        """Each agent's verdict (None, with the reason, for those the process did not live to give)."""
        if not self._running():
            self._stop()
            self._start()
        assert self._send is not None and self._receive is not None, "_start() opened them"
        verdicts: dict[int, SolutionCheck] = {}
        stage = "starting"
        try:
            self._send.send((str(scenario_file), solution_xml))
            while True:
                kind, *payload = self._receive.recv()
                if kind == "stage":
                    stage = payload[0]
                elif kind == "agent":
                    verdicts[payload[0]] = SolutionCheck(payload[1], payload[2])
                elif kind == "error":
                    return verdicts | {aid: SolutionCheck(None, payload[0]) for aid in agent_ids if aid not in verdicts}
                else:
                    return verdicts
        except (EOFError, OSError):
            code = self._wait()
            self._stop()
            how = f"signal {-code}" if code < 0 else f"exit status {code}"
            reason = f"the drivability checker crashed ({how}) in {stage}"
            return verdicts | {aid: SolutionCheck(None, reason) for aid in agent_ids if aid not in verdicts}


def _serve_forked(receive_fd: int, send_fd: int) -> NoReturn:
    """The forked process: its parent's signals back to their defaults, every file but its two
    pipes closed (standard input and output on /dev/null), its parent's objects never collected
    (their finalisers would act on files it no longer has), `serve`, then out without its parent's
    exit handlers."""
    status = 1
    try:
        for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            signal.signal(signum, signal.SIG_DFL)
        gc.freeze()
        devnull = os.open(os.devnull, os.O_RDWR)
        for fd in (0, 1, 2):
            os.dup2(devnull, fd)
        low, high = sorted((receive_fd, send_fd))
        os.closerange(3, low)
        os.closerange(low + 1, high)
        os.closerange(high + 1, os.sysconf("SC_OPEN_MAX"))
        serve(Connection(receive_fd), Connection(send_fd))
        status = 0
    finally:
        os._exit(status)


def checked_solution(solution: Solution, scenario: Scenario, problems: PlanningProblemSet,
                     scenario_file: str | Path | None, cache: SolutionCheckCache | None) -> tuple[dict[int, SolutionCheck], bool]:
    """The verdicts on ``solution`` and whether they came from ``cache`` (checked in the shared
    `CheckerProcess`; a scenario without a file is written to a temporary one for it)."""
    file = scenario_file if scenario_file is not None and Path(scenario_file).is_file() else None
    key = SolutionCheckCache.key(solution, file) if cache is not None and file is not None else None
    agents = [p.planning_problem_id for p in solution.planning_problem_solutions]
    if cache is not None and key is not None:
        known = cache.get(key)
        if known is not None and set(known) == set(agents):
            return known, True
    with tempfile.TemporaryDirectory() as folder:
        if file is None:
            file = Path(folder) / "scenario.xml"
            write_xml(scenario, problems, file)
        checks = CheckerProcess.shared().check(file, solution_xml(solution), agents)
    if cache is not None and key is not None and all(c.valid is not None for c in checks.values()):
        cache.put(key, checks)
    return checks, False


SCENARIOS_KEPT = 8     # scenario files the checker process keeps parsed (a study runs each several times)


def serve(receive: Connection, send: Connection) -> None:
    """The process's loop: check what arrives until the parent closes the pipe. The last
    `SCENARIOS_KEPT` scenario files read stay parsed (by path, size and modification time), so
    that the runs on one scenario share it and its road boundary (`solution_check`)."""
    parsed: dict[tuple[str, int, int], tuple] = {}
    while True:
        try:
            scenario_file, solution_xml = receive.recv()
        except EOFError:
            return
        try:
            stat = Path(scenario_file).stat()
            key = (str(scenario_file), stat.st_size, stat.st_mtime_ns)
            if key not in parsed:
                parsed[key] = load_scenario(scenario_file)
                while len(parsed) > SCENARIOS_KEPT:
                    parsed.pop(next(iter(parsed)))
            scenario, problems = parsed[key]
            solution = CommonRoadSolutionReader.fromstring(solution_xml)
        except Exception as exc:      # a file it cannot read: no verdict, with the reason
            send.send(("error", f"the drivability checker could not read the run: {exc}"))
            continue
        for pps in solution.planning_problem_solutions:         # each verdict sent as soon as it is known
            check = check_agent(pps, solution, scenario, problems, lambda stage: send.send(("stage", stage)))
            send.send(("agent", pps.planning_problem_id, check.valid, check.reason))
        send.send(("done",))
