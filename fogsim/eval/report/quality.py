"""The quality gate: whether a run's figures can be trusted at all.

A run is *poor* when one of the limits below is crossed; :class:`Quality` lists one reason per
crossed limit, the console prints each as a WARNING line, and ``--strict`` fails the run.
"""

from __future__ import annotations

from fogsim.eval.report.schema import ArchiveScores, Quality
from fogsim.eval.rounding import fraction

MAX_WITHDRAWN_FRACTION = 0.2
"""More withdrawn frames than this share make a run poor. The z-match rule (Sec. IV) withdraws
a frame only when it finds neither a floor match nor a ground plane: a good run withdraws a few
frames where it turns its head away; when a fifth of the frames are dropped the map misses whole
stretches of the route."""
MAX_NO_GROUND_PLANE_FRACTION = 0.5
"""Without z matching, more frames without a ground plane than this share make a run poor: the
ground plane is then a frame's only height reference (Sec. IV), and a map built mostly from
unreferenced frames carries the odometry's height drift. With z matching on (the default) a
frame without a ground plane is either z-matched to the map — fine — or withdrawn, which
:data:`MAX_WITHDRAWN_FRACTION` limits: the share alone does not tell a poor run. Measured: the
stage's depth run (seed 1) has 420 of 778 frames (54 %) without a ground plane, every one of
them z-matched (the robot on the upper steps and the platform finds no plane at its feet's
height in view), and a good map; the stereo run of seed 2 has 553 (71 %), all withdrawn."""
MIN_FLOOR_RIGHT_FRACTION = 0.5
"""A run whose seen true floor is labelled floor at the right height (within the safety
tolerance, ``safety.height_tolerance_mm``) in less than this share is poor: then the map is wrong
more often than right where a robot would walk."""


def floor_right_fraction(scores: ArchiveScores) -> float | None:
    """Of the seen true-floor cells, the share the FOG labels floor within the safety tolerance.

    None when no seen cell is true floor.
    """
    floor = scores.cells.fog.classes.floor
    right = floor.true_positive - scores.safety.floor_height_off
    return fraction(right, floor.truth_seen)


def assess_quality(
    *,
    frames: int,
    withdrawn: int,
    frames_without_ground_plane: int,
    z_match: bool,
    map_empty: bool,
    scores: ArchiveScores | None,
) -> Quality:
    """The quality block of a run's report (the limits are this module's constants).

    Args:
        frames: Frames processed (> 0).
        withdrawn: Frames withdrawn by the z-match rule.
        frames_without_ground_plane: Frames whose segmentation found no ground plane.
        z_match: The pipeline z-matched frames to the map (``pipe.use_z_match``).
        map_empty: The FOG labelled no cell in the whole run.
        scores: The run's figures against the truth (None without ground truth: the floor is
            then not judged).
    """
    withdrawn_share = withdrawn / frames
    no_ground_share = frames_without_ground_plane / frames
    floor_right = floor_right_fraction(scores) if scores is not None else None
    reasons = []
    if withdrawn_share > MAX_WITHDRAWN_FRACTION:
        reasons.append(
            f"{withdrawn} of {frames} frames ({100 * withdrawn_share:.1f} %) were withdrawn by "
            f"the z-match rule (limit {100 * MAX_WITHDRAWN_FRACTION:.0f} %)"
        )
    if not z_match and no_ground_share > MAX_NO_GROUND_PLANE_FRACTION:
        reasons.append(
            f"{frames_without_ground_plane} of {frames} frames ({100 * no_ground_share:.1f} %) "
            f"had no ground plane and z matching is off "
            f"(limit {100 * MAX_NO_GROUND_PLANE_FRACTION:.0f} %)"
        )
    if map_empty:
        reasons.append("the map is empty: the FOG labelled no cell floor or obstacle")
    if scores is not None and floor_right is not None and floor_right < MIN_FLOOR_RIGHT_FRACTION:
        reasons.append(
            f"only {100 * floor_right:.1f} % of the seen floor is floor within "
            f"{scores.safety.height_tolerance_mm:.0f} mm of the truth "
            f"(limit {100 * MIN_FLOOR_RIGHT_FRACTION:.0f} %)"
        )
    return Quality(
        withdrawn_fraction=float(fraction(withdrawn, frames)),
        frames_without_ground_plane=int(frames_without_ground_plane),
        map_empty=bool(map_empty),
        floor_right_fraction=floor_right,
        poor=bool(reasons),
        reasons=tuple(reasons),
    )
