"""The pipeline's heading rebuild: frames mapped before the heading's first estimate are mapped
again with it, and again when a later estimate moves more than `heading_rebuild_change_deg` or
(`heading_rebuild_on_structure`) the structure score's first estimate replaces the edge score's
(synthetic walk, exact depth, a known 3° camera yaw error), no MuJoCo."""

import math

import numpy as np
import pytest
from synthetic_depth import Box, look_down_camera, render_boxes

import fogsim.mapping.pipeline as pipeline_module
from fogsim.config import RunParams
from fogsim.config.params import PipelineParams
from fogsim.data.frame import Frame
from fogsim.errors import ParameterError
from fogsim.mapping.pipeline import Pipeline
from mapper import HeadingEstimator, HeadingParams
from mapper.heading import yaw_about_pivot
from mapper.intrinsics import PinholeIntrinsics
from mapper.transforms import planar_pose_to_matrix

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
CAMERA_IN_ROBOT = look_down_camera((0.05, 0.0, 0.9), pitch_down_deg=35.0)
YAW_ERROR_DEG = 3.0
CAMERA_BELIEVED = yaw_about_pivot(math.radians(YAW_ERROR_DEG), CAMERA_IN_ROBOT[:3, 3]) @ (
    CAMERA_IN_ROBOT
)
"""The believed camera: turned 3° (to the left) about its centre, as a neck yaw bias does."""
BOXES = (
    Box((1.6, 0.2), (0.3, 0.3, 0.25)),
    Box((1.7, 0.85), (0.3, 0.3, 0.2)),
    Box((2.3, 0.45), (0.3, 0.3, 0.3)),
)
STEP_M = 0.04
"""The robot walks along x at y = 0.5 m, 4 cm a frame (0.5 m a second at 12.5 Hz)."""
FIRST_ESTIMATE = 17
"""The frame of the heading's first estimate on this walk: the keyframes (one per 0.1 m) span
the 0.5 m baseline from frame 14 on, and the estimate comes with the 8th keyframe
(`estimate_every` 4)."""


def walk(n):
    """Exact depth of the boxes from the robot walking along x; its camera believed 3° off."""
    frames = []
    for i in range(n):
        pose = np.array([STEP_M * i, 0.5, 0.0, 0.0])
        world = planar_pose_to_matrix(pose) @ CAMERA_IN_ROBOT
        frames.append(
            Frame(
                index=i,
                time_s=i / 12.5,
                depth_m=render_boxes(INTR, world, BOXES).astype(np.float32),
                intrinsics=INTR,
                transform_camera_to_robot_believed=CAMERA_BELIEVED,
                robot_pose_believed=pose,
                transform_camera_to_world_true=world,
                robot_pose_true=pose,
            )
        )
    return frames


FRAMES = walk(FIRST_ESTIMATE + 3)


class ScriptedHeading(HeadingEstimator):
    """A heading estimator whose estimates come as scripted: frame index → correction [deg],
    or (correction [deg], whether it is the edge score's[, whether it was refined point to
    plane: True unless given])."""

    def __init__(self, script):
        super().__init__(HeadingParams())
        self._script = script
        self._seen = 0

    def observe(self, *args, **kwargs):
        if self._seen in self._script:
            step = self._script[self._seen]
            degrees, edges, *refined = step if isinstance(step, tuple) else (step, False)
            self.correction_rad = math.radians(degrees)
            self.refined = refined[0] if refined else True
            self.estimates += 1
            self.edge_estimates += edges
            self.from_edges = edges
        self._seen += 1


def run(
    rebuild_frames=300,
    heading=None,
    script=None,
    change_deg=1.0,
    on_structure=False,
    refined_only=True,
):
    pipeline = Pipeline(
        RunParams(
            pipeline=PipelineParams(
                heading_rebuild_frames=rebuild_frames,
                heading_rebuild_change_deg=change_deg,
                heading_rebuild_on_structure=on_structure,
                heading_rebuild_refined_only=refined_only,
            ),
            heading=heading if heading is not None else HeadingParams(),
        )
    )
    if script is not None:
        pipeline.heading = ScriptedHeading(script)
    for frame in FRAMES:
        pipeline.process(frame)
    pipeline.finish()
    return pipeline


