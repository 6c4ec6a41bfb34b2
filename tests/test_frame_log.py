"""``frames.csv``: every frame's decisions and pose errors, against poses whose errors are known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fogsim.data.frame import Frame
from fogsim.errors import ReportError
from fogsim.eval.frame_log import COLUMNS, FORMAT_LINE, FrameLog, read_frame_log, write_frame_log
from fogsim.eval.pose_error import FramePoseErrors, PoseErrorAccumulator
from mapper.intrinsics import PinholeIntrinsics

INTRINSICS = PinholeIntrinsics(4, 3, 4.0, 4.0, 2.0, 1.5)


def rot_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def pose(rotation: np.ndarray, translation=(0.1, 0.0, 1.0)) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = rotation
    out[:3, 3] = translation
    return out


# The true camera in the robot frame: looking along +x, 30° down (optical z forward).
LOOK = rot_y(90.0 + 30.0) @ rot_z(-90.0)
ROBOT = np.array([1.0, 2.0, 0.0, math.radians(40.0)])


def frame(index: int, camera_believed: np.ndarray, *, truth: bool = True) -> Frame:
    robot = pose(rot_z(40.0), (1.0, 2.0, 0.0))
    world_true = robot @ pose(LOOK) if truth else np.full((4, 4), np.nan)
    return Frame(
        index=index,
        time_s=index / 12.5,
        depth_m=np.ones((3, 4), dtype=np.float32),
        intrinsics=INTRINSICS,
        transform_camera_to_robot_believed=camera_believed,
        robot_pose_believed=ROBOT,
        transform_camera_to_world_true=world_true,
        robot_pose_true=ROBOT if truth else np.full(4, np.nan),
    )


def test_each_frame_gets_the_errors_its_poses_were_given():
    """Believed camera 2° of yaw and 1° of pitch off; corrected poses with known errors left."""
    believed = pose(rot_z(2.0) @ rot_y(1.0) @ LOOK)
    corrected_first = pose(rot_z(0.5) @ LOOK)  # 0.5° of yaw left, no tilt
    corrected_late = pose(rot_z(-0.25) @ rot_y(0.3) @ LOOK)  # mapped again: −0.25°, 0.3° tilt
    acc = PoseErrorAccumulator()
    acc.add(frame(0, believed))  # no corrected pose (deferred), mapped later
    acc.add(frame(1, believed), corrected_first)
    acc.add(frame(2, believed), corrected_first)
    acc.add(frame(3, believed, truth=False), corrected_first)  # no truth: nothing known
    acc.remapped(0, corrected_late)
    acc.remapped(2, corrected_late)
    errors = acc.per_frame()

    # The believed camera's rotation error: the angle of Rz(2°)·Ry(1°), from its trace.
    tr = np.trace(rot_z(2.0) @ rot_y(1.0))
    angle = math.degrees(math.acos((tr - 1.0) / 2.0))
    np.testing.assert_allclose(errors.camera_rotation_deg[:3], angle, atol=1e-9)
    np.testing.assert_allclose(errors.camera_translation_mm[:3], 0.0, atol=1e-9)
    # Believed and true robot poses agree: the world errors are the robot frame's.
    np.testing.assert_allclose(errors.world_rotation_deg[:3], angle, atol=1e-9)

    # As processed: frame 0 had no corrected pose, frames 1 and 2 +0.5°.
    assert math.isnan(errors.residual_heading_deg[0])
    np.testing.assert_allclose(errors.residual_heading_deg[1:3], 0.5, atol=1e-9)
    # As last mapped: frames 0 and 2 were mapped again with −0.25° and 0.3° of tilt.
    np.testing.assert_allclose(errors.map_heading_deg[[0, 2]], -0.25, atol=1e-3)
    np.testing.assert_allclose(errors.map_heading_deg[1], 0.5, atol=1e-9)
    np.testing.assert_allclose(errors.residual_tilt_deg[[0, 2]], 0.3, atol=1e-3)
    np.testing.assert_allclose(errors.residual_tilt_deg[1], 0.0, atol=1e-6)
    np.testing.assert_allclose(errors.world_heading_deg[:3], errors.map_heading_deg[:3], atol=1e-9)

    # No truth: every column unknown.
    assert all(math.isnan(getattr(errors, f)[3]) for f in FramePoseErrors.__dataclass_fields__)

    # The report's statistics are these columns' magnitudes over the frames processed with a
    # corrected pose (1 and 2).
    stats = acc.stats()
    assert stats.residual_heading_deg.median == pytest.approx(0.5, abs=1e-4)
    assert stats.map_heading_deg.max == pytest.approx(0.5, abs=1e-4)
    assert stats.map_heading_deg.median == pytest.approx((0.5 + 0.25) / 2, abs=1e-3)
    # The tilt left, over every frame mapped with a corrected pose (0 as last mapped too).
    tilt = stats.residual_tilt_deg
    assert (tilt.median, tilt.p95, tilt.max) == pytest.approx((0.3, 0.3, 0.3), abs=1e-3)


def small_log() -> FrameLog:
    nan = math.nan
    columns = np.array(
        [
            [3.5144422863758247, 3.1, nan],
            [7.6, 6.2, nan],
            [3.5, 3.2, nan],
            [7.6, 12.4, nan],
            [0.04150174443037956, nan, nan],
            [nan, -1.2637693542451744, nan],
            [3.8, -1.26, nan],
            [3.7, -1.3, nan],
        ]
    )
    return FrameLog(
        frame=np.array([0, 1, 7], dtype=np.int64),
        time_s=np.array([0.0, 0.08, 15.040000000000001]),
        withdrawn=np.array([True, False, False]),
        z_matched=np.array([False, True, False]),
        ground_plane_found=np.array([False, True, True]),
        pose=FramePoseErrors(*columns),
    )


def test_the_file_reads_back_bit_for_bit(tmp_path):
    log = small_log()
    path = tmp_path / "frames.csv"
    write_frame_log(path, log)
    lines = path.read_text().splitlines()
    assert lines[0] == FORMAT_LINE
    assert lines[1] == ",".join(COLUMNS)
    assert lines[2].startswith("0,0.0,1,0,0,3.5144422863758247,")
    assert lines[2].endswith(",0.04150174443037956,,3.8,3.7")  # unknown = empty
    back = read_frame_log(path)
    assert back.frame.tolist() == [0, 1, 7]
    assert back.time_s.tobytes() == log.time_s.tobytes()
    for name in ("withdrawn", "z_matched", "ground_plane_found"):
        assert getattr(back, name).tolist() == getattr(log, name).tolist()
    for name in FramePoseErrors.__dataclass_fields__:
        assert getattr(back.pose, name).tobytes() == getattr(log.pose, name).tobytes(), name


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("frame,time_s\n", "line 1 is 'frame,time_s', expected '# fogsim-frames 1'"),
        (FORMAT_LINE + "\nframe,time_s\n", "line 2 must be the header frame,time_s,withdrawn"),
        (
            FORMAT_LINE + "\n" + ",".join(COLUMNS) + "\n0,0.0,1\n",
            "line 3 has 3 values, expected 13",
        ),
        (
            FORMAT_LINE + "\n" + ",".join(COLUMNS) + "\n" + ",".join(["x"] * 13) + "\n",
            "a value is not a number",
        ),
    ],
)
def test_a_file_that_is_not_a_frame_log_is_refused_by_line(tmp_path, text, message):
    path = tmp_path / "frames.csv"
    path.write_text(text)
    with pytest.raises(ReportError, match=message.replace("(", r"\(")) as raised:
        read_frame_log(path)
    assert str(path) in str(raised.value)
