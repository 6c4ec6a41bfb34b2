"""Route application: each route step becomes one command of the footstep planner.

A route step is a mapping or an object (``fogsim.config.RouteStep``) with exactly one
of ``walk_to: (x [m], y [m])``, ``turn_to: yaw [deg]``, ``look: (yaw [deg], pitch [deg])``
(head relative to the body, positive yaw = left, negative pitch = down) or ``wait: seconds``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Protocol

from fogsim.errors import RouteError
from fogsim.robot.walking.footsteps import FootstepPlanner

ROUTE_KEYS = ("walk_to", "turn_to", "look", "wait")
"""The route commands; a step has exactly one of them."""


class RouteStepLike(Protocol):
    """A route step given as an object: exactly one attribute is not None."""

    walk_to: tuple[float, float] | None
    turn_to: float | None
    look: tuple[float, float] | None
    wait: float | None


RouteStepInput = RouteStepLike | Mapping[str, object]
"""A route step as an object or as a mapping (a TOML table)."""


def apply_route(planner: FootstepPlanner, route_steps: Sequence[RouteStepInput]) -> None:
    """Run each route step on the planner, in order.

    Raises:
        RouteError: A step without exactly one command, or with a malformed value (the message
            names the step's index and key).
    """
    for index, step in enumerate(route_steps):
        present = {k: _route_field(step, k) for k in ROUTE_KEYS}
        present = {k: v for k, v in present.items() if v is not None}
        if len(present) != 1:
            raise RouteError(
                f"route step {index} must have exactly one of {', '.join(ROUTE_KEYS)}; "
                f"got {sorted(present) or 'none'}"
            )
        ((key, value),) = present.items()
        try:
            if key == "walk_to":
                x, y = (float(v) for v in value)
                planner.walk_to(x, y)
            elif key == "turn_to":
                planner.turn_to(math.radians(float(value)))
            elif key == "look":
                yaw, pitch = (float(v) for v in value)
                planner.look_at(yaw, pitch)
            else:
                seconds = float(value)
                if not seconds > 0.0:
                    raise RouteError(f"route step {index}: wait must be > 0 s, got {value}")
                planner.wait(seconds)
        except (TypeError, ValueError) as error:
            if isinstance(error, RouteError):
                raise
            raise RouteError(
                f"route step {index}: {key} has a malformed value {value!r} ({error})"
            ) from error


def _route_field(step: RouteStepInput, key: str) -> object:
    """The value of ``key`` in a step (None if absent): user data, checked by the caller."""
    if isinstance(step, Mapping):
        return step.get(key)
    return getattr(step, key, None)
