"""Samplers of a logical scenario's parameter space: the full grid, or seeded random, Latin
hypercube and Sobol samples (scipy's quasi-Monte Carlo engines) over each parameter's range.

A parameter the spec gives `values` for is sampled from those values (uniformly, by index); one
with `min`/`max` (or neither: the logical scenario's own range) from that interval. Integer
parameters are rounded. The same spec and seed give the same samples, in the same order.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
from scipy.stats import qmc

from simgap.scenario.logical import LogicalScenario


def _grid_span(spec, logical: LogicalScenario, name: str) -> list[Any]:
    par = logical.parameters[name]
    rng = spec.parameters.get(name)
    if rng is not None and rng.values is not None:
        return [par.coerce(v) for v in rng.values]
    if rng is not None and (rng.min is not None or rng.max is not None):
        lo = rng.min if rng.min is not None else par.min
        hi = rng.max if rng.max is not None else par.max
        return [par.coerce(v) for v in par.span() if lo <= v <= hi] or [par.coerce(lo)]
    return [par.coerce(v) for v in par.span()]


def _unit_samples(kind: str, n: int, dims: int, seed: int) -> np.ndarray:
    if dims == 0:
        return np.zeros((n, 0))
    if kind == "random":
        return np.random.default_rng(seed).random((n, dims))
    if kind == "lhs":
        return qmc.LatinHypercube(d=dims, seed=seed).random(n)
    engine = qmc.Sobol(d=dims, scramble=True, seed=seed)
    return engine.random(n)


def grid_size(spec, logical: LogicalScenario) -> int:
    """How many parameter sets the full grid of ``spec`` holds, without making them."""
    return math.prod(len(_grid_span(spec, logical, n)) for n in logical.parameters)


def sample(spec, logical: LogicalScenario) -> list[dict[str, Any]]:
    """The concrete parameter sets of ``spec`` (duplicates removed, order kept)."""
    names = list(logical.parameters)
    if spec.sampler.kind == "grid":
        spans = [_grid_span(spec, logical, n) for n in names]
        combos = [dict(zip(names, c)) for c in itertools.product(*spans)]
    else:
        varying, fixed = [], {}
        for n in names:
            par, rng = logical.parameters[n], spec.parameters.get(n)
            if rng is None and len(par.span()) <= 1 and par.grid is None and par.values is None:
                fixed[n] = par.coerce(par.default)       # not part of the explored space
            else:
                varying.append(n)
        u = _unit_samples(spec.sampler.kind, spec.sampler.samples, len(varying), spec.sampler.seed)
        combos = []
        for row in u:
            params = dict(fixed)
            for x, n in zip(row, varying):
                par, rng = logical.parameters[n], spec.parameters.get(n)
                if rng is not None and rng.values is not None:
                    params[n] = par.coerce(rng.values[min(int(x * len(rng.values)), len(rng.values) - 1)])
                else:
                    lo = rng.min if rng is not None and rng.min is not None else par.min
                    hi = rng.max if rng is not None and rng.max is not None else par.max
                    params[n] = par.coerce(round(lo + x * (hi - lo), 6))
            combos.append({n: params[n] for n in names})
    unique, seen = [], set()
    for c in combos:
        key = tuple(c[n] for n in names)
        if key not in seen:
            seen.add(key)
            unique.append(c)
    return unique
