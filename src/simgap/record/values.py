"""Records' values compared as a change that must not change behaviour compares them
(`bench/records/`): as plain data (`plain`: mappings, dataclasses and sequences to dicts and lists)
and equal to a relative 1e-9, NaN equal to NaN (`same`)."""

from __future__ import annotations

import math
from typing import Any


def plain(value: Any) -> Any:
    """``value`` as plain data: dataclasses and mappings as dicts, tuples as lists."""
    if hasattr(value, "__dataclass_fields__"):
        return {f: plain(getattr(value, f)) for f in value.__dataclass_fields__}
    if hasattr(value, "items"):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


def same(a: Any, b: Any, rel: float = 1e-9) -> bool:
    """Equal as plain data, floats to a relative ``rel`` (and 1e-12 absolute), NaN equal to NaN."""
    a, b = plain(a), plain(b)
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=rel, abs_tol=1e-12)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k], rel) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y, rel) for x, y in zip(a, b))
    return a == b
