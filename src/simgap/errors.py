"""Errors that reach the user. The CLI prints them as one clear message and exits non-zero."""

from __future__ import annotations

from pathlib import Path


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


def pydantic_to_input_error(err, file: str | Path | None) -> InputError:
    """Turn the first problem of a pydantic ValidationError into an InputError."""
    first = err.errors()[0]
    field = ".".join(str(p) for p in first.get("loc", ()))
    msg = first.get("msg", str(err))
    allowed = None
    ctx = first.get("ctx") or {}
    if "expected" in ctx:
        allowed = str(ctx["expected"])
    return InputError(msg, file=file, field=field or None, allowed=allowed)


def validated_settings(model, values: dict, prefix: str = "backend_settings"):
    """``model(**values)``, or an InputError naming ``prefix.FIELD`` and, for an unknown key, the
    keys ``model`` has."""
    from pydantic import ValidationError

    try:
        return model(**values)
    except ValidationError as err:
        error = pydantic_to_input_error(err, None)
        extra = err.errors()[0].get("type") == "extra_forbidden"
        allowed = ", ".join(model.model_fields) if extra else error.allowed
        raise InputError(error.reason, field=f"{prefix}.{error.field}", allowed=allowed) from None
