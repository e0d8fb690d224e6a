"""What a command may write over. A command writes into a folder that is new, or that holds what
the same command wrote (a run of the very same scenario, backend, vehicles and planners; a
report; pictures; scenarios or exports, which `simgap generate` and `simgap export` list in a
hidden file of the folder); anything else it would replace is refused before any work, naming
what is there, unless ``--overwrite`` is given."""

from __future__ import annotations

import json
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from simgap.errors import InputError
from simgap.files import atomic_write_text

if TYPE_CHECKING:                 # (a run's modules are imported by the checks of a run's folder only:
    from simgap.experiment.single_run import RunRequest  # generate and export start without them)

OVERWRITE_HELP = "replace what the output folder holds even when this command did not write it"
REPORT_FILES = ("index.html", "report.css", "report.js")
PICTURES = "pictures.json"                                     # what `simgap render` drew into a folder


def refuse(out: Path, what: str) -> None:
    raise InputError(f"holds {what}; not replaced", file=out,
                     allowed="another --out, or --overwrite to replace it")


def check_run_out(out: Path, request: RunRequest, overwrite: bool) -> None:
    """``out`` is new, empty, or holds a run of the very same configuration as ``request``."""
    from simgap.record import read_run

    if overwrite or not out.exists():
        return
    if not out.is_dir():
        refuse(out, "a file")
    meta = out / "run.json"
    if not meta.exists():
        _refuse_foreign(out, "a simgap run")
        return
    try:
        held = read_run(out)
    except InputError:
        refuse(out, "a run.json that cannot be read")
    agents = {a.id: (a.history.vehicle.name, a.planner) for a in held.agents}
    there = (f"a run of {held.scenario_id} (backend {held.history.backend}, vehicle "
             f"{'+'.join(sorted({v for v, _ in agents.values()}))}, planner "
             f"{'+'.join(sorted({p for _, p in agents.values()}))})")
    if not (_same_scenario(held.settings.scenario_path, request.scenario) and held.history.backend == request.backend
            and agents == _requested_agents(request, list(agents))):
        refuse(out, there)


def _refuse_foreign(out: Path, what: str) -> None:
    """Refuse ``out`` unless it is empty (the command, writing ``what``, would replace it whole)."""
    others = sorted(p.name for p in out.iterdir())
    if others:
        more = f" (and {len(others) - 1} more)" if len(others) > 1 else ""
        refuse(out, f"{others[0]}{more}, not {what}")


def _same_scenario(path: str | None, scenario: Path) -> bool:
    return path is not None and Path(path).resolve() == Path(scenario).resolve()


def _requested_agents(request: RunRequest, ids: list[int]) -> dict[int, tuple[str, str]] | None:
    """(vehicle name, planner name) of each agent as ``request`` would run it (None: it cannot)."""
    from simgap.planning.registry import planner_of
    from simgap.vehicles import load_vehicle

    out = {}
    try:
        for aid in ids:
            ref = request.vehicles if isinstance(request.vehicles, str) else request.vehicles[aid]
            out[aid] = (load_vehicle(ref).name, planner_of(request.planner, aid, ids).name)
    except (KeyError, InputError):
        return None
    return out


def check_report_out(out: Path, overwrite: bool) -> None:
    """``out`` is new, empty, or holds a report simgap wrote: the report replaces the whole folder."""
    if overwrite or not out.exists():
        return
    from simgap.report.site import GENERATOR

    index = out / "index.html"
    if index.is_file() and GENERATOR in index.read_text(errors="replace"):
        return
    existing = [name for name in REPORT_FILES if (out / name).exists()]
    if existing:
        refuse(out, f"{existing[0]}, which simgap report did not write")
    _refuse_foreign(out, "a simgap report")


def check_pictures_out(out: Path, names: list[str], overwrite: bool) -> None:
    """``out`` holds none of the pictures ``names``, or is a run directory or a folder that
    `simgap render` drew into (their pictures are its own)."""
    existing = [name for name in names if (out / name).exists()]
    if overwrite or not existing or (out / "run.json").exists() or _drawn(out, existing):
        return
    refuse(out, f"{existing[0]}, which simgap render did not write")


def _drawn(out: Path, names: list[str]) -> bool:
    try:
        drawn = set(json.loads((out / PICTURES).read_text())["pictures"])
    except (OSError, ValueError, KeyError, TypeError):
        return False
    return set(names) <= drawn


def record_pictures(out: Path, run_dir: Path, written: list[Path]) -> None:
    """Say in ``out`` which pictures `simgap render` drew there, and of which run (not needed in
    the run directory itself)."""
    if (out / "run.json").exists():
        return
    out.mkdir(parents=True, exist_ok=True)
    try:
        earlier = set(json.loads((out / PICTURES).read_text())["pictures"])
    except (OSError, ValueError, KeyError, TypeError):
        earlier = set()
    atomic_write_text(out / PICTURES, json.dumps({"run": str(run_dir),
                                                   "pictures": sorted(earlier | {p.name for p in written})}, indent=2))


def _written_by(out: Path, command: str) -> Path:
    """The hidden file in which ``simgap COMMAND`` lists the files it wrote into ``out``."""
    return out / f".simgap-{command}.json"


def _listed(out: Path, command: str) -> set[str] | None:
    """The files ``simgap COMMAND`` says it wrote into ``out`` (None: it says nothing there)."""
    try:
        return set(json.loads(_written_by(out, command).read_text())["files"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def check_files_out(out: Path, command: str, names: list[str], overwrite: bool) -> None:
    """``out`` is new, empty (but for hidden files), or a folder ``simgap COMMAND`` wrote into, where
    of the files ``names`` it would write only those it wrote before exist: the user's folder, and
    the user's file of a name it would write, are refused (before any work) unless ``overwrite``."""
    if overwrite or not out.exists():
        return
    if not out.is_dir():
        refuse(out, "a file")
    listed = _listed(out, command)
    if listed is None:
        theirs = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
        if theirs:
            more = f" (and {len(theirs) - 1} more)" if len(theirs) > 1 else ""
            refuse(out, f"{theirs[0]}{more}, which simgap {command} did not write")
        return
    theirs = [name for name in names if (out / name).exists() and name not in listed]
    if theirs:
        refuse(out, f"{theirs[0]}, which simgap {command} did not write")


def record_files(out: Path, command: str, names: list[str]) -> None:
    """Say in ``out`` that ``simgap COMMAND`` wrote the files (or folders) ``names`` there: before it
    writes them, so a command cut short leaves a folder its rerun may write into again."""
    out.mkdir(parents=True, exist_ok=True)
    listed = _listed(out, command) or set()
    atomic_write_text(_written_by(out, command), json.dumps({"files": sorted(listed | set(names))}, indent=2))


@contextmanager
def files_out(out: Path, command: str, names: list[str], overwrite: bool) -> Iterator[None]:
    """`check_files_out`, then `record_files` of ``names``, for the block that writes them; a folder
    the block made and left holding nothing of its own (it failed) is removed again."""
    check_files_out(out, command, names, overwrite)
    made = not out.exists()
    record_files(out, command, names)
    try:
        yield
    except BaseException:
        if made and not any(p.name != _written_by(out, command).name for p in out.iterdir()):
            shutil.rmtree(out, ignore_errors=True)
        raise
