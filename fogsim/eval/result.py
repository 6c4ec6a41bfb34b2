"""What a run produced: the typed result the report, the pictures and the suite read."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fogsim.eval.scoring import WorldArchive


@dataclass
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


@dataclass
class RunResult:
    """Everything a run produced (the report is assembled from it by :mod:`fogsim.eval.report`).

    Attributes:
        frames: Frames processed.
        withdrawn: Frames withdrawn by the z-match rule.
        z_matched: Frames whose data were shifted by an accepted z match.
        update_ms: (frames,) time of ``FloorObstacleMapper.update`` per applied frame [ms].
        segmentation_ms: (frames,) time of ``segment_depth`` per frame [ms].
        frame_ms: (frames,) whole pipeline time per frame, scoring excluded [ms].
        wall_s: Wall time of the whole run incl. scoring [s].
        mapper: The final FloorObstacleMapper.
        baseline: The final AveragingMap.
        archive: World-fixed archive of both maps.
        scores: ``{"table1", "cells"}`` from :func:`fogsim.eval.scoring.score_archive`, None without
            ground truth.
        events: Per-event results of :class:`fogsim.eval.scoring.EventTracker`.
        pose_error: Believed-vs-true camera pose error statistics.
        params: ``{"mapper", "segmentation", "elevation", "pipeline"}`` parameters used.
        snapshots: Snapshots for Fig. 5 (event scenarios only).
        final_truth: ``GroundTruthGrid`` of the final world on the final grid, or None.
        last_depth_m: Depth image of the last frame.
    """

    frames: int
    withdrawn: int
    z_matched: int
    update_ms: NDArray[np.float64]
    segmentation_ms: NDArray[np.float64]
    frame_ms: NDArray[np.float64]
    wall_s: float
    mapper: Any
    baseline: Any
    archive: WorldArchive
    scores: dict | None
    events: list[dict]
    pose_error: dict
    params: dict
    snapshots: list[Snapshot] = field(default_factory=list)
    final_truth: Any | None = None
    last_depth_m: NDArray[np.float32] | None = None
