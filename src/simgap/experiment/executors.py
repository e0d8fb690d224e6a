"""Executors: where the runs of an experiment execute.

`LocalExecutor` keeps N worker processes (forked from `fork_server`, which has loaded what a run
imports, so nothing of the driver's threads or state leaks into them; each takes the driver's
environment of the moment), hands each one run at a time, and watches them: a worker that dies (a crash,
a kill) or overruns the per-run timeout is replaced, and only its run is recorded as failed, with
the reason. A worker ends with the driver, however the driver ends (a SIGKILL too), and says
nothing when it finds the driver gone. `RayExecutor` submits the runs to a Ray cluster (a local
one when no address is given; `ray_cluster` connects and checks the nodes first). A node needs no shared filesystem: each
run gets its scenario files with it, runs in a scratch directory of the node it lands on, and
returns its store row and the files of its run directory, which the driver writes (it alone
writes the experiment directory).

Both take the jobs as a list, or as a `JobSource`: a function asked for the next job whenever a
worker is free, which returns ``None`` when it has nothing to give right now (a search that
waits for results before it proposes more). The executor stops when the source has nothing and
no job is in flight.
"""

from __future__ import annotations

import ctypes
import dataclasses
import os
import signal
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any

from simgap.errors import machine_failure
from simgap.experiment import fork_server
from simgap.experiment.job import Job, JobContext
from simgap.experiment.run_row import RunRow
from simgap.experiment.store import MACHINE_FAILED, WORKER_DIED
from simgap.files import replace_directory
from simgap.record import read_run, rewrite_record

OnResult = Callable[[Job, RunRow], None]
_PRCTL = getattr(ctypes.CDLL(None), "prctl", None) if sys.platform.startswith("linux") else None
JobSource = Callable[[], "Job | None"]


def _source(jobs: list[Job] | JobSource) -> JobSource:
    if callable(jobs):
        return jobs
    queue = list(jobs)
    return lambda: queue.pop(0) if queue else None


def failed_row(job: Job, reason: str) -> RunRow:
    return RunRow.failed(job, reason)


def _crashed_row(job: Job, exc: BaseException) -> RunRow:
    """The row of a run whose code raised ``exc``: its last line is the reason (a failure of the
    machine says so: such a run is no result and runs again on resume)."""
    reason = traceback.format_exception_only(type(exc), exc)[-1].strip()
    machine = machine_failure(exc)
    return failed_row(job, reason if machine is None else f"{MACHINE_FAILED}: {machine} ({reason})")


def _worker(conn, driver: int, where: _Where) -> None:
    """A pool's worker: runs the jobs the driver (process ``driver``) sends, one at a time, where
    the driver runs, and ends with it — killed when the driver dies (Linux), quietly when it finds
    the driver gone."""
    _die_with_driver(driver)
    where.enter()
    from simgap.experiment.worker import execute_job

    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        job, context = message
        try:
            row = execute_job(job, context)
        except KeyboardInterrupt:        # Ctrl-C reaches the whole process group: the driver stops, no result
            return
        except BaseException as exc:     # the run failed; the worker lives on
            row = _crashed_row(job, exc)
        try:
            conn.send(row)
        except (BrokenPipeError, OSError):   # the driver is gone: nobody is left to read it
            return


def _die_with_driver(driver: int) -> None:
    """End this worker when the driver ends however it ends (SIGKILL too): its parent is the fork
    server, which ends with the driver, so the kernel's parent-death signal on Linux; then a check
    that neither ended before it was set."""
    parent = os.getppid()
    if _PRCTL is not None:
        _PRCTL(1, signal.SIGKILL)                        # PR_SET_PDEATHSIG
    try:
        os.kill(driver, 0)
    except ProcessLookupError:
        os._exit(0)
    if os.getppid() != parent:
        os._exit(0)


