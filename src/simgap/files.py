"""The project's file handling in one place: every file is written atomically (a temporary file
beside it, then a rename, so a reader never sees half of one), and every YAML input is read as a
mapping and validated by a pydantic model, with errors that name the file and the field."""

from __future__ import annotations

import os
import shutil
import tempfile
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator, TypeVar

import yaml
from pydantic import BaseModel

from simgap.errors import InputError, validated

M = TypeVar("M", bound=BaseModel)


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


def read_yaml_mapping(path: str | Path, what: str, keys: str | None = None, empty_ok: bool = False
                      ) -> dict[str, Any]:
    """The YAML mapping in ``path`` (an empty file too, if ``empty_ok``), or an `InputError` naming
    the file (``what``: the kind of file; ``keys``: what such a mapping holds)."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except OSError as exc:
        raise InputError(f"cannot read the {what}: {exc.strerror}", file=path) from None
    except yaml.YAMLError as exc:
        raise InputError(f"malformed YAML: {exc}", file=path) from None
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


@contextmanager
def staged_directory(parent: str | Path, name: str = "staged") -> Iterator[Path]:
    """A hidden directory in ``parent`` to build several files in before any of them is moved
    into place (by the caller, each with an `os.replace`); removed afterwards with whatever was
    left in it, so a failure leaves nothing half-written."""
    parent = Path(parent)
    parent.mkdir(parents=True, exist_ok=True)
    path = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".tmp", dir=parent))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)


def replace_directory(staged: Path, target: Path) -> Path:
    """Move the directory ``staged`` to ``target``, replacing a directory there (the old one is
    moved aside first, then removed)."""
    if target.exists():
        old = target.with_name(f".{target.name}.{uuid.uuid4().hex[:8]}.old")
        os.replace(target, old)
        os.replace(staged, target)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(staged, target)
    return target
