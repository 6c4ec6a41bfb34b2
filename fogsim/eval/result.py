"""What a run produced: the typed result the report, the pictures and the suite read."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.config import RunParams
from fogsim.eval.archive import WorldArchive
from fogsim.eval.frame_log import FrameLog
from fogsim.eval.report.schema import ArchiveScores, EventResult, PoseErrorStats
from fogsim.world.truth import GroundTruthGrid
from mapper import AveragingMap, FloorObstacleMapper


@dataclass(frozen=True)
class Snapshot:
    """Both maps at one frame (for Fig. 5).

    Attributes:
        label: What the snapshot shows (``"before"`` / ``"after"``).
        frame_index: Frame number.
        time_s: Frame time [s].
        cell_centers_xy: (nx, ny, 2) world cell centres [m].
        fog_types: (nx, ny) CellType values.
        fog_heights_m: (nx, ny) FOG heights [m], NaN = none.
        baseline_heights_m: (nx, ny) averaging-baseline heights [m], NaN = none.
        depth_m: The frame's depth image [m].
    """

    label: str
    frame_index: int
    time_s: float
    cell_centers_xy: NDArray[np.float64]
    fog_types: NDArray[np.int8]
    fog_heights_m: NDArray[np.float64]
    baseline_heights_m: NDArray[np.float64]
    depth_m: NDArray[np.float32]


@dataclass(frozen=True)
class RunResult:
    """Everything a run produced (:func:`fogsim.eval.report.build_report` makes the report of it).

    Attributes:
        frames: Frames processed.
        withdrawn: Frames withdrawn by the z-match rule.
        z_matched: Frames whose data were shifted by an accepted z match.
        frames_without_ground_plane: Frames whose segmentation found no ground plane.
        update_ms: (frames,) time of ``FloorObstacleMapper.update`` per frame [ms], NaN for a
            withdrawn frame.
        segmentation_ms: (frames,) time of ``segment_depth`` per frame [ms].
        frame_ms: (frames,) whole pipeline time per frame, scoring excluded [ms].
        wall_s: Wall time of the whole run incl. scoring [s].
        mapper: The final mapper.
        baseline: The final averaging baseline.
        archive: World-fixed archive of both maps.
        scores: Every figure of the archive against the final truth (None without ground
            truth).
        events: One result per removed or moved object (empty without ground truth).
        pose_error: Believed-vs-true camera pose error statistics.
        params: The parameters used.
        snapshots: Snapshots for Fig. 5 (event scenarios only).
        final_truth: Ground truth of the final world on the archive's cells (what the scores
            and ``maps.npz`` compare against), or None.
        last_depth_m: Depth image of the last frame [m].
        frame_log: Every frame's decisions and pose errors (``frames.csv``), or None.
    """

    frames: int
    withdrawn: int
    z_matched: int
    frames_without_ground_plane: int
    update_ms: NDArray[np.float64]
    segmentation_ms: NDArray[np.float64]
    frame_ms: NDArray[np.float64]
    wall_s: float
    mapper: FloorObstacleMapper
    baseline: AveragingMap
    archive: WorldArchive
    scores: ArchiveScores | None
    events: tuple[EventResult, ...]
    pose_error: PoseErrorStats
    params: RunParams
    snapshots: tuple[Snapshot, ...] = ()
    final_truth: GroundTruthGrid | None = None
    last_depth_m: NDArray[np.float32] | None = None
    frame_log: FrameLog | None = None
