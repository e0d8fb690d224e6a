"""Connecting to a Ray cluster, and checking before any run starts that its nodes can run ours.

An address is ``HOST:PORT`` or ``auto`` (from a node of the cluster: the driver joins it) or
``ray://HOST:PORT`` (Ray Client, from outside the cluster: the driver talks to the head's client
server); no address starts a local cluster. Whatever stands in the way — nothing answers, Ray or
Python differ between driver and cluster, a node cannot import simgap or has other versions of
the packages a run depends on — is an `InputError` that names the address and what to do.

Each node with a CPU runs one probe task that reports its software; the probe is shipped by
value, so it runs (and reports) on a node that cannot import simgap.
"""

from __future__ import annotations

import importlib.util
import os
import re
import socket
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from simgap.errors import InputError

ADDRESS_FORMS = "HOST:PORT or auto from a node of the cluster, ray://HOST:PORT (Ray Client) from outside it"
ADDRESS_HELP = f"Ray cluster, with --executor ray: {ADDRESS_FORMS}; none starts a local one"
INSTALL = "install the driver's versions on every node (pip install -r requirements.lock, then simgap)"
PROBE_TIMEOUT_S = 120.0

_session: str | None = None     # the cluster this process connected to ("local" or its address)


@dataclass(frozen=True)
class NodeSoftware:
    """What a node (or the driver) runs: Python and Ray, and the packages a run's result depends on."""

    node: str
    python: str                                     # major.minor
    ray: str
    packages: dict[str, str] = field(default_factory=dict)
    import_error: str | None = None                 # why simgap cannot be imported there, if it cannot
    source: str = ""                                # digest of simgap's Python files there


def _make_probe() -> Callable[[], dict[str, Any]]:
    # A function defined in a function is pickled by value: a worker runs it without importing simgap.
    def probe() -> dict[str, Any]:
        import hashlib
        import importlib
        import platform
        from pathlib import Path

        import ray

        digest, versions = hashlib.sha256(), {}
        try:
            versions = importlib.import_module("simgap.experiment.single_run").software_versions()
            error = None
            package = Path(importlib.import_module("simgap").__path__[0])
            for path in sorted(package.rglob("*.py")):
                digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
        except Exception as exc:            # noqa: BLE001 - reported, whatever it is
            error = f"{type(exc).__name__}: {exc}"
        node = ray.util.get_node_ip_address() if ray.is_initialized() else platform.node()
        return {"node": node, "python": ".".join(platform.python_version_tuple()[:2]), "ray": ray.__version__,
                "packages": versions, "import_error": error, "source": digest.hexdigest()[:16]}

    return probe


def driver_software() -> NodeSoftware:
    return NodeSoftware(**(_make_probe()() | {"node": "this driver"}))


def _error(address: str, problem: str, todo: str) -> InputError:
    return InputError(f"Ray cluster at {address}: {problem}; {todo}", field="address")


def endpoint(address: str) -> tuple[str, int] | None:
    """(host, port) of ``HOST:PORT`` or ``ray://HOST:PORT``; None for ``auto``."""
    if address == "auto":
        return None
    host, sep, port = address.removeprefix("ray://").rpartition(":")
    if not sep or not host or not port.isdigit():
        raise InputError(f"'{address}' is not a Ray cluster address", field="address", allowed=ADDRESS_FORMS)
    return host, int(port)


def _check_reachable(address: str) -> None:
    where = endpoint(address)
    if where is None:
        return
    try:
        socket.create_connection(where, timeout=5.0).close()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        todo = ("start its head with 'ray start --head' (it prints the address), or fix --address"
                if not address.startswith("ray://") else
                "start its head with 'ray start --head' (Ray Client listens on port 10001), or fix --address")
        raise _error(address, f"nothing answers ({reason})", todo) from None


def _init(address: str) -> None:
    import ray

    kwargs: dict[str, Any] = {"address": address, "log_to_driver": False, "configure_logging": False}
    for attempt in (1, 2):
        try:
            ray.init(**kwargs)
            return
        except ConnectionAbortedError:
            # Ray 2.48's client server sometimes loses the session it forks for a new client
            # (ray-project/ray#63202); a second connection gets a fresh one.
            if attempt == 2 or not address.startswith("ray://"):
                raise


