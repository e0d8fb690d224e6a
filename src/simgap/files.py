"""The project's file handling in one place: every file is written atomically (a temporary file
beside it, then a rename, so a reader never sees half of one), so is every directory (built aside,
then swapped into place), and every YAML input is read as a mapping and validated by a pydantic
model, with errors that name the file and the field."""

from __future__ import annotations

import fcntl
import glob
import json
import os
import shutil
import tempfile
import uuid
from collections.abc import Callable, Hashable, Iterator
from contextlib import contextmanager
from datetime import UTC
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel

from simgap.errors import InputError, validated

M = TypeVar("M", bound=BaseModel)


TEMPORARY_NAME_ROOM = 24    # bytes a temporary name beside a file or directory adds to its name


def writable_directory(path: Path | None) -> Path | None:
    """``path`` as a directory simgap can make and write in (None passes through): an existing
    file there, a name longer than the file system holds (with the room temporary names beside it
    need) and a folder that cannot be written (no permission, a read-only file system) are
    refused in one line before any work."""
    if path is None:
        return None
    existing = _deepest_existing(path.absolute())
    if existing.exists() and not existing.is_dir():
        raise InputError("is a file" if existing == path.absolute() else f"lies inside the file {existing}",
                         file=path, allowed="a directory, new or existing")
    longest = os.pathconf(existing, "PC_NAME_MAX") - TEMPORARY_NAME_ROOM
    too_long = next((part for part in path.parts if len(os.fsencode(part)) > longest), None)
    if too_long is not None:
        raise InputError(f"a name in it is {len(os.fsencode(too_long))} bytes long", file=path,
                         allowed=f"names of at most {longest} bytes (the file system's limit less room for "
                                 "temporary names)")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        raise InputError(f"cannot be written: {exc.strerror} in {existing}", file=path,
                         allowed="a folder you can write to") from None
    return path


def _deepest_existing(absolute: Path) -> Path:
    """The deepest folder (or file) on the way to ``absolute`` that exists."""
    existing = Path(absolute.anchor)
    for part in absolute.parts[1:]:
        try:
            if not (existing / part).exists():
                break
        except OSError:              # a name too long to look up
            break
        existing = existing / part
    return existing


def atomic_write(path: str | Path, write: Callable[[Path], Any], keep_suffix: bool = False) -> Path:
    """Call ``write`` on a temporary file next to ``path``, then rename it into place. The
    temporary file is hidden and ends in ``.tmp`` (or, with ``keep_suffix``, in ``.tmp`` and the
    suffix of ``path``, for writers that choose the format by it)."""
    path = Path(path)
    tmp = path.parent / f".{path.name}.{uuid.uuid4().hex[:8]}.tmp{path.suffix if keep_suffix else ''}"
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def remove_stale_temporaries(root: str | Path) -> int:
    """Delete the temporary files `atomic_write` leaves under ``root`` when its process is killed
    mid-write (never read by anyone); call it only where no other writer is at work. Returns how
    many it removed."""
    removed = 0
    for stale in Path(root).rglob(".*.tmp*"):
        if stale.is_file() and ".tmp" in stale.name:
            stale.unlink(missing_ok=True)
            removed += 1
    return removed


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write(path, lambda tmp: tmp.write_text(text))


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    return atomic_write(path, lambda tmp: tmp.write_bytes(data))


def replace_directory(path: str | Path, build: Callable[[Path], Any]) -> Path:
    """Call ``build`` on an empty hidden directory next to ``path``, then swap it into place: the
    old directory (if any) is renamed aside, the new one renamed in, the old one deleted. A reader
    never sees half a directory; a process killed between two renames leaves the old directory
    aside, and the next swap into ``path`` (or `restore_directory`) puts it back first — so
    ``path`` always ends up holding one whole directory, the old or the new."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    restore_directory(path)
    old = _set_aside(path)
    if path.exists() and old.exists() and not old.is_dir():
        raise InputError(f"a file named {old.name} lies where the old directory would be set aside while the new one "
                         "moves in; it is not simgap's, so nothing was replaced", file=old,
                         allowed="remove or rename that file, or choose another destination")
    tmp = path.parent / f".{path.name}.{uuid.uuid4().hex[:8]}"
    tmp.mkdir()                       # with the permissions of the user's umask, as any folder they make
    try:
        build(tmp)
        if path.exists():
            os.replace(path, old)
        os.replace(tmp, path)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        restore_directory(path)
        raise
    shutil.rmtree(old, ignore_errors=True)
    return path


def restore_directory(path: str | Path) -> None:
    """Finish a swap of `replace_directory` that a killed process left half done: the old
    directory set aside goes back to ``path`` when ``path`` is missing, else it is deleted, and
    a new one left half-built beside it is deleted (call it where no other writer of ``path`` is
    at work)."""
    path = Path(path)
    old = _set_aside(path)
    if old.is_dir():                  # anything else by that name is not one of ours
        if path.exists():
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(old, path)
    if path.parent.exists():
        for stale in path.parent.glob(f".{path.name}.*"):
            if stale.is_dir():
                shutil.rmtree(stale, ignore_errors=True)


def _set_aside(path: Path) -> Path:
    """Where `replace_directory` keeps the old directory while the new one moves in."""
    return path.with_name(f".{path.name}.old")


class _StrictYamlLoader(yaml.SafeLoader):
    """Safe YAML that also refuses a key given twice in one mapping (YAML keys are unique; PyYAML
    would keep the last silently) and aliases (``*name``), which let a few hundred bytes expand
    to gigabytes; a simgap input has no need of them."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            alias = self.peek_event()
            raise yaml.MarkedYAMLError(problem=f"the alias *{alias.anchor}: simgap reads no aliases, write the "
                                               "value out", problem_mark=alias.start_mark)
        return super().compose_node(parent, index)

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        first_line: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if isinstance(key, Hashable) and key in first_line:
                raise yaml.MarkedYAMLError(problem=f"the key '{key}' is given twice (first on line "
                                                   f"{first_line[key]})", problem_mark=key_node.start_mark)
            first_line.setdefault(key, key_node.start_mark.line + 1)
        return super().construct_mapping(node, deep)


