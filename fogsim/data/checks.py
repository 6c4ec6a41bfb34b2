"""Checks of per-frame poses and transforms against the data layer's limits.

Each check takes a stack of frames (a recording's arrays, or one frame and its predecessor in
the pipeline) and returns the first :class:`FrameProblem`, or None; the caller raises its own
error (:class:`~fogsim.errors.RecordingError` naming the file and array, or the pipeline's
error naming the frame). Poses are (x [m], y [m], z [m], yaw [rad]) of the robot frame in the
world; transforms are 4×4 homogeneous matrices. See :mod:`fogsim.data.limits` for the numbers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.data.limits import (
    LAST_ROW_TOLERANCE,
    MAX_ABS_YAW_RAD,
    MAX_POSE_STEP_M,
    MAX_POSITION_M,
    RIGID_TOLERANCE,
)


@dataclass(frozen=True)
class FrameProblem:
    """The first frame of a stack that breaks a rule.

    Attributes:
        row: Position of the frame in the checked stack (0 = its first frame).
        what: The value and the rule it breaks, e.g. ``"x = 1e+30 m is not within ±10000 m"``.
    """

    row: int
    what: str


def _first(bad: NDArray[np.bool_]) -> int | None:
    """Index of the first True, or None."""
    rows = np.flatnonzero(bad)
    return int(rows[0]) if rows.size else None


def _unknown(values: NDArray[np.float64], allowed: bool) -> NDArray[np.bool_]:
    """Frames whose values are all NaN, where the rule allows "unknown" (else none)."""
    flat = values.reshape(len(values), -1)
    return np.all(np.isnan(flat), axis=1) if allowed else np.zeros(len(values), dtype=bool)


def pose_problem(poses: ArrayLike, *, unknown_allowed: bool = False) -> FrameProblem | None:
    """The first pose that is not finite or lies beyond the world's limits.

    Args:
        poses: (T, 4) poses (x, y, z [m], yaw [rad]) in the world.
        unknown_allowed: A pose of four NaN means "unknown" and passes (true poses of real data).
    """
    pose = np.asarray(poses, dtype=np.float64)
    unknown = _unknown(pose, unknown_allowed)
    with np.errstate(invalid="ignore"):
        inside = np.all(np.abs(pose[:, :3]) <= MAX_POSITION_M, axis=1) & (
            np.abs(pose[:, 3]) <= MAX_ABS_YAW_RAD
        )  # NaN and inf compare False
    row = _first(~inside & ~unknown)
    if row is None:
        return None
    values = ", ".join(f"{name} = {v:.6g}" for name, v in zip("xyz", pose[row, :3], strict=True))
    allowed = f"finite, |x|, |y|, |z| <= {MAX_POSITION_M:g} m and |yaw| <= {MAX_ABS_YAW_RAD:g} rad"
    if unknown_allowed:
        allowed += " (or all four NaN: unknown)"
    return FrameProblem(row, f"{values}, yaw = {pose[row, 3]:.6g} rad: must be {allowed}")


def step_problem(positions: ArrayLike) -> FrameProblem | None:
    """The first frame whose position is more than :data:`MAX_POSE_STEP_M` from the previous.

    Args:
        positions: (T, ≥3) frames whose first three columns are x, y, z [m] in the world.
    """
    xyz = np.asarray(positions, dtype=np.float64)[:, :3]
    steps = np.linalg.norm(np.diff(xyz, axis=0), axis=1)
    row = _first(~(steps <= MAX_POSE_STEP_M))  # NaN steps are implausible too
    if row is None:
        return None
    return FrameProblem(
        row + 1,
        f"the believed position jumped {steps[row]:.6g} m from the previous frame's "
        f"({', '.join(f'{v:.6g}' for v in xyz[row])}) to "
        f"({', '.join(f'{v:.6g}' for v in xyz[row + 1])}); at most {MAX_POSE_STEP_M:g} m a "
        "frame is plausible",
    )


def transform_problem(
    transforms: ArrayLike, *, max_translation_m: float, unknown_allowed: bool = False
) -> FrameProblem | None:
    """The first transform that is not a finite rigid motion within ``max_translation_m``.

    Args:
        transforms: (T, 4, 4) homogeneous transforms.
        max_translation_m: Largest distance of the translation from the origin [m].
        unknown_allowed: A transform of sixteen NaN means "unknown" and passes.
    """
    t = np.asarray(transforms, dtype=np.float64)
    unknown = _unknown(t, unknown_allowed)
    finite = np.all(np.isfinite(t.reshape(len(t), -1)), axis=1)
    rotation = np.where(finite[:, None, None], t[:, :3, :3], np.eye(3))
    with np.errstate(over="ignore", invalid="ignore"):
        gram = rotation @ rotation.transpose(0, 2, 1) - np.eye(3)
        rules = (
            (finite, "must be finite"),
            (
                np.abs(t[:, 3] - (0.0, 0.0, 0.0, 1.0)).max(axis=1) <= LAST_ROW_TOLERANCE,
                f"last row {{last}} must be 0 0 0 1 (within {LAST_ROW_TOLERANCE:g})",
            ),
            (
                (np.abs(gram).max(axis=(1, 2)) <= RIGID_TOLERANCE) & (np.linalg.det(rotation) > 0),
                f"rotation block must be orthonormal (within {RIGID_TOLERANCE:g}) with "
                "determinant +1 (no reflection)",
            ),
            (
                np.linalg.norm(t[:, :3, 3], axis=1) <= max_translation_m,
                f"translation ({{translation}}) m must lie within {max_translation_m:g} m of "
                "the origin",
            ),
        )
    row = _first(~np.all([ok for ok, _ in rules], axis=0) & ~unknown)
    if row is None:
        return None
    rule = next(rule for ok, rule in rules if not ok[row])
    if unknown_allowed:
        rule += " (or all sixteen entries NaN: unknown)"
    last = " ".join(f"{v:.6g}" for v in t[row, 3])
    translation = ", ".join(f"{v:.6g}" for v in t[row, :3, 3])
    return FrameProblem(row, rule.format(last=last, translation=translation))


def surely_plausible(
    pose: NDArray[np.float64],
    transform: NDArray[np.float64],
    previous_pose: NDArray[np.float64] | None,
    *,
    max_translation_m: float,
) -> bool:
    """Whether one frame surely passes the pose, transform and step checks: run it first.

    The checks are :func:`pose_problem`, :func:`transform_problem` and :func:`step_problem`
    (from ``previous_pose``). Plain arithmetic on the frame's 20 numbers instead of some
    thirty numpy calls on tiny arrays (0.4 ms a frame on the pipeline's thread). True only
    with a margin no rounding comes near: position, yaw, step and translation within half
    their limits, the rotation block orthonormal within half :data:`RIGID_TOLERANCE`, its
    determinant above 1/2, the last row exactly 0 0 0 1. False means "run the checks": they
    name the problem, or find none.

    Args:
        pose: (4,) pose (x, y, z [m], yaw [rad]) in the world.
        transform: (4, 4) homogeneous transform.
        previous_pose: (4,) the previous frame's pose, or None (no step to check).
        max_translation_m: Largest distance of the transform's translation from the origin [m].
    """
    x, y, z, yaw = pose.tolist()
    if not (
        abs(x) <= 0.5 * MAX_POSITION_M
        and abs(y) <= 0.5 * MAX_POSITION_M
        and abs(z) <= 0.5 * MAX_POSITION_M
        and abs(yaw) <= 0.5 * MAX_ABS_YAW_RAD
    ):  # NaN fails too
        return False
    rows = transform.tolist()
    if rows[3] != [0.0, 0.0, 0.0, 1.0]:
        return False
    r = [row[:3] for row in rows[:3]]
    for i in range(3):
        for j in range(i, 3):
            dot = r[i][0] * r[j][0] + r[i][1] * r[j][1] + r[i][2] * r[j][2]
            if not abs(dot - (1.0 if i == j else 0.0)) <= 0.5 * RIGID_TOLERANCE:  # NaN, inf
                return False
    determinant = (
        r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0])
    )
    translation = math.hypot(rows[0][3], rows[1][3], rows[2][3])
    if not (determinant > 0.5 and translation <= 0.5 * max_translation_m):
        return False
    if previous_pose is None:
        return True
    px, py, pz = previous_pose.tolist()[:3]
    return math.hypot(x - px, y - py, z - pz) <= 0.5 * MAX_POSE_STEP_M
