"""Trajectory-tracking controllers: steering, throttle and brake from a plan and a measured state."""

from simgap.control.protocol import Command, Controller

__all__ = ["Command", "Controller"]
