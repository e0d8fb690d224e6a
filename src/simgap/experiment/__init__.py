"""Experiments: one run wired end to end, and (later) batches, samplers, search and the results store."""