def connection_error(address: str, exc: Exception) -> InputError:
    """The one line for what ``ray.init(address)`` raised."""
    text = " ".join(str(exc).split())
    cluster = re.search(r"Version mismatch: The cluster was started with: Ray: (\S+) Python: (\S+)", text)
    if cluster:
        mine = driver_software()
        return _error(address, f"it runs Ray {cluster[1]} on Python {cluster[2]}, this driver Ray {mine.ray} on "
                               f"Python {mine.python}", INSTALL)
    return _error(address, f"cannot connect ({type(exc).__name__}: {text[:200]})",
                  "check that the address is the one 'ray start --head' printed")


def check_nodes(address: str, nodes: list[NodeSoftware], driver: NodeSoftware) -> None:
    """An InputError for the first node that cannot run this driver's runs as the driver would."""
    for n in nodes:
        if (n.ray, n.python) != (driver.ray, driver.python):
            raise _error(address, f"node {n.node} runs Ray {n.ray} on Python {n.python}, this driver Ray "
                                  f"{driver.ray} on Python {driver.python}", INSTALL)
        if n.import_error:
            raise _error(address, f"node {n.node} cannot import simgap ({n.import_error})",
                         "install simgap and requirements.lock on every node")
        if n.source != driver.source:
            raise _error(address, f"node {n.node} has other simgap code than this driver (its Python files "
                                  "differ)", "install the driver's simgap on every node")
        for name, version in driver.packages.items():
            if n.packages.get(name) != version:
                raise _error(address, f"node {n.node} has {name} {n.packages.get(name, '(none)')} where this "
                                      f"driver has {version}, so its runs would not match", INSTALL)


def probe_nodes(address: str) -> list[NodeSoftware]:
    """The software of every live node of the connected cluster that has a CPU."""
    import ray
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    nodes = [n for n in ray.nodes() if n.get("Alive") and n.get("Resources", {}).get("CPU", 0) > 0]
    if not nodes:
        raise _error(address, "no live node has a CPU", "start a worker with 'ray start --address HEAD:PORT'")
    probe = ray.remote(num_cpus=0, max_retries=0)(_make_probe())
    refs = [probe.options(scheduling_strategy=NodeAffinitySchedulingStrategy(n["NodeID"], soft=False))
            .remote() for n in nodes]
    try:
        reports = ray.get(refs, timeout=PROBE_TIMEOUT_S)
    except ray.exceptions.GetTimeoutError:
        raise _error(address, f"its nodes did not run a probe task within {PROBE_TIMEOUT_S:g} s",
                     "check 'ray status' on the head") from None
    except Exception as exc:                 # noqa: BLE001 - a node that cannot start a worker at all
        raise _error(address, f"a probe task failed ({type(exc).__name__}: {str(exc).splitlines()[0][:200]})",
                     "check the nodes' Ray logs (/tmp/ray/session_latest/logs)") from None
    return [NodeSoftware(**r) for r in reports]


def connect(address: str | None, workers: int | None) -> bool:
    """Connect this process to the cluster at ``address`` (a new local one for None) and check its
    nodes. Returns False if the caller had initialised Ray itself (its connection is used as is)."""
    global _session
    import ray

    target = address or "local"
    if ray.is_initialized():
        if _session is None:
            return False
        if _session == target:
            return True
        disconnect()
    if address is None:
        ray.init(num_cpus=workers or os.cpu_count() or 1, include_dashboard=False, log_to_driver=False, configure_logging=False)
        _session = target
        return True
    if address.startswith("ray://") and importlib.util.find_spec("grpc") is None:
        raise _error(address, "Ray Client needs the package ray[client]",
                     f"pip install 'ray[client]=={ray.__version__}'")
    _check_reachable(address)
    try:
        _init(address)
    except Exception as exc:                 # noqa: BLE001 - whatever Ray raises, one line for the user
        raise connection_error(address, exc) from None
    _session = target
    try:
        check_nodes(address, probe_nodes(address), driver_software())
    except BaseException:
        disconnect()
        raise
    return True


def disconnect() -> None:
    """Leave the cluster this process connected to (nothing if the caller connected itself)."""
    global _session
    if _session is not None:
        import ray

        ray.shutdown()
        _session = None
