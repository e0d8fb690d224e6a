"""What stops a run from outside its planners: the user's Ctrl-C and the run's wall-clock limit.

Whatever a planner raises — ``SystemExit``, ``KeyboardInterrupt`` or a ``BaseException`` of its
own — fails its planning cycle (`PLANNER_CRASHES`); what stops the run from outside must not be
mistaken for one (`RUN_STOPS`): while `interruptions` is active the user's Ctrl-C raises
`RunInterrupted`, which the loop lets through. The wall-clock limit is a timer
signal that raises `WallClockExceeded` wherever the run is, even in a ``plan()`` that never
returns (once its Python code runs again). Signals reach only the main thread: elsewhere neither is
installed, and the loop's check of the wall clock between steps remains. A planner that ends the
process itself with ``os._exit`` raises `ProcessExitRefused` instead while `interruptions` is active
(its cycle fails like any crash; a process it forked still ends); one that crashes the interpreter
(a segfault) cannot be stopped in process: the command says so (``faulthandler``) and ``--isolate``
keeps such a planner in a process of its own.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NoReturn

PLANNER_CRASHES = BaseException     # what a planner may raise: its cycle fails (after RUN_STOPS are let through)
DEFAULT_RUN_TIMEOUT_S = 600.0   # wall time a run may take unless told otherwise [s] (simgap run, experiments)


class RunInterrupted(KeyboardInterrupt):
    """The user pressed Ctrl-C."""


class WallClockExceeded(BaseException):
    """The run's wall-clock limit passed (a BaseException: a planner's ``except Exception`` does not swallow it)."""

    def __init__(self, limit_s: float):
        super().__init__(f"still running after {limit_s:g} s of wall time")
        self.limit_s = limit_s


class ProcessExitRefused(BaseException):
    """``os._exit`` called in simgap's process during a run (by a planner): its cycle fails, the run goes on."""

    def __init__(self, code: int):
        super().__init__(f"os._exit({code}) would have ended simgap's process (refused; --isolate runs a planner "
                         "in a process of its own)")


@contextmanager
def _exit_refused() -> Iterator[None]:
    """Inside, in this process (not in one forked from it), ``os._exit`` raises `ProcessExitRefused`."""
    own_exit, owner = os._exit, os.getpid()

    def refused(status: int) -> NoReturn:
        if os.getpid() != owner:
            own_exit(status)
        raise ProcessExitRefused(status)

    os._exit = refused
    try:
        yield
    finally:
        os._exit = own_exit


@contextmanager
def interruptions(wall_time_limit_s: float | None = None) -> Iterator[None]:
    """Inside: Ctrl-C raises `RunInterrupted` (where it would raise KeyboardInterrupt), and
    `WallClockExceeded` is raised once ``wall_time_limit_s`` after entering (None: no limit)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    with _exit_refused(), _signals(wall_time_limit_s):
        yield


@contextmanager
def _signals(wall_time_limit_s: float | None) -> Iterator[None]:

    def interrupted(signum, frame) -> None:
        raise RunInterrupted()

    own_sigint = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if own_sigint:
        signal.signal(signal.SIGINT, interrupted)
    previous_alarm = None
    if wall_time_limit_s is not None:
        limit_s = wall_time_limit_s

        def timed_out(signum, frame) -> None:
            raise WallClockExceeded(limit_s)

        previous_alarm = signal.signal(signal.SIGALRM, timed_out)
        signal.setitimer(signal.ITIMER_REAL, wall_time_limit_s)
    try:
        yield
    finally:
        if wall_time_limit_s is not None:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous_alarm or signal.SIG_DFL)
        if own_sigint:
            signal.signal(signal.SIGINT, signal.default_int_handler)


RUN_STOPS = (RunInterrupted, WallClockExceeded)     # what stops a run from outside its planners: let through
