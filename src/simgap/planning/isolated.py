"""Host one of simgap's Python planner classes behind the planner protocol, in a process of its own.

``python -m simgap.planning.isolated REF`` (REF: a planner name or reference of the registry) is
what ``--isolate`` starts per agent: the planner is built from the same `PlannerSetup` and settings
model as in simgap's own process, and asked with the same `State` and `World`, rebuilt from the
protocol's messages (the lanelet network and planning problem from their CommonRoad XML, written
at 1e-8 m as every scenario file is, so a scenario read from a file reaches the planner unchanged).
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

from simgap.planning.protocol import Planner, PlannerSetup, TrafficParticipant, World
from simgap.trajectory import STATE_FIELDS, State, Trajectory


def main(argv: list[str] | None = None) -> None:
    from simgap_planner import Adapter, serve
    from simgap_planner.messages import trajectory_columns

    from simgap.planning.registry import load_planner
    from simgap.scenario.files import load_scenario
    from simgap.vehicles.catalogue import Vehicle

    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        raise SystemExit("usage: python -m simgap.planning.isolated PLANNER_REF")
    planner_class = load_planner(argv[0])

    class SimgapAdapter(Adapter):
        def setup(self, message) -> PlannerSetup:
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "setup.xml"
                path.write_text(message.commonroad_xml)
                scenario, problems = load_scenario(path)
            return PlannerSetup(message.agent_id, Vehicle.model_validate_json(message.vehicle.json),
                                scenario.lanelet_network, problems.planning_problem_dict[message.agent_id],
                                message.dt, json.loads(message.settings_json or "{}"))

        def observed(self, message) -> State:
            return State(*(getattr(message, name) for name in STATE_FIELDS))

        def world(self, message, dt: float, setup: PlannerSetup) -> World:
            traffic = tuple(TrafficParticipant(p.id, p.length, p.width,
                                               Trajectory(p.prediction.dt, **trajectory_columns(p.prediction)))
                            for p in message.traffic)
            return World(setup.lanelet_network, setup.planning_problem.goal, dt, traffic)

    def factory(setup: PlannerSetup) -> Planner:
        return planner_class.build(setup, planner_class.settings(setup.settings))

    serve(factory, name=planner_class.ref, adapter=SimgapAdapter())


if __name__ == "__main__":
    main()
