"""Evaluation: alignment of trajectories across fidelities, error metrics, outcomes, criticality,
and scores in the field's terms (CommonRoad solutions, their validity and cost; a closed-loop score
built like nuPlan's)."""
