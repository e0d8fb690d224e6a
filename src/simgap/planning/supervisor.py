"""Stand between simgap and a planner it starts, so that nothing the planner starts outlives it.

``python -I -S supervisor.py SIMGAP_PID FOLDER -- COMMAND ARGS`` (what `simgap.planning.remote`
runs, by path: this file imports the standard library alone) starts COMMAND and waits. It is a
*child subreaper* (Linux's ``PR_SET_CHILD_SUBREAPER``): whatever the planner forks — children,
``setsid`` daemons, double-forked ones — stays below it however its parents end, where a process
group or a session would lose them. It ends, with every descendant killed and FOLDER (the
planner's temporary folder) removed, when

* the planner's process ends: then with the planner's exit status (its code, or its signal), so
  that simgap reads why the planner ended from this process's;
* it is sent SIGTERM, SIGINT or SIGHUP (simgap closing the planner), or simgap's process ends,
  even killed (``PR_SET_PDEATHSIG`` sends it SIGTERM).

Without cgroups, a process that leaves this tree can only be one that was re-parented to a
subreaper between it and this one (none, unless the planner makes itself one).
"""

from __future__ import annotations

import ctypes
import os
import resource
import shutil
import signal
import sys
import time

LINUX = sys.platform.startswith("linux")
PR_SET_PDEATHSIG = 1
PR_SET_CHILD_SUBREAPER = 36
END_ALL_WITHIN_S = 5.0          # wall time to kill and reap every descendant (a fork bomb: as many as it made)
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGHUP)


class _Stop(Exception):
    """simgap asked this process to end, or ended itself."""


def _stop(signum, frame) -> None:
    raise _Stop()


def descendants(root: int) -> list[int]:
    """Every process below ``root`` (from /proc: each process's parent; none without /proc)."""
    children: dict[int, list[int]] = {}
    if not LINUX:
        return []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", "rb") as stat:
                text = stat.read()
        except OSError:             # ended meanwhile
            continue
        parent = int(text[text.rindex(b")") + 2:].split()[1])
        children.setdefault(parent, []).append(int(entry))
    found, todo = [], [root]
    while todo:
        for child in children.get(todo.pop(), ()):
            found.append(child)
            todo.append(child)
    return found


def _reap() -> None:
    """Collect every ended child (orphans become this process's children: it is a subreaper)."""
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def end_all() -> None:
    """Kill every descendant, until none is left (or ``END_ALL_WITHIN_S`` has passed)."""
    end = time.monotonic() + END_ALL_WITHIN_S
    while time.monotonic() < end:
        _reap()
        left = descendants(os.getpid())
        if not left:
            return
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        time.sleep(0.005)


def _start(command: list[str]) -> int:
    pid = os.fork()
    if pid == 0:                                                # the planner, before its program runs
        try:
            for signum in STOP_SIGNALS:
                signal.signal(signum, signal.SIG_DFL)
            if LINUX:
                ctypes.CDLL(None).prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
            os.execvp(command[0], command)
        except BaseException as exc:                            # noqa: BLE001 - whatever it is, say it and end
            os.write(2, f"cannot start {command[0]}: {exc}\n".encode(errors="replace"))
        os._exit(127)
    return pid


def main(argv: list[str]) -> None:
    if len(argv) < 4 or argv[2] != "--":
        raise SystemExit("usage: supervisor.py SIMGAP_PID FOLDER -- COMMAND ARGS")
    simgap, folder, command = int(argv[0]), argv[1], argv[3:]
    resource.setrlimit(resource.RLIMIT_CORE, (0, resource.getrlimit(resource.RLIMIT_CORE)[1]))
    if LINUX:                                                   # elsewhere: the planner alone is ended
        libc = ctypes.CDLL(None)
        libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
    status = None
    try:
        for signum in STOP_SIGNALS:
            signal.signal(signum, _stop)
        if os.getppid() != simgap:                              # simgap ended before the line above
            raise _Stop()
        planner = _start(command)
        while status is None:
            pid, code = os.waitpid(-1, 0)
            if pid == planner:
                status = code
    except _Stop:
        pass
    finally:
        for signum in STOP_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)               # the cleaning-up is not cut short
        end_all()
        shutil.rmtree(folder, ignore_errors=True)
    if status is None or os.WIFSIGNALED(status):                # end as the planner did: by its signal …
        ended_by: int = signal.SIGTERM if status is None else os.WTERMSIG(status)
        if ended_by != signal.SIGKILL:
            signal.signal(ended_by, signal.SIG_DFL)
        os.kill(os.getpid(), ended_by)
        time.sleep(1)
    sys.exit(os.waitstatus_to_exitcode(status) if status is not None else 1)   # … or with its code


if __name__ == "__main__":
    main(sys.argv[1:])
