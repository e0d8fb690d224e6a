"""Executors: where the runs of an experiment execute.

`LocalExecutor` keeps N worker processes (spawned, so nothing of the parent's threads or state
leaks into them), hands each one run at a time, and watches them: a worker that dies (a crash,
a kill) or overruns the per-run timeout is replaced, and only its run is recorded as failed, with
the reason. `RayExecutor` submits the same job function to a Ray cluster (a local one when no
address is given); results come back to the driver, which alone writes the store.

Both take the jobs as a list, or as a `JobSource`: a function asked for the next job whenever a
worker is free, which returns ``None`` when it has nothing to give right now (a search that
waits for results before it proposes more). The executor stops when the source has nothing and
no job is in flight.
"""

from __future__ import annotations

import multiprocessing as mp
import time
import traceback
from multiprocessing.connection import wait
from typing import Any, Callable

from simgap.experiment.records import Job, RunRow

OnResult = Callable[[Job, RunRow], None]
JobSource = Callable[[], "Job | None"]


def _source(jobs: "list[Job] | JobSource") -> JobSource:
    if callable(jobs):
        return jobs
    queue = list(jobs)
    return lambda: queue.pop(0) if queue else None


def failed_row(job: Job, reason: str) -> RunRow:
    return RunRow.failed(job, reason)


def _worker(conn) -> None:
    from simgap.experiment.job import execute_job

    while True:
        try:
            message = conn.recv()
        except EOFError:
            return
        if message is None:
            return
        job, context = message
        try:
            row = execute_job(job, context)
        except BaseException as exc:     # the run failed; the worker lives on
            last = traceback.format_exception_only(type(exc), exc)[-1].strip()
            row = failed_row(job, f"{last}")
        conn.send(row)


class _Worker:
    def __init__(self, ctx):
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(target=_worker, args=(child,), daemon=True)
        self.process.start()
        child.close()
        self.job: Job | None = None
        self.started = 0.0

    def give(self, job: Job, context: dict) -> None:
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

    def run(self, jobs: "list[Job] | JobSource", context: dict, on_result: OnResult) -> None:
        ctx = mp.get_context("spawn")
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
                        code = w.process.exitcode
                        reason = f"worker died (exit code {code})" if code is None or code >= 0 else \
                            f"worker died (signal {-code})"
                        on_result(job, failed_row(job, reason))
                        pool[i] = _Worker(ctx)
                    elif now - w.started > self.timeout_s:
                        w.stop(force=True)
                        on_result(job, failed_row(job, f"timeout: still running after {self.timeout_s:g} s"))
                        pool[i] = _Worker(ctx)
        finally:
            for w in pool:
                w.stop(force=w.job is not None)


def _ray_job(job: Job, context: dict) -> dict:
    from simgap.experiment.job import execute_job

    try:
        return execute_job(job, context)
    except BaseException as exc:
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        return failed_row(job, last)


class RayExecutor:
    name = "ray"

    def __init__(self, workers: int, timeout_s: float, address: str | None = None):
        self.workers = max(1, workers)
        self.timeout_s = timeout_s
        self.address = address

    def run(self, jobs: "list[Job] | JobSource", context: dict, on_result: OnResult) -> None:
        import ray

        started_here = not ray.is_initialized()
        if started_here:
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                                      "configure_logging": False}
            if self.address:
                ray.init(address=self.address, **kwargs)
            else:
                ray.init(num_cpus=self.workers, **kwargs)
        remote = ray.remote(max_retries=0, num_cpus=1)(_ray_job)
        next_job = _source(jobs)
        pending: dict[Any, tuple[Job, float]] = {}
        try:
            while True:
                while len(pending) < self.workers:
                    job = next_job()
                    if job is None:
                        break
                    pending[remote.remote(job, context)] = (job, time.monotonic())
                if not pending:
                    break
                done, _ = ray.wait(list(pending), num_returns=1, timeout=0.5)
                for ref in done:
                    job, _ = pending.pop(ref)
                    try:
                        row = ray.get(ref)
                    except Exception as exc:     # a worker that died or a task Ray gave up on
                        row = failed_row(job, f"ray: {type(exc).__name__}: {str(exc).splitlines()[0]}")
                    on_result(job, row)
                now = time.monotonic()
                for ref, (job, started) in list(pending.items()):
                    if now - started > self.timeout_s:
                        ray.cancel(ref, force=True)
                        pending.pop(ref)
                        on_result(job, failed_row(job, f"timeout: still running after {self.timeout_s:g} s"))
        finally:
            if started_here:
                ray.shutdown()


def make_executor(name: str, workers: int, timeout_s: float, address: str | None = None):
    from simgap.errors import InputError

    if name == "local":
        if address:
            raise InputError("--address is for the ray executor", field="address", allowed="--executor ray")
        return LocalExecutor(workers, timeout_s)
    if name == "ray":
        return RayExecutor(workers, timeout_s, address)
    raise InputError(f"unknown executor '{name}'", field="executor", allowed="local, ray")
