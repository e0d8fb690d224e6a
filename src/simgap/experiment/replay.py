"""A recorded run, run again from its record alone, and whether it reproduced.

A run directory holds everything a run needs: the scenario it drove (``driven.xml``: the original
scenario, planning problems and traffic, with the agents added as obstacles offset by
`AGENT_ID_OFFSET`, and ``driven.json``, its sidecar with the road's relief), the vehicles its
agents drove (their models in full), the planners and their settings, the loop's and the
backend's settings and the seed (``run.json``). With ``measured`` latency the plans' latencies
are the record's, not this machine's, so a run made on a loaded machine replays exactly on an
idle one. It reproduced when the replay's fingerprint (`History.fingerprint`, the same on any
CPU) is the record's.

What a record cannot bring back: a planner file or program that is gone or changed, a planner in
its own process that keeps state of its own, and ``tcp://`` planners (they run elsewhere).
"""

from __future__ import annotations

import shlex
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from simgap.cosim.history import AGENT_ID_OFFSET
from simgap.cosim.loop import MEASURED
from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute
from simgap.planning.registry import PlannerAssignment, PlannerChoice
from simgap.record import PlannerRecord, RunRecord, read_run
from simgap.scenario import load_scenario
from simgap.scenario.files import scenario_xml
from simgap.sim.protocol import Realism
from simgap.trajectory import STATE_FIELDS

DRIVEN_SCENARIO = "driven.xml"


@dataclass(frozen=True)
class Replay:
    """A run (``original``, from ``run_dir``) and its replay."""

    run_dir: Path
    original: RunRecord
    replayed: RunRecord

    @property
    def reproduced(self) -> bool:
        return self.replayed.fingerprint == self.original.fingerprint

    def largest_difference(self) -> tuple[str, float, float] | None:
        """Where the replay drove differently: (state field, the largest difference, the first time
        it exceeds 1e-6), over the agents both drove the same number of steps; None where they
        drove alike."""
        worst = None
        for a in self.original.history.agents:
            b = self.replayed.history.agent(a.id)
            n = min(len(a.driven), len(b.driven))
            for f in STATE_FIELDS:
                diff = np.abs(getattr(a.driven, f)[:n] - getattr(b.driven, f)[:n])
                if n and float(diff.max()) > 1e-6 and (worst is None or float(diff.max()) > worst[1]):
                    worst = (f, float(diff.max()), float(a.driven.t[int(np.argmax(diff > 1e-6))]))
        return worst


def reproduce_command(run_dir: str | Path) -> str:
    """The command that runs a recorded run again and says whether it reproduced (its folder
    relative to the working folder where it lies below it, else absolute)."""
    folder = Path(run_dir).resolve()
    try:
        folder = folder.relative_to(Path.cwd())
    except ValueError:
        pass
    return f"simgap replay {shlex.quote(str(folder))}"


def replay(run_dir: str | Path, out: Path | None = None) -> Replay:
    """Run the run of ``run_dir`` again from its record (into ``out`` when given)."""
    run_dir = Path(run_dir)
    original = read_run(run_dir)
    with tempfile.TemporaryDirectory(prefix="simgap-replay-") as scratch:
        scenario = recorded_scenario(run_dir, original, Path(scratch))
        replayed = execute(replay_request(original, scenario), out)
    return Replay(run_dir, original, replayed)


def replay_request(record: RunRecord, scenario: Path) -> RunRequest:
    """The request that runs ``record``'s run again on ``scenario``: its vehicles, planners,
    settings and seed, and its plan latencies where they were measured."""
    s, h = record.settings, record.history
    latencies = {a.id: tuple(a.plan_latency_s) for a in h.agents} \
        if s.cosim.latency == MEASURED and h.realism is Realism.REAL else None
    return RunRequest(scenario=scenario, backend=h.backend, vehicles={a.id: a.vehicle for a in h.agents},
                      planner_vehicle=s.planner_vehicle or h.agents[0].vehicle.name, backend_settings=s.backend,
                      planner=_planners(s.planner, [a.id for a in h.agents]), cosim=s.cosim, evaluation=s.evaluation,
                      seed=s.seed,
                      validate=record.evaluation.solution_check is not None, replayed_latencies=latencies,
                      criticality=bool(record.evaluation.criticality))


def _planners(planner: PlannerRecord, agent_ids: list[int]) -> PlannerAssignment:
    if not planner.agents:
        return _choice(planner)
    return {aid: _choice(planner.of_agent(aid)) for aid in agent_ids}


def _choice(planner: PlannerRecord) -> PlannerChoice:
    if planner.planner.startswith("tcp://"):
        raise InputError(f"the run's planner ran elsewhere ({planner.planner}); a replay starts its planners itself",
                         field="settings.planner", allowed="planners simgap loads or starts (names, files, exec:)")
    choice = PlannerChoice(planner=planner.planner or planner.name, settings=dict(planner.settings),
                           label=planner.name)
    choice.load(field="settings.planner")
    return choice


def recorded_scenario(run_dir: Path, record: RunRecord, scratch: Path) -> Path:
    """The scenario the run drove, as its record keeps it (``driven.xml`` without the agents),
    written to ``scratch`` with its sidecar."""
    driven = run_dir / DRIVEN_SCENARIO
    if not driven.is_file():
        raise InputError("the run directory keeps no driven scenario", file=driven,
                         allowed="a run directory simgap wrote with its driven.xml")
    scenario, problems = load_scenario(driven)
    for obstacle in list(scenario.dynamic_obstacles):
        if obstacle.obstacle_id >= AGENT_ID_OFFSET:
            scenario.remove_obstacle(obstacle)
    target = scratch / f"{record.scenario_id}.xml"
    target.write_text(scenario_xml(scenario, problems))
    sidecar = driven.with_suffix(".json")
    if sidecar.is_file():
        target.with_suffix(".json").write_bytes(sidecar.read_bytes())
    return target
