"""A run that a test simulated, evaluated and recorded as `simgap run` records it (without the
slow criticality), for tests that drive `simulate` themselves."""

from __future__ import annotations

from simgap.cosim import CosimSettings, History
from simgap.evaluate import EvaluationSettings
from simgap.evaluate.run_evaluation import EvaluationContext, evaluate
from simgap.record import PlannerRecord, RunRecord, RunSettings
from simgap.sim.settings import DRY_ROAD_FRICTION
from simgap.vehicles import load_vehicle


def recorded(history: History, scenario, problems, cosim: CosimSettings | None = None) -> RunRecord:
    cosim = cosim or CosimSettings()
    context = EvaluationContext(scenario, problems, EvaluationSettings(), cosim.offroad_tolerance, cosim.planning_budget_s,
                                DRY_ROAD_FRICTION, load_vehicle("sedan"))
    return RunRecord(history, evaluate(history, context),
                     RunSettings(history.scenario_id, cosim, PlannerRecord("test")))
