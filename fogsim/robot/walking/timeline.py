"""The walk as a timeline of segments (one foot steps, or both stand), sampled at any time.

Foot poses are sole-origin poses (x, y, z [m], yaw [rad]) in the world; head looks are
(yaw, pitch) [deg] relative to the body.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.robot.kinematics import Stance
from fogsim.robot.planar import wrap_angle

_LIFT_END = 0.35
"""Swing phase by which the foot has risen to the apex height."""
_LOWER_START = 0.75
"""Swing phase from which the foot comes down onto its target surface."""
_TRAVEL_START = 0.1
"""Swing phase at which the foot starts moving towards its target (after lifting off)."""
_TRAVEL_LENGTH = 0.65
"""Swing phases the forward travel takes (it ends at 0.75, before the foot lands)."""


@dataclass(frozen=True)
class Segment:
    """A stretch of the timeline: a step of one foot, or standing still.

    Attributes:
        start_s: Start time [s].
        duration_s: Duration [s].
        swing: The foot that steps, or None when both feet stand.
        left_from: Left sole pose at the start.
        left_to: Left sole pose at the end.
        right_from: Right sole pose at the start.
        right_to: Right sole pose at the end.
        apex_z: Height the swing sole passes at [m] (unused when standing).
        look_from: Head look at the start [deg].
        look_to: Head look at the end [deg].
        route_step: Index of the route step that made the segment; None for the stands
            before and after the route.
    """

    start_s: float
    duration_s: float
    swing: Stance | None
    left_from: NDArray[np.float64]
    left_to: NDArray[np.float64]
    right_from: NDArray[np.float64]
    right_to: NDArray[np.float64]
    apex_z: float
    look_from: NDArray[np.float64]
    look_to: NDArray[np.float64]
    route_step: int | None


@dataclass(frozen=True)
class SegmentSample:
    """The feet and the head at one time of a segment.

    Attributes:
        left: Left sole pose.
        right: Right sole pose.
        left_surface_m: Height of the surface under the left foot (interpolated in swing) [m].
        right_surface_m: Height of the surface under the right foot [m].
        phase: Swing phase in [0, 1] (0 when both feet are down).
        support: The stance foot while the other swings, None when both feet are down.
        look_deg: Head look [deg].
    """

    left: NDArray[np.float64]
    right: NDArray[np.float64]
    left_surface_m: float
    right_surface_m: float
    phase: float
    support: Stance | None
    look_deg: NDArray[np.float64]


def smoothstep(x: float) -> float:
    """3x² - 2x³ of ``x`` clipped to [0, 1]: 0 → 0 and 1 → 1 with zero slope at both ends."""
    x = min(1.0, max(0.0, x))
    return x * x * (3.0 - 2.0 * x)


def sample_segment(
    segment: Segment, time_s: float, double_support_fraction: float
) -> SegmentSample:
    """Foot poses, surface heights, swing phase, support foot and look at a time in a segment.

    Args:
        segment: The segment.
        time_s: The time [s], clipped to the segment.
        double_support_fraction: Fraction of a step's duration with both feet down (at its start).
    """
    seg = segment
    rel = min(max(time_s - seg.start_s, 0.0), seg.duration_s)
    if seg.swing is None:
        look = seg.look_from + smoothstep(rel / seg.duration_s) * (seg.look_to - seg.look_from)
        return SegmentSample(
            seg.left_to, seg.right_to, seg.left_to[2], seg.right_to[2], 0.0, None, look
        )
    ds = double_support_fraction * seg.duration_s
    if rel <= ds:
        return SegmentSample(
            seg.left_from,
            seg.right_from,
            seg.left_from[2],
            seg.right_from[2],
            0.0,
            None,
            seg.look_to,
        )
    phase = (rel - ds) / (seg.duration_s - ds)
    start = seg.left_from if seg.swing == Stance.LEFT else seg.right_from
    end = seg.left_to if seg.swing == Stance.LEFT else seg.right_to
    travel = smoothstep((phase - _TRAVEL_START) / _TRAVEL_LENGTH)
    pose = start + travel * (end - start)
    pose[3] = start[3] + travel * wrap_angle(end[3] - start[3])
    if phase < _LIFT_END:
        pose[2] = start[2] + smoothstep(phase / _LIFT_END) * (seg.apex_z - start[2])
    elif phase > _LOWER_START:
        pose[2] = seg.apex_z + smoothstep((phase - _LOWER_START) / (1.0 - _LOWER_START)) * (
            end[2] - seg.apex_z
        )
    else:
        pose[2] = seg.apex_z
    surface = start[2] + smoothstep(phase) * (end[2] - start[2])
    if seg.swing == Stance.LEFT:
        return SegmentSample(
            pose, seg.right_from, surface, seg.right_from[2], phase, Stance.RIGHT, seg.look_to
        )
    return SegmentSample(
        seg.left_from, pose, seg.left_from[2], surface, phase, Stance.LEFT, seg.look_to
    )