def _yaml_problem(exc: yaml.YAMLError) -> str:
    """A YAML error in one line: what is wrong, and where."""
    if isinstance(exc, yaml.MarkedYAMLError) and exc.problem_mark is not None:
        mark = exc.problem_mark
        return f"malformed YAML at line {mark.line + 1}, column {mark.column + 1}: {exc.problem}"
    return "malformed YAML: " + " ".join(str(exc).split())


def read_yaml_mapping(path: str | Path, what: str, keys: str | None = None, empty_ok: bool = False
                      ) -> dict[str, Any]:
    """The YAML mapping in ``path`` (an empty file too, if ``empty_ok``), or an `InputError` naming
    the file (``what``: the kind of file; ``keys``: what such a mapping holds). A key given twice
    and an alias are refused (`_StrictYamlLoader`)."""
    path = Path(path)
    try:
        raw = yaml.load(path.read_text(), Loader=_StrictYamlLoader)
    except OSError as exc:
        raise InputError(f"cannot read the {what}: {exc.strerror}", file=path) from None
    except yaml.YAMLError as exc:
        raise InputError(_yaml_problem(exc), file=path) from None
    if raw is None and empty_ok:
        raw = {}
    if not isinstance(raw, dict):
        raise InputError(f"a {what} is a mapping", file=path, allowed=keys)
    return raw


def read_model(path: str | Path, model: type[M], what: str, keys: str | None = None,
               defaults: dict[str, Any] | None = None, empty_ok: bool = False) -> M:
    """``path`` read as YAML and validated as ``model`` (``defaults`` fill keys the file leaves
    out); every problem is an `InputError` naming the file, the field and what is allowed."""
    raw = dict(defaults or {}) | read_yaml_mapping(path, what, keys, empty_ok)
    return validated(model, raw, file=path)


def read_json_model(path: str | Path, model: type[M], what: str) -> M:
    """The JSON object in ``path`` validated as ``model`` (a file simgap wrote: JSON, not YAML, whose
    rules would read ``5e-05`` as a string); every problem is an `InputError` naming the file and
    the field."""
    path = Path(path)
    try:
        raw = json.loads(path.read_text())
    except OSError as exc:
        raise InputError(f"cannot read the {what}: {exc.strerror}", file=path) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"the {what} is not JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})",
                         file=path) from None
    if not isinstance(raw, dict):
        raise InputError(f"the {what} is a JSON object", file=path)
    return validated(model, raw, file=path)


WRITER_LOCK = ".writer.lock"   # the file in a directory that its one writer holds locked


@contextmanager
def sole_writer(path: str | Path, writer: str) -> Iterator[Path]:
    """Hold ``path`` (made if missing) as its only writer while the block runs: a lock on a hidden
    file in it, which the system releases when the process ends however it ends. A second
    ``writer`` on the same directory is refused in one line instead of doing the same work."""
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    with open(path / WRITER_LOCK, "a") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(f"another {writer} is writing to this directory", file=path,
                             allowed="wait until it ends, or another --out") from None
        yield path


