"""The part of the per-frame pipeline that depends on the frames alone: segmentation and tilt.

:class:`FrameSegmenter` segments each frame's depth image (``segment_depth`` or a cache in front
of it) and rotates the result by the camera tilt filtered over the frames
(:mod:`mapper.tilt_filter`, ``pipe.use_tilt_filter``). Neither reads the maps, so a run can do
this on a second thread ahead of the mapping (:class:`~fogsim.mapping.prefetch.SegmentAhead`)
with the same results bit for bit: the filter is fed the same frames in the same order.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from fogsim.config import RunParams
from fogsim.data.frame import Frame
from mapper.segmentation import SegmentationParams, SegmentationResult, segment_depth
from mapper.tilt_filter import TiltFilter, TiltFilterParams, apply_tilt, measured_tilt
from mapper.transforms import rotation_angle_deg

SegmentFunction = Callable[..., SegmentationResult]
"""``(depth_m, intrinsics, transform_camera_to_robot, params) -> SegmentationResult``:
:func:`~mapper.segmentation.segment_depth`, or a cache in front of it (``fogsim tune``)."""

Segmented = Callable[[Frame], SegmentationResult]
"""A frame's tilt-filtered segmentation: a :class:`FrameSegmenter`, or
:meth:`~fogsim.mapping.prefetch.SegmentAhead.segmented` handing out one made ahead."""


def pipeline_segmentation_params(params: RunParams) -> SegmentationParams:
    """The segmentation parameters a run uses (its ``[segmentation]`` table, adjusted).

    With the height reference (``pipe.use_height_reference``) the segmentation's per-frame
    ground-plane shift is off: the reference replaces it.
    """
    if params.pipeline.use_height_reference:
        return replace(params.segmentation, correct_ground_shift=False)
    return params.segmentation


class FrameSegmenter:
    """Segments frames and filters their tilt; call it on every frame of a run, in order.

    Args:
        params: The run's parameters.
        segment: The segmentation, called with the frame's depth, intrinsics, believed camera
            transform and :attr:`segmentation_params`, and nothing else; its result is only
            read, so a cache may hand out the same result again (:mod:`fogsim.tune.segment_cache`).

    Attributes:
        segmentation_params: What ``segment`` is called with (:func:`pipeline_segmentation_params`).
        tilt: The tilt filter; None when ``pipe.use_tilt_filter`` or the segmentation's own tilt
            correction is off (the segmentation's result is then handed out as it is).
    """

    def __init__(self, params: RunParams, segment: SegmentFunction = segment_depth) -> None:
        self._segment = segment
        self.segmentation_params = pipeline_segmentation_params(params)
        pipe = params.pipeline
        self.tilt = (
            TiltFilter(
                TiltFilterParams(
                    pipe.tilt_noise_deg,
                    pipe.tilt_bias_deg,
                    tail_dof=pipe.tilt_tail_dof,
                )
            )
            if pipe.use_tilt_filter and self.segmentation_params.correct_tilt
            else None
        )
        # The believed camera rotations of the last `pipe.tilt_turn_frames` frames.
        self._camera_rotations: deque[NDArray[np.float64]] = deque(maxlen=pipe.tilt_turn_frames)

    def __call__(self, frame: Frame) -> SegmentationResult:
        """The frame's segmentation, rotated by the tilt filtered up to this frame."""
        seg = self._segment(
            frame.depth_m,
            frame.intrinsics,
            frame.transform_camera_to_robot_believed,
            self.segmentation_params,
        )
        if self.tilt is None:
            return seg
        return self._filtered_tilt(seg, frame)

    def _filtered_tilt(self, seg: SegmentationResult, frame: Frame) -> SegmentationResult:
        """``seg`` rotated by the tilt filtered over frames (`mapper.tilt_filter`).

        The filter's process noise scales with the believed camera's turn in the robot frame
        per frame (the neck bias's effect turns with the neck), taken over the last
        ``pipe.tilt_turn_frames`` frames (fewer at the start).
        """
        assert self.tilt is not None
        rotation = np.asarray(frame.transform_camera_to_robot_believed, dtype=np.float64)[:3, :3]
        rotations = self._camera_rotations
        turn_rad = (
            math.radians(rotation_angle_deg(rotations[0].T @ rotation)) / len(rotations)
            if rotations
            else 0.0
        )
        rotations.append(rotation)
        measured, sigma_rad = measured_tilt(seg, self.segmentation_params)
        return apply_tilt(seg, self.tilt.update(measured, sigma_rad, turn_rad).tilt_rad)
