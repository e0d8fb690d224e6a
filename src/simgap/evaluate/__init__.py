"""Evaluation: alignment of trajectories across fidelities, error metrics, outcomes, criticality."""
