"""Errors that reach the user. The CLI prints them as one clear message and exits non-zero."""

from __future__ import annotations

import errno
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

M = TypeVar("M", bound=BaseModel)


class InputError(Exception):
    """Bad input: names the file, the field and what is allowed."""

    def __init__(self, message: str, *, file: str | Path | None = None, field: str | None = None,
                 allowed: str | None = None):
        self.file = str(file) if file is not None else None
        self.field = field
        self.allowed = allowed
        self.reason = message
        super().__init__(self.describe())

    def describe(self) -> str:
        parts = []
        if self.file:
            parts.append(self.file)
        if self.field:
            parts.append(f"field '{self.field}'")
        head = ": ".join(parts)
        text = f"{head}: {self.reason}" if head else self.reason
        if self.allowed:
            text += f" (allowed: {self.allowed})"
        return text


# failures of the machine, not of the input (what was being written is cleaned up by the atomic
# writes of `simgap.files`): the CLI says so in one line; an experiment runs such a run again
ENVIRONMENT_ERRORS = {errno.ENOSPC: "no space left on the device", errno.EDQUOT: "disk quota exceeded",
                      errno.EROFS: "the file system is read-only"}


def machine_failure(exc: BaseException) -> str | None:
    """What failed in the machine rather than in the input when ``exc`` was raised (a full disk,
    a read-only file system, no memory left), or None."""
    if isinstance(exc, MemoryError):
        return "out of memory"
    if isinstance(exc, OSError) and exc.errno in ENVIRONMENT_ERRORS:
        return ENVIRONMENT_ERRORS[exc.errno]
    return None


def _model_at(model: type[BaseModel], loc: tuple) -> type[BaseModel]:
    """The (nested) model that holds the last key of ``loc``, a pydantic error location."""
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        ann = getattr(model.model_fields.get(str(part)), "annotation", None)
        candidates = [a for a in (ann, *getattr(ann, "__args__", ()))
                      if isinstance(a, type) and issubclass(a, BaseModel)]
        if not candidates:
            break
        model = candidates[0]
    return model


def validation_error(err: ValidationError, *, file: str | Path | None = None, prefix: str | None = None,
                     model: type[BaseModel] | None = None, unknown: str | None = None,
                     allowed: str | None = None) -> InputError:
    """The project's one translation of a pydantic `ValidationError` into an `InputError`: its first
    problem, the field path (under ``prefix``), and what is allowed — a literal's choices, or, for an
    unknown key, the keys ``model`` has there (``unknown`` replaces pydantic's reason then);
    ``allowed`` says it where neither does."""
    first = err.errors()[0]
    loc = tuple(first.get("loc", ()))
    members = _union_members(err.errors())
    if members:                     # a value that is none of a union's forms: the form it was meant as, and all
        loc = loc[:-1]
        first = next((e for e in members if not _is_type_error(e)), first)
        allowed = " or ".join(dict.fromkeys(_form(e) for e in members))
    field = ".".join(str(p) for p in ((prefix,) if prefix else ()) + loc) or None
    reason = first.get("msg", str(err)).removeprefix("Value error, ")
    if members:
        if _is_type_error(first):
            reason = f"{first.get('input')!r} is none of the forms it may take"
    elif first.get("type") == "extra_forbidden" and model is not None:
        allowed = ", ".join(_model_at(model, loc).model_fields)
        reason = unknown or reason
    elif "expected" in (first.get("ctx") or {}):       # a literal's choices
        allowed = str(first["ctx"]["expected"])
    return InputError(reason, file=file, field=field, allowed=allowed)


def _union_members(errors: list[dict]) -> list[dict]:
    """The errors of the first one's value under each form of a union it is none of (pydantic tags
    each with the form, e.g. ``literal['measured']``, ``constrained-float``), or none."""
    loc = tuple(errors[0].get("loc", ()))
    if not loc or not _is_form_tag(loc[-1]):
        return []
    members = [e for e in errors if len(e.get("loc", ())) == len(loc) and tuple(e["loc"][:-1]) == loc[:-1]
               and _is_form_tag(e["loc"][-1])]
    return members if len(members) > 1 else []


def _is_form_tag(part: object) -> bool:
    return isinstance(part, str) and (not part.isidentifier() or part in ("int", "float", "str", "bool"))


def _is_type_error(error: dict) -> bool:
    """The value is not of this form at all (not a bound or a rule of it that it breaks)."""
    kind = str(error.get("type", ""))
    return kind == "literal_error" or kind.endswith(("_parsing", "_type")) or kind == "finite_number"


def _form(error: dict) -> str:
    """What one form of a union allows, from the error of a value under it."""
    tag, ctx = str(error["loc"][-1]), error.get("ctx") or {}
    if "expected" in ctx:
        return str(ctx["expected"])
    if "float" in tag or "int" in tag:
        bound = next((f" {word} {ctx[key]:g}" for key, word in (("le", "up to"), ("lt", "below"), ("ge", "from"),
                                                                  ("gt", "above")) if key in ctx), "")
        return f"a number{bound}"
    return tag


def validated(model: type[M], values: Mapping[str, Any] | None, *, file: str | Path | None = None,
              prefix: str | None = None, unknown: str | None = None) -> M:
    """``values`` validated as ``model``, or the `InputError` of `validation_error`."""
    try:
        return model.model_validate(dict(values or {}))
    except ValidationError as err:
        raise validation_error(err, file=file, prefix=prefix, model=model, unknown=unknown) from None


def validated_settings(model: type[M], values: Mapping[str, Any], prefix: str = "backend_settings") -> M:
    """A backend's settings, validated; errors name ``backend_settings.FIELD``."""
    return validated(model, values, prefix=prefix, unknown="not a setting of this backend")