def raised_cells_off_the_boxes(pipeline):
    """FOG cells 10 cm or more above the ground (box tops and sides) lying more than one cell
    (4 cm) outside every box's footprint: where a yaw error puts a box's edges."""
    types, heights = (np.asarray(a) for a in pipeline.mapper.fog())
    xy = np.asarray(pipeline.mapper.geometry.cell_centers_xy())
    raised = (types != 0) & (np.nan_to_num(heights, nan=0.0) >= 0.1)
    on_a_box = np.zeros(types.shape, dtype=bool)
    for box in BOXES:
        half_x, half_y = box.size_m[0] / 2 + 0.04, box.size_m[1] / 2 + 0.04
        on_a_box |= (np.abs(xy[..., 0] - box.center_xy_m[0]) <= half_x) & (
            np.abs(xy[..., 1] - box.center_xy_m[1]) <= half_y
        )
    return int((raised & ~on_a_box).sum()), int((raised & on_a_box).sum())


def assert_same_maps(a, b):
    for x, y in zip(a.mapper.fog(), b.mapper.fog(), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    np.testing.assert_array_equal(
        np.asarray(a.baseline.heights()), np.asarray(b.baseline.heights())
    )


@pytest.fixture(scope="module")
def rebuilt():
    return run()


def test_the_first_estimate_undoes_the_yaw_error(rebuilt):
    assert rebuilt.heading.estimates == 1  # one estimate on this walk, at FIRST_ESTIMATE
    # Within the peak band's half step (0.25°) of −3°.
    assert math.degrees(rebuilt.heading.correction_rad) == pytest.approx(-YAW_ERROR_DEG, abs=0.3)


def test_frames_mapped_before_the_first_estimate_are_mapped_again_with_it(rebuilt):
    # The first 7 frames waited for the height reference (mapped late at frame 7); frames 0-16
    # were mapped again at frame 17, when the estimate came.
    positions = [late.position for late in rebuilt.mapped_late]
    reference_wait = positions.index(0, 1)
    assert positions[:reference_wait] == list(range(reference_wait))
    assert positions[reference_wait:] == list(range(FIRST_ESTIMATE))
    for late in rebuilt.mapped_late[reference_wait:]:  # with the estimate: 3° back
        axis = late.transform_camera_to_robot[:3, 2]
        assert math.degrees(math.atan2(axis[1], axis[0])) == pytest.approx(0.0, abs=0.3)
    # The rebuilt maps are those of a run that knew the correction from its first frame.
    # The first estimate is refined point to plane (`plane_refine_estimates`): within 0.05° of
    # the true error, where the score's 0.5° candidates gave -3.25°.
    correction_deg = math.degrees(rebuilt.heading.correction_rad)
    assert correction_deg == pytest.approx(-YAW_ERROR_DEG, abs=0.05)
    known = run(heading=HeadingParams(correct_heading=False, prior_deg=correction_deg))
    assert known.heading.correction_rad == rebuilt.heading.correction_rad
    assert_same_maps(rebuilt, known)


def test_the_boxes_edges_lie_where_they_are_only_with_the_rebuild(rebuilt):
    # With the 3° error a box side 1.2-1.9 m from the camera lies 6-10 cm (1.5-2.5 cells)
    # sideways in the first 17 frames: without the rebuild their box edges stay in the map.
    off, on = raised_cells_off_the_boxes(rebuilt)
    assert off == 0 and on > 50
    off_without, _ = raised_cells_off_the_boxes(run(rebuild_frames=0))
    assert off_without >= 5


def test_no_rebuild_beyond_heading_rebuild_frames(rebuilt):
    # 17 frames were mapped before the estimate: a bound of 17 keeps them all, 16 drops them
    # (no rebuild: the maps of a run without it; nothing is kept from frame 16 on).
    assert_same_maps(run(rebuild_frames=FIRST_ESTIMATE), rebuilt)
    bounded = run(rebuild_frames=FIRST_ESTIMATE - 1)
    assert [late.position for late in bounded.mapped_late] == list(range(7))
    assert_same_maps(bounded, run(rebuild_frames=0))


def test_no_rebuild_beyond_the_bytes_kept_for_it(rebuilt, monkeypatch):
    # The frames kept for the rebuild hold their depth image, points and floor heights: a
    # budget of exactly the 17 frames' bytes keeps them all (the same maps as the rebuild), one
    # byte less drops them (the maps of a run without a rebuild).
    probe = Pipeline(RunParams())
    kept = []
    for frame in FRAMES[:FIRST_ESTIMATE]:
        probe.process(frame)
        kept.append(probe.rebuild_bytes)
    assert kept[-1] > kept[-2] > 0  # one 88 x 72 frame: more than its 25 KB depth image
    assert kept[-1] - kept[-2] > 88 * 72 * 4
    monkeypatch.setattr(pipeline_module, "MAX_REBUILD_BYTES", kept[-1])
    assert_same_maps(run(), rebuilt)
    monkeypatch.setattr(pipeline_module, "MAX_REBUILD_BYTES", kept[-1] - 1)
    bounded = run()
    assert [late.position for late in bounded.mapped_late] == list(range(7))
    assert bounded.rebuild_bytes == 0
    assert_same_maps(bounded, run(rebuild_frames=0))


def test_same_frames_same_rebuilt_maps_bit_for_bit(rebuilt):
    assert_same_maps(run(), rebuilt)


def test_an_estimate_that_moves_more_than_the_change_rebuilds_again():
    # A first estimate at frame 10 of -1°, then +1.25° at frame 14 (2.25° away): frames 0-9 are
    # mapped again at frame 10 and frames 0-13 at frame 14, with the estimate of the moment;
    # the final maps are those of a run that knew +1.25° from its first frame.
    script = {10: -1.0, 14: 1.25}
    again = run(script=script)
    positions = [late.position for late in again.mapped_late]
    reference_wait = positions.index(0, 1)  # the first frames waited for the height reference
    assert positions[reference_wait:] == [*range(10), *range(14)]
    yaws = [
        math.degrees(
            math.atan2(late.transform_camera_to_robot[1, 2], late.transform_camera_to_robot[0, 2])
        )
        for late in again.mapped_late[reference_wait:]
    ]
    believed = math.degrees(math.atan2(CAMERA_BELIEVED[1, 2], CAMERA_BELIEVED[0, 2]))
    assert yaws[:10] == pytest.approx([believed - 1.0] * 10, abs=1e-5)
    assert yaws[10:] == pytest.approx([believed + 1.25] * 14, abs=1e-5)
    known = run(heading=HeadingParams(correct_heading=False, prior_deg=1.25))
    assert_same_maps(again, known)
    # 0: only the first estimate's rebuild; a move within the change: none either.
    for once in (run(script=script, change_deg=0.0), run(script={10: -1.0, 14: -0.25})):
        positions = [late.position for late in once.mapped_late]
        assert positions[positions.index(0, 1) :] == list(range(10))
    # Beyond heading_rebuild_frames frames mapped, no more rebuilds.
    bounded = run(script=script, rebuild_frames=12)
    positions = [late.position for late in bounded.mapped_late]
    assert positions[positions.index(0, 1) :] == list(range(10))


def test_only_a_refined_estimate_rebuilds_again_unless_told_otherwise():
    # The same moves as above, but the estimate at frame 14 is the score's own (not refined
    # point to plane): with `heading_rebuild_refined_only` (the default) only frames 0-9 are
    # mapped again (at frame 10); without it, frames 0-13 once more at frame 14.
    script = {10: -1.0, 14: (1.25, False, False)}
    assert rebuilt_positions(run(script=script)) == list(range(10))
    assert rebuilt_positions(run(script=script, refined_only=False)) == [*range(10), *range(14)]
    # A refined estimate at 14 rebuilds either way.
    refined = {10: -1.0, 14: (1.25, False, True)}
    for refined_only in (True, False):
        assert rebuilt_positions(run(script=refined, refined_only=refined_only)) == [
            *range(10),
            *range(14),
        ]


def test_frames_are_kept_only_while_a_later_estimate_may_rebuild():
    # After the first estimate (frame 10) one more may be refined (`plane_refine_estimates`
    # 2): the frames are kept for it. Once the second has come (frame 14), no later estimate
    # can be refined, so with `heading_rebuild_refined_only` nothing is kept any more; without
    # it any later estimate may still rebuild, and the frames stay.
    assert run(script={10: -1.0}).rebuild_bytes > 0
    assert run(script={10: -1.0, 14: 1.25}).rebuild_bytes == 0
    assert run(script={10: -1.0, 14: 1.25}, refined_only=False).rebuild_bytes > 0
    assert run(script={10: -1.0}, change_deg=0.0).rebuild_bytes == 0  # no rebuild on change


def rebuilt_positions(pipeline):
    """Positions of the frames mapped again with the heading (after the reference's wait)."""
    positions = [late.position for late in pipeline.mapped_late]
    return positions[positions.index(0, 1) :]


def test_the_structure_scores_first_estimate_replaces_the_edge_scores_in_a_rebuild():
    # The edge score's -1° at frame 10 (the maps rebuilt with it: frames 0-9), the structure
    # score's +1.25° at frame 14: frames 0-13 are mapped again with it, and the final maps are
    # those of a run that knew +1.25° from its first frame. No change threshold (0).
    script = {10: (-1.0, True), 14: (1.25, False)}
    replaced = run(script=script, change_deg=0.0, on_structure=True)
    assert rebuilt_positions(replaced) == [*range(10), *range(14)]
    assert_same_maps(replaced, run(heading=HeadingParams(correct_heading=False, prior_deg=1.25)))
    # Off: only the first estimate's rebuild.
    assert rebuilt_positions(run(script=script, change_deg=0.0)) == list(range(10))
    # Once only: a later structure estimate, or an edge estimate after an edge estimate, or a
    # first estimate of the structure score rebuilds nothing more.
    for once in (
        {10: (-1.0, True), 12: (-0.5, True)},
        {10: (-1.0, False), 14: (1.25, False)},
    ):
        assert rebuilt_positions(run(script=once, change_deg=0.0, on_structure=True)) == list(
            range(10)
        )
    twice = run(
        script={10: (-1.0, True), 12: (1.0, False), 16: (-2.0, False)},
        change_deg=0.0,
        on_structure=True,
    )
    assert rebuilt_positions(twice) == [*range(10), *range(12)]
    # Beyond heading_rebuild_frames frames mapped, no more rebuilds.
    bounded = run(script=script, rebuild_frames=12, change_deg=0.0, on_structure=True)
    assert rebuilt_positions(bounded) == list(range(10))


@pytest.mark.parametrize("bad", [-1.0, float("inf"), float("nan")])
def test_heading_rebuild_change_deg_must_be_finite_and_not_negative(bad):
    with pytest.raises(ParameterError, match=r"PipelineParams\.heading_rebuild_change_deg"):
        PipelineParams(heading_rebuild_change_deg=bad)


@pytest.mark.parametrize("bad", [-1, 10_001, 2.0, True])
def test_heading_rebuild_frames_must_be_an_integer_in_range(bad):
    with pytest.raises(ParameterError, match=r"PipelineParams\.heading_rebuild_frames"):
        PipelineParams(heading_rebuild_frames=bad)
