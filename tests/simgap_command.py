"""`simgap` as a user runs it, in a process of its own, for the command-line tests: its exit code,
standard output and error, working directory and environment are its own. Each command is a fork
of a server process that imported simgap's commands and what a run imports once (and runs nothing
itself), not a new interpreter that imports them again: 2 to 5 s of CPU saved a command, and the
suite runs several hundred. A server is started by the first command of a test worker that needs it
and ends with the worker.

Why a server and not a fork of the test worker: the worker has run planners in process, and
GNU OpenMP (frenetix's) does not survive a fork once its threads have run. The environment a
module reads when it is imported (`IMPORTED`: ``MUJOCO_GL`` by MuJoCo, ``PYTHONPATH`` and with it
the entry points an installed plugin declares, the BLAS kernel) is the server's: a command whose
environment sets them otherwise runs in a server of its own, started with that environment."""

from __future__ import annotations

import json
import os
import select
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from functools import cache
from pathlib import Path


def simgap(*args: object, cwd: str | Path | None = None, env: dict[str, str] | None = None,
           timeout: float = 300) -> subprocess.CompletedProcess:
    """``simgap ARGS`` run to its end in a process of its own (``env``: its whole environment; the
    worker's when None)."""
    return start(*args, cwd=cwd, env=env).wait(timeout)


@dataclass
class Started:
    """A command running in a process of its own, the leader of its process group (``pid``: what
    ``os.killpg`` stops with its study's processes). Its server runs nothing else until it ends."""

    argv: list[str]
    pid: int
    server: subprocess.Popen
    folder: Path            # its standard output and error

    def wait(self, timeout: float = 300) -> subprocess.CompletedProcess:
        """Its exit code and output once it has ended (killed after ``timeout`` seconds)."""
        try:
            code = int(_line(self.server, timeout))
        except TimeoutError:
            os.killpg(self.pid, signal.SIGKILL)
            _line(self.server, 60)
            raise subprocess.TimeoutExpired(["simgap", *self.argv], timeout) from None
        finally:
            out, err = (self.folder / name for name in ("stdout", "stderr"))
            printed = out.read_text(), err.read_text()
            shutil.rmtree(self.folder)
        return subprocess.CompletedProcess(["simgap", *self.argv], code, *printed)


def start(*args: object, cwd: str | Path | None = None, env: dict[str, str] | None = None) -> Started:
    """``simgap ARGS`` started in a process of its own, as `simgap` runs it (the tests that stop a
    command midway)."""
    argv = [str(a) for a in args]
    environment = dict(os.environ if env is None else env)
    server = _server(tuple(_imported(name, environment.get(name)) for name in IMPORTED))
    folder = Path(tempfile.mkdtemp(prefix="simgap-command-"))
    request = {"argv": argv, "cwd": None if cwd is None else str(cwd), "env": environment,
               "stdout": str(folder / "stdout"), "stderr": str(folder / "stderr")}
    server.stdin.write(json.dumps(request) + "\n")
    server.stdin.flush()
    return Started(argv, int(_line(server, 60)), server, folder)


#: what a process reads from its environment when it imports simgap and what a run imports
IMPORTED = ("PYTHONPATH", "MUJOCO_GL", "OPENBLAS_CORETYPE")
#: where the worker found modules when it started (not what a test puts on its path since)
_STARTING_PATH = {os.path.realpath(p) for p in sys.path if p} | {str(Path(__file__).resolve().parents[1] / "src")}


def _imported(name: str, value: str | None) -> str | None:
    """``value`` of ``name`` as far as it changes what is imported: a ``PYTHONPATH`` without the
    folders the worker found modules in when it started (simgap's own among them)."""
    if name != "PYTHONPATH" or value is None:
        return value
    extra = [p for p in value.split(os.pathsep) if p and os.path.realpath(p) not in _STARTING_PATH]
    return os.pathsep.join(extra) or None


@cache
def _server(imported: tuple[str | None, ...]) -> subprocess.Popen:
    """The server whose environment has the values ``imported`` (of `IMPORTED`), the worker's
    modules found after the given ``PYTHONPATH``'s."""
    env = dict(os.environ)
    for name, value in zip(IMPORTED, imported):
        if value is None:
            env.pop(name, None)
        else:
            env[name] = value
    env["PYTHONPATH"] = os.pathsep.join([p for p in [env.get("PYTHONPATH")] if p] + sys.path)
    return subprocess.Popen([sys.executable, __file__], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            bufsize=1, env=env)


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
        _fork_server_from_here()
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


def _fork_server_from_here() -> None:
    """The fork server a command's study starts (`simgap.experiment.fork_server`) forked from the
    command's own process — which, a fork of this server, has imported what a run imports and has
    the command's environment, folder and output — instead of a new interpreter that imports it
    all again (seconds of CPU a study): set up as multiprocessing's ``ForkServer.ensure_running``
    sets up the one it starts, which then finds it running. Only the way the server comes to be
    differs: it forks the study's workers as it would."""
    from multiprocessing import connection, forkserver, resource_tracker

    server = forkserver._forkserver
    ensure_running = server.ensure_running

    def from_here() -> None:
        if server._forkserver_pid is None:
            resource_tracker.ensure_running()
            listener = socket.socket(socket.AF_UNIX)
            address = connection.arbitrary_address("AF_UNIX")
            listener.bind(address)
            os.chmod(address, 0o600)
            listener.listen()
            alive_r, alive_w = os.pipe()       # the server ends when this process (the write end) does
            pid = os.fork()
            if pid == 0:
                try:
                    os.close(alive_w)
                    forkserver.main(listener.fileno(), alive_r, [])
                finally:
                    os._exit(0)
            os.close(alive_r)
            listener.close()
            server._forkserver_address, server._forkserver_alive_fd, server._forkserver_pid = address, alive_w, pid
        ensure_running()

    server.ensure_running = forkserver.ensure_running = from_here


if __name__ == "__main__":
    _serve()