@dataclasses.dataclass(frozen=True)
class _Where:
    """What a process started by the driver would take from it and a fork of the fork server (started
    earlier) does not: the environment, the import path and the working directory of the moment."""

    environment: dict[str, str]
    path: list[str]
    cwd: str

    @classmethod
    def now(cls) -> _Where:
        return cls(dict(os.environ), list(sys.path), os.getcwd())

    def enter(self) -> None:
        os.environ.clear()
        os.environ.update(self.environment)
        sys.path[:] = self.path
        os.chdir(self.cwd)


class _Worker:
    def __init__(self, ctx):
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker, args=(child, os.getpid(), _Where.now()), daemon=True)
        self.process.start()
        child.close()
        self.job: Job | None = None
        self.started = 0.0

    def give(self, job: Job, context: JobContext) -> None:
        self.job, self.started = job, time.monotonic()
        self.conn.send((job, context))

    def stop(self, force: bool = False) -> None:
        if force:
            self.process.kill()
        else:
            try:
                self.conn.send(None)
            except (BrokenPipeError, OSError):
                pass
        self.process.join(timeout=5)
        if self.process.is_alive():
            self.process.kill()
            self.process.join()


class LocalExecutor:
    name = "local"

    def __init__(self, workers: int, timeout_s: float):
        self.workers = max(1, workers)
        self.timeout_s = timeout_s

    def run(self, jobs: list[Job] | JobSource, context: JobContext, on_result: OnResult) -> None:
        ctx = fork_server.context()
        size = self.workers if callable(jobs) else min(self.workers, len(jobs))
        next_job = _source(jobs)
        pool = [_Worker(ctx) for _ in range(size)]
        try:
            while True:
                for w in pool:
                    if w.job is None:
                        job = next_job()
                        if job is not None:
                            w.give(job, context)
                busy = [w for w in pool if w.job is not None]
                if not busy:
                    break
                ready = wait([w.conn for w in busy] + [w.process.sentinel for w in busy], timeout=0.5)
                now = time.monotonic()
                for i, w in enumerate(pool):
                    if w.job is None:
                        continue
                    job = w.job
                    if w.conn in ready:
                        try:
                            row = w.conn.recv()
                        except (EOFError, OSError):
                            row = None
                        if row is not None:
                            w.job = None
                            on_result(job, row)
                            continue
                    if not w.process.is_alive() or w.process.sentinel in ready:
                        w.process.join(timeout=5)           # its exit code is known once it is reaped
                        code = w.process.exitcode
                        reason = f"{WORKER_DIED} (exit code {code})" if code is None or code >= 0 else \
                            f"{WORKER_DIED} (signal {-code})"
                        on_result(job, failed_row(job, reason))
                        pool[i] = _Worker(ctx)
                    elif now - w.started > self.timeout_s:
                        w.stop(force=True)
                        on_result(job, failed_row(job, f"timeout: still running after {self.timeout_s:g} s"))
                        pool[i] = _Worker(ctx)
        finally:
            for w in pool:
                w.stop(force=w.job is not None)


def _scenario_path(job: Job, context: JobContext) -> Path:
    return Path(job.scenario_path or (context.scenarios or {})[job.scenario])


def _scenario_files(job: Job, context: JobContext) -> dict[str, bytes]:
    """The scenario of ``job``: its CommonRoad XML and the sidecar beside it, by file name."""
    xml = _scenario_path(job, context)
    return {p.name: p.read_bytes() for p in (xml, xml.with_suffix(".json")) if p.exists()}


def _ray_job(job: Job, context: JobContext, scenario: dict[str, bytes]) -> tuple[RunRow, dict[str, bytes]]:
    """On a node: run ``job`` in a scratch directory; its store row and its run directory's files."""
    from simgap.experiment.worker import execute_job, run_dir_of

    with tempfile.TemporaryDirectory(prefix="simgap-run-") as scratch:
        root = Path(scratch)
        (root / "scenario").mkdir()
        for name, data in scenario.items():
            (root / "scenario" / name).write_bytes(data)
        xml = next(root / "scenario" / name for name in scenario if name.endswith(".xml"))
        try:
            row = execute_job(dataclasses.replace(job, scenario_path=str(xml)), dataclasses.replace(context, root=root))
        except BaseException as exc:
            return _crashed_row(job, exc), {}
        run_dir = run_dir_of(root, job)
        files = {p.relative_to(run_dir).as_posix(): p.read_bytes() for p in run_dir.rglob("*") if p.is_file()}
    return row, files


