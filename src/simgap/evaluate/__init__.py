"""Evaluation: every metric of a run, computed from its history (`run_evaluation.evaluate`) —
outcomes, the closest approach, tracking, criticality, and scores in the field's terms (CommonRoad
solutions, their validity and cost; a closed-loop score built like nuPlan's) — and the comparison
of two runs across fidelities (`compare`). What a run is evaluated by is its own model,
`EvaluationSettings` (the cost function, the score's thresholds and weights)."""

from simgap.evaluate.settings import EvaluationSettings

__all__ = ["EvaluationSettings"]
