"""`simgap` as a user runs it, in a process of its own, for the command-line tests: its exit code,
standard output and error, working directory and environment are its own. Each command is a fork
of a server process that imported simgap's commands and what a run imports once (and runs nothing
itself), not a new interpreter that imports them again: 2 to 5 s of CPU saved a command, and the
suite runs several hundred. The server is started by the first command of a test worker and ends with it.

Why a server and not a fork of the test worker: the worker has run planners in process, and
GNU OpenMP (frenetix's) does not survive a fork once its threads have run. What a fork cannot
give: an environment read when a module is imported (``MUJOCO_GL`` by MuJoCo, ``PYTHONPATH`` and
entry points) is the server's, the worker's at its start; tests about those start the interpreter
(`subprocess`)."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import tempfile
from functools import cache
from pathlib import Path


def simgap(*args: object, cwd: str | Path | None = None, env: dict[str, str] | None = None,
           timeout: float = 300) -> subprocess.CompletedProcess:
    """``simgap ARGS`` run to its end in a process of its own (``env``: its whole environment; the
    worker's when None)."""
    argv = [str(a) for a in args]
    server = _server()
    with tempfile.TemporaryDirectory(prefix="simgap-command-") as folder:
        out, err = Path(folder) / "stdout", Path(folder) / "stderr"
        request = {"argv": argv, "cwd": None if cwd is None else str(cwd), "env": dict(os.environ if env is None else env),
                   "stdout": str(out), "stderr": str(err)}
        server.stdin.write(json.dumps(request) + "\n")
        server.stdin.flush()
        pid = int(_line(server, 60))
        try:
            code = int(_line(server, timeout))
        except TimeoutError:
            os.killpg(pid, signal.SIGKILL)
            _line(server, 60)
            raise subprocess.TimeoutExpired(["simgap", *argv], timeout) from None
        return subprocess.CompletedProcess(["simgap", *argv], code, out.read_text(), err.read_text())


@cache
def _server() -> subprocess.Popen:
    return subprocess.Popen([sys.executable, __file__], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            bufsize=1, env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))


def _line(server: subprocess.Popen, timeout: float) -> str:
    if not select.select([server.stdout], [], [], timeout)[0]:
        raise TimeoutError
    line = server.stdout.readline()
    if not line:
        raise RuntimeError(f"the simgap command server ended (exit {server.wait()})")
    return line


def _serve() -> None:
    """Read a request a line, fork its command, answer its process id, then its exit code."""
    import importlib

    from simgap.cli import main as cli
    from simgap.experiment.fork_server import RUN_IMPORTS

    for module in [f"simgap.cli.{m}" for m in sorted(set(cli.COMMANDS.values()))] + list(RUN_IMPORTS):
        importlib.import_module(module)
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            _command(cli, request)
        print(pid, flush=True)
        print(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), flush=True)


def _command(cli, request: dict) -> None:
    code = 1
    try:
        os.setpgid(0, 0)                                  # its own group: a timeout stops it and its children
        null = os.open(os.devnull, os.O_RDONLY)
        out = os.open(request["stdout"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        err = os.open(request["stderr"], os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(null, 0), os.dup2(out, 1), os.dup2(err, 2)
        sys.stdin, sys.stdout, sys.stderr = open(0, closefd=False), open(1, "w", closefd=False), open(2, "w", closefd=False)
        os.environ.clear()
        os.environ.update(request["env"])
        if request["cwd"] is not None:
            os.chdir(request["cwd"])
        sys.argv = ["simgap", *request["argv"]]
        try:
            cli.main()
            code = 0
        except SystemExit as stop:
            code = stop.code if isinstance(stop.code, int) else (0 if stop.code is None else 1)
            if isinstance(stop.code, str):
                print(stop.code, file=sys.stderr)
    except BaseException:
        import traceback
        traceback.print_exc()
    finally:
        try:
            import atexit
            atexit._run_exitfuncs()
            sys.stdout.flush(), sys.stderr.flush()
        finally:
            os._exit(code)


if __name__ == "__main__":
    _serve()
