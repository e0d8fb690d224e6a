"""MuJoCo and the user's ``MUJOCO_GL``: MuJoCo reads the variable when it is first imported and
refuses a value it does not know with a RuntimeError, for physics without pictures too."""

from __future__ import annotations

from pydantic import BaseModel

from simgap.errors import InputError


def check_mujoco_gl(settings: BaseModel | None = None) -> None:
    """Refuse, before any work, a ``MUJOCO_GL`` with which MuJoCo cannot be imported (``settings``:
    the backend's, unused, as the registry's checks take them)."""
    try:
        import mujoco  # noqa: F401
    except RuntimeError as exc:
        raise InputError(f"MuJoCo does not start: {exc}", field="MUJOCO_GL",
                         allowed="egl (simgap's default), osmesa or glx; glfw with a display") from None
