"""Route application: each route step becomes one command of the footstep planner.

A route step is a mapping or an object (``fogsim.config.RouteStep``) with exactly one
of ``walk_to: (x [m], y [m])``, ``turn_to: yaw [deg]``, ``look: (yaw [deg], pitch [deg])``
(head relative to the body, positive yaw = left, negative pitch = down) or ``wait: seconds``.

Every step is checked before anything is planned (:func:`route_commands`: one command, finite
numbers), and each step's duration before the step is planned (:func:`apply_route`: a lower
bound of the time it takes against the walk's :class:`FrameBudget`). Errors name the step as
the scenario file does: ``route[3] (walk_to 1.5, 0.5)``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from fogsim.errors import RouteError
from fogsim.robot.walking.footsteps import FootstepPlanner

ROUTE_KEYS = ("walk_to", "turn_to", "look", "wait")
"""The route commands; a step has exactly one of them."""
_ARITY = {"walk_to": 2, "turn_to": 1, "look": 2, "wait": 1}
"""How many numbers each command takes."""


class RouteStepLike(Protocol):
    """A route step given as an object: exactly one attribute is not None."""

    walk_to: tuple[float, float] | None
    turn_to: float | None
    look: tuple[float, float] | None
    wait: float | None


RouteStepInput = RouteStepLike | Mapping[str, object]
"""A route step as an object or as a mapping (a TOML table)."""


@dataclass(frozen=True)
class RouteCommand:
    """One checked route step.

    Attributes:
        index: Position in the route (``route[index]`` of the scenario file).
        kind: One of ``ROUTE_KEYS``.
        values: ``walk_to``: (x, y) [m]; ``turn_to``: (yaw,) [deg]; ``look``: (yaw, pitch)
            [deg]; ``wait``: (seconds,). Finite.
    """

    index: int
    kind: str
    values: tuple[float, ...]

    def __str__(self) -> str:
        return f"route[{self.index}] ({self.kind} {', '.join(f'{v:g}' for v in self.values)})"


@dataclass(frozen=True)
class FrameBudget:
    """How long a walk may last: at most ``max_frames`` samples at ``frame_rate_hz``.

    Attributes:
        frame_rate_hz: Sample rate of the walk [Hz].
        max_frames: Most samples (``fogsim.robot.walking.limits.MAX_TRAJECTORY_FRAMES``).
        final_stand_s: The stand after the route [s] (it counts against the budget).
    """

    frame_rate_hz: float
    max_frames: int
    final_stand_s: float

    @property
    def route_end_s(self) -> float:
        """Latest time [s] the route's last step may end."""
        return (self.max_frames - 1) / self.frame_rate_hz - self.final_stand_s

    def refusal(self, duration_s: float) -> str:
        """Why a walk of ``duration_s`` [s] (final stand included) is refused."""
        frames = math.floor(duration_s * self.frame_rate_hz) + 1
        return (
            f"the walk would last {duration_s:.1f} s or more, {frames} frames at "
            f"{self.frame_rate_hz:g} Hz; at most {self.max_frames} frames "
            f"({(self.max_frames - 1) / self.frame_rate_hz:.1f} s at this rate) are allowed"
        )


def route_commands(route_steps: Sequence[RouteStepInput], origin: str) -> tuple[RouteCommand, ...]:
    """Check every route step and return its command.

    Args:
        route_steps: The route.
        origin: How messages name the route's origin (the scenario file).

    Raises:
        RouteError: A step without exactly one command, or with a value that is not the right
            count of finite numbers, or a wait that is not > 0 s (the message names the step).
    """
    commands = []
    for index, step in enumerate(route_steps):
        present = {k: _route_field(step, k) for k in ROUTE_KEYS}
        present = {k: v for k, v in present.items() if v is not None}
        if len(present) != 1:
            raise RouteError(
                f"{origin}: route[{index}]: must have exactly one of {', '.join(ROUTE_KEYS)}; "
                f"got {sorted(present) or 'none'}"
            )
        ((kind, value),) = present.items()
        values = _numbers(value, _ARITY[kind])
        if values is None:
            raise RouteError(
                f"{origin}: route[{index}]: {kind} has a malformed value {value!r}; it must be "
                f"{_ARITY[kind]} finite number(s)"
            )
        if kind == "wait" and not values[0] > 0.0:
            raise RouteError(f"{origin}: route[{index}]: wait must be > 0 s, got {value}")
        commands.append(RouteCommand(index, kind, values))
    return tuple(commands)


def apply_route(
    planner: FootstepPlanner, commands: Sequence[RouteCommand], budget: FrameBudget, origin: str
) -> None:
    """Plan each route command on the planner, in order, within the frame budget.

    Before a step is planned, a lower bound of its duration is checked against the budget
    (exact for ``turn_to``, ``look`` and ``wait``; see
    :meth:`FootstepPlanner.min_walk_duration_s`); after, the time it really took.

    Args:
        planner: The footstep planner (feet down at the start).
        commands: The checked route (:func:`route_commands`).
        budget: How long the walk may last.
        origin: How messages name the route's origin (the scenario file).

    Raises:
        RouteError: A step the terrain leaves no footstep for, or one that would make the walk
            longer than the budget; the message names ``origin``, the step and its values.
    """
    for command in commands:
        planner.route_step = command.index
        end_s = planner.time_s + _min_duration_s(planner, command)
        if end_s > budget.route_end_s:
            raise RouteError(f"{origin}: {command}: {budget.refusal(end_s + budget.final_stand_s)}")
        try:
            _run(planner, command)
        except RouteError as error:
            raise RouteError(f"{origin}: {command}: {error}") from error
        if planner.time_s > budget.route_end_s:
            raise RouteError(
                f"{origin}: {command}: {budget.refusal(planner.time_s + budget.final_stand_s)}"
            )
    planner.route_step = None


def _numbers(value: object, count: int) -> tuple[float, ...] | None:
    """``value`` as ``count`` finite floats (one number or a sequence), None if it is not."""
    try:
        values = tuple(float(v) for v in value) if count > 1 else (float(value),)  # type: ignore[attr-defined, arg-type]
    except (TypeError, ValueError, OverflowError):
        return None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        return None
    return values


def _min_duration_s(planner: FootstepPlanner, command: RouteCommand) -> float:
    """A lower bound of how long ``command`` takes from the planner's state [s]."""
    values = command.values
    if command.kind == "walk_to":
        return planner.min_walk_duration_s(values[0], values[1])
    if command.kind == "turn_to":
        return planner.turn_duration_s(math.radians(values[0]))
    if command.kind == "look":
        return planner.params.look_transition_s
    return values[0]


def _run(planner: FootstepPlanner, command: RouteCommand) -> None:
    """Plan ``command`` on the planner."""
    values = command.values
    if command.kind == "walk_to":
        planner.walk_to(values[0], values[1])
    elif command.kind == "turn_to":
        planner.turn_to(math.radians(values[0]))
    elif command.kind == "look":
        planner.look_at(values[0], values[1])
    else:
        planner.wait(values[0])


def _route_field(step: RouteStepInput, key: str) -> object:
    """The value of ``key`` in a step (None if absent): user data, checked by the caller."""
    if isinstance(step, Mapping):
        return step.get(key)
    return getattr(step, key, None)