@contextmanager
def staged_directory(parent: str | Path, name: str = "staged") -> Iterator[Path]:
    """A hidden directory in ``parent`` to build several files in before any of them is moved
    into place (`publish`); removed afterwards with whatever was left in it, so a failure leaves
    nothing half-written. What a writer of the same ``name`` killed there before (SIGKILL: no
    cleanup ran) left is removed first."""
    parent = Path(parent)
    parent.mkdir(parents=True, exist_ok=True)
    for stale in parent.glob(f".{glob.escape(name)}.*.tmp"):
        if stale.is_dir():
            shutil.rmtree(stale, ignore_errors=True)
    path = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".tmp", dir=parent))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def publish(staged: Path, out: Path, names: list[str]) -> list[Path]:
    """Move the files ``names``, built in ``staged`` (a `staged_directory` in ``out``), into
    ``out``, each by one rename so a reader sees it whole, in the order given (a file that refers
    to another after it); returns where they are now."""
    out.mkdir(parents=True, exist_ok=True)
    for name in names:
        os.replace(staged / name, out / name)
    return [out / name for name in names]


class BenchmarkResults:
    """A benchmark's results file: its figures beside where they came from.

    Made when the benchmark starts (the load then is kept), written at its end with
    ``write(path, figures)``: one JSON object with ``commit`` (the short hash, ``-dirty`` when tracked
    files other than ``bench/results/`` differ from it), ``date`` (UTC), ``machine`` (architecture, CPUs, system, Python), ``load``
    (the 1-minute load average at the start and at the end, and the CPUs it is shared over),
    ``command`` (how the benchmark was started), ``wall_time_s``, then the figures: a mapping's keys,
    or a list under ``rows``. ``printed`` tees what the benchmark prints, for a script whose tables
    are only printed: ``write(path, figures, printed=True)`` adds them as ``printed`` lines (with
    ``BenchmarkResults(tee=True)``, everything printed until ``write``).
    """

    PROVENANCE = ("commit", "date", "machine", "load", "command", "wall_time_s")

    def __init__(self, argv: list[str] | None = None, tee: Any = False) -> None:
        """``tee`` true: keep what is printed from now until ``write`` (as ``printed`` does)."""
        import sys
        import time
        self._start = time.perf_counter()
        self._load_before = os.getloadavg()[0]
        self._argv = list(sys.argv if argv is None else argv)
        self._printed: list[str] = []
        self._tee: Any = None
        if tee:
            self._tee = self.printed()
            self._tee.__enter__()

    @contextmanager
    def printed(self) -> Iterator[None]:
        """Keep a copy of what is printed to stdout inside the block (it is still printed)."""
        import io
        import sys

        class Tee(io.TextIOBase):
            def write(tee, text: str) -> int:
                self._printed.append(text)
                return original.write(text)

            def flush(tee) -> None:
                original.flush()

        original = sys.stdout
        sys.stdout = Tee()
        try:
            yield
        finally:
            sys.stdout = original

    def provenance(self) -> dict[str, Any]:
        import platform
        import shlex
        import subprocess
        import time
        from datetime import datetime

        def git(*args: str) -> subprocess.CompletedProcess:
            return subprocess.run(["git", *args], capture_output=True, text=True, cwd=Path(self._argv[0]).parent
                                  if self._argv and Path(self._argv[0]).parent.is_dir() else None)
        commit = git("rev-parse", "--short", "HEAD").stdout.strip() or "unknown"
        # results files written since (this benchmark's or another's) are not code: they leave the commit clean
        if commit != "unknown" and git("diff", "--quiet", "HEAD", "--", ":(top)",
                                       ":(top,exclude)bench/results").returncode == 1:
            commit += "-dirty"
        script = Path(self._argv[0]) if self._argv else Path("?")
        try:
            script = script.resolve().relative_to(Path.cwd())
        except ValueError:
            pass
        return {"commit": commit, "date": datetime.now(UTC).isoformat(timespec="seconds"),
                "machine": f"{platform.machine()}, {os.cpu_count()} CPUs, {platform.system()} {platform.release()}, "
                           f"Python {platform.python_version()}",
                "load": {"start": round(self._load_before, 2), "end": round(os.getloadavg()[0], 2),
                         "cpus": os.cpu_count()},
                "command": shlex.join(["python", str(script), *self._argv[1:]]),
                "wall_time_s": round(time.perf_counter() - self._start, 1)}

    def write(self, path: str | Path, figures: Any = None, printed: bool = False) -> Path:
        """Write the results file (atomically; its folder is made) and return its path."""
        import json
        if self._tee is not None:
            self._tee.__exit__(None, None, None)
            self._tee = None
            printed = True
        data = self.provenance()
        if isinstance(figures, dict):
            data.update({k: v for k, v in figures.items() if k not in self.PROVENANCE})
        elif figures is not None:
            data["rows"] = figures
        if printed:
            data["printed"] = "".join(self._printed).rstrip("\n").splitlines()
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        return atomic_write_text(path, json.dumps(data, indent=1, default=str) + "\n")