def _receive_run(root: Path, job: Job, files: dict[str, bytes], scenario_path: str) -> None:
    """Write the run directory a node sent back into ``root``, atomically (aside, then swapped in);
    its ``run.json`` names the scenario file on this machine, as a local run's does."""
    from simgap.experiment.worker import run_dir_of

    if not files:
        return

    def write(tmp: Path) -> None:
        for name, data in files.items():
            (tmp / name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / name).write_bytes(data)
        if (tmp / "run.json").exists():
            record = read_run(tmp)
            rewrite_record(dataclasses.replace(record, settings=dataclasses.replace(record.settings,
                                                                                scenario_path=scenario_path)), tmp)

    replace_directory(run_dir_of(root, job), write)


def _lost(exc: Exception) -> str:
    import ray

    first = (str(exc).strip().splitlines() or [""])[0][:300]
    if isinstance(exc, ray.exceptions.RayTaskError):
        return f"ray: {type(exc).__name__}: {first}"
    return f"{WORKER_DIED} ({type(exc).__name__}: {first})"        # a crash, a kill, a node gone


class RayExecutor:
    name = "ray"

    def __init__(self, workers: int | None, timeout_s: float, address: str | None = None):
        self.workers = workers              # runs in flight; None: as many as the cluster has CPUs
        self.timeout_s = timeout_s
        self.address = address

    def connect(self) -> bool:
        """Connect to the cluster and check its nodes (an InputError if they cannot run ours)."""
        from simgap.experiment.ray_cluster import connect

        return connect(self.address, self.workers)

    def run(self, jobs: list[Job] | JobSource, context: JobContext, on_result: OnResult) -> None:
        import ray

        from simgap.experiment.ray_cluster import disconnect

        ours = self.connect()
        slots = self.workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
        root = Path(context.root)
        remote = ray.remote(max_retries=0, num_cpus=1)(_ray_job)
        next_job = _source(jobs)
        pending: dict[Any, tuple[Job, float]] = {}
        try:
            while True:
                while len(pending) < slots:
                    job = next_job()
                    if job is None:
                        break
                    pending[remote.remote(job, context, _scenario_files(job, context))] = (job, time.monotonic())
                if not pending:
                    break
                done, _ = ray.wait(list(pending), num_returns=1, timeout=0.5)
                for ref in done:
                    job, _ = pending.pop(ref)
                    try:
                        row, files = ray.get(ref)
                    except Exception as exc:     # a worker that died, or a node that left
                        row, files = failed_row(job, _lost(exc)), {}
                    _receive_run(root, job, files, str(_scenario_path(job, context)))
                    on_result(job, row)
                now = time.monotonic()
                for ref, (job, started) in list(pending.items()):
                    if now - started > self.timeout_s:
                        ray.cancel(ref, force=True)
                        pending.pop(ref)
                        on_result(job, failed_row(job, f"timeout: still running after {self.timeout_s:g} s"))
        finally:
            if ours:
                disconnect()


def make_executor(name: str, workers: int | None, timeout_s: float, address: str | None = None):
    """The executor ``name`` with ``workers`` runs in flight (None: all cores, or all the cluster's CPUs)."""
    from simgap.errors import InputError

    if name == "local":
        if address:
            raise InputError("--address is for the ray executor", field="address", allowed="--executor ray")
        return LocalExecutor(workers or os.cpu_count() or 1, timeout_s)
    if name == "ray":
        executor = RayExecutor(workers, timeout_s, address)
        executor.connect()              # an unreachable or unfit cluster stops us before any run
        return executor
    raise InputError(f"unknown executor '{name}'", field="executor", allowed="local, ray")
