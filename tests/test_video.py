"""run.mp4 read back: codec, frame count, size and known pixels of each panel; the third-person
camera on a tiny scene with known geometry; a short simulated run with the video on.

H.264 needs PyAV (the ``av`` package); its tests are skipped without it, the MPEG-4 Part 2
fallback is tested with PyAV hidden.
"""

from __future__ import annotations

import sys

import cv2
import matplotlib.pyplot as plt
import mujoco
import numpy as np
import pytest
from matplotlib.colors import Normalize

from fogsim.config import load_scenario
from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.run.runner import run_scenario
from fogsim.sim.third_person import VIEW_PX, ThirdPersonCamera, robot_root_body
from fogsim.viz.style import UNKNOWN_RGB
from fogsim.viz.video import FOG_HEIGHTS_MM, H264_ENCODERS, RunVideoWriter, video_codec
from mapper.grid import CellType
from mapper.intrinsics import PinholeIntrinsics

INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
FPS = 12.5
FRAMES = 4
NX, NY = 5, 4  # FOG grid: 5 cells along x, 4 along y → panel 450 × 360
VIEW_RGB = (30, 160, 60)  # the stand-in third-person picture: one colour
FLOOR_HEIGHT_M = 0.065  # a floor cell's height: viridis at (65 + 20) / 170 = 0.5
TOLERANCE = 12  # grey levels a lossy codec may move a flat block's colour


def frame(index: int) -> Frame:
    depth = np.full(INTR.shape, 2.0, dtype=np.float32)  # 2 m: half way to DEPTH_SPAN_M
    depth[:, : INTR.width // 2] = np.nan  # left half unmeasured: black
    return Frame(
        index=index,
        time_s=index / FPS,
        depth_m=depth,
        intrinsics=INTR,
        transform_camera_to_robot_believed=np.eye(4),
        robot_pose_believed=np.zeros(4),
        transform_camera_to_world_true=None,
        robot_pose_true=None,
    )


class FakePipeline:
    """What the writer reads of a pipeline: the FOG of the robot-centred grid."""

    def maps(self):
        types = np.full((NX, NY), CellType.FLOOR, dtype=np.int8)
        types[0, 0] = CellType.OBSTACLE  # x 0, y 0: bottom left
        types[NX - 1, NY - 1] = CellType.UNKNOWN  # top right
        return types, np.full((NX, NY), FLOOR_HEIGHT_M), None


def view(index: int) -> np.ndarray:
    return np.broadcast_to(np.array(VIEW_RGB, np.uint8), (*VIEW_PX[::-1], 3)).copy()


def write_video(path, third_person=view, frames=FRAMES):
    writer = RunVideoWriter(path, FPS, third_person=third_person)
    for i in range(frames):
        writer.add(frame(i), FakePipeline())
    assert not path.exists()  # written beside it, moved into place when closed
    writer.close()
    return writer


def read_with_opencv(path):
    """(fourcc, pictures as RGB)."""
    capture = cv2.VideoCapture(str(path))
    fourcc = int(capture.get(cv2.CAP_PROP_FOURCC)).to_bytes(4, "little").decode()
    pictures = []
    while True:
        ok, bgr = capture.read()
        if not ok:
            break
        pictures.append(bgr[:, :, ::-1])
    capture.release()
    return fourcc, pictures


def sample_entry(path) -> str:
    """The four-character code of the MP4's first sample entry (``stsd`` box): the codec as
    the file declares it, ``avc1`` (H.264) or ``mp4v`` (MPEG-4 Part 2), read from its bytes."""
    data = path.read_bytes()
    stsd = data.find(b"stsd")  # then version/flags, entry count, the entry's size and type
    return data[stsd + 16 : stsd + 20].decode()


def expected_pixels(picture):
    """Known pixels of every panel: (row, column) → RGB."""
    depth_left = 480  # the third-person panel is 480 px wide
    fog_left = depth_left + 440  # the depth panel: 88 px × 5
    floor = np.array(plt.get_cmap("viridis")(Normalize(*FOG_HEIGHTS_MM)(65.0))[:3]) * 255
    return {
        (180, 240): VIEW_RGB,
        (180, depth_left + 100): (0, 0, 0),  # NaN half
        (180, depth_left + 340): np.array(plt.get_cmap("magma")(127 / 255)[:3]) * 255,
        (359 - 45, fog_left + 45): (0, 0, 0),  # obstacle cell (0, 0), bottom left
        (45, fog_left + 405): np.array(UNKNOWN_RGB) * 255,  # unknown, top right
        (180, fog_left + 225): floor,
    }


def assert_panels(picture):
    assert picture.shape == (360, 480 + 440 + 450, 3)
    for (row, column), rgb in expected_pixels(picture).items():
        np.testing.assert_allclose(picture[row, column], rgb, atol=TOLERANCE)


def test_the_video_frame_has_the_three_panels_at_known_pixels():
    writer = RunVideoWriter("unused.mp4", FPS, third_person=view)
    picture = writer.picture(frame(0), FakePipeline())
    assert picture.dtype == np.uint8
    assert_panels(picture)  # exact here (no codec), checked with the codec's tolerance


def test_without_pyav_the_video_is_mpeg4_part2_and_says_so(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "av", None)  # import av → ImportError
    codec = video_codec()
    assert (codec.codec, codec.encoder) == ("mpeg4", "opencv mp4v")
    writer = write_video(tmp_path / "run.mp4")
    assert writer.codec.describe() == "mpeg4 (opencv mp4v)"
    assert "PyAV (pip package 'av') is not installed" in capsys.readouterr().err
    assert sample_entry(tmp_path / "run.mp4") == "mp4v"
    fourcc, pictures = read_with_opencv(tmp_path / "run.mp4")
    assert fourcc == "FMP4" and len(pictures) == FRAMES  # FFmpeg's tag of MPEG-4 Part 2
    assert_panels(pictures[-1])
    assert [p.name for p in tmp_path.iterdir()] == ["run.mp4"]  # no temporary left


def test_pyav_without_an_h264_encoder_falls_back_and_names_it(monkeypatch):
    av = pytest.importorskip("av")
    monkeypatch.setattr("fogsim.viz.video.H264_ENCODERS", ("no_such_encoder",))
    codec = video_codec()
    assert codec.codec == "mpeg4"
    assert f"PyAV {av.__version__} has none of the H.264 encoders no_such_encoder" in (
        codec.fallback or ""
    )


def test_with_pyav_the_video_is_h264_and_reads_back(tmp_path, capsys):
    av = pytest.importorskip("av")
    codec = video_codec()
    assert codec.codec == "h264" and codec.encoder in H264_ENCODERS and codec.fallback is None
    write_video(tmp_path / "run.mp4")
    assert capsys.readouterr().err == ""  # no fallback message
    assert sample_entry(tmp_path / "run.mp4") == "avc1"
    with av.open(str(tmp_path / "run.mp4")) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264"
        assert (stream.width, stream.height) == (1370, 360)
        assert stream.codec_context.pix_fmt == "yuv420p"  # what browsers play
        assert stream.average_rate == FPS
        pictures = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    assert len(pictures) == FRAMES
    assert_panels(pictures[-1])
    fourcc, read_back = read_with_opencv(tmp_path / "run.mp4")  # OpenCV plays it too
    assert fourcc in ("avc1", "h264") and len(read_back) == FRAMES


def test_the_h264_video_is_the_same_file_for_the_same_frames(tmp_path):
    pytest.importorskip("av")
    write_video(tmp_path / "a.mp4")
    write_video(tmp_path / "b.mp4")
    assert (tmp_path / "a.mp4").read_bytes() == (tmp_path / "b.mp4").read_bytes()


def test_a_replay_video_has_no_third_person_panel_and_an_odd_width_is_padded(tmp_path):
    writer = RunVideoWriter(tmp_path / "run.mp4", FPS)
    picture = writer.picture(frame(0), FakePipeline())
    assert picture.shape == (360, 440 + 450, 3)  # already even
    odd = RunVideoWriter(tmp_path / "run.mp4", FPS, third_person=lambda i: view(i)[:, :479])
    assert odd.picture(frame(0), FakePipeline()).shape == (360, 479 + 440 + 450 + 1, 3)


# ---------------------------------------------------------------------- third-person camera

BALL_MJCF = """
<mujoco>
  <visual><headlight ambient="1 1 1" diffuse="0 0 0" specular="0 0 0"/></visual>
  <worldbody>
    <geom type="plane" size="20 20 0.1" rgba="0 0 1 1"/>
    <body name="robot" pos="0 0 0.5">
      <freejoint/>
      <geom type="sphere" size="0.3" rgba="1 0 0 1"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_the_third_person_camera_keeps_the_robot_in_the_middle():
    model = mujoco.MjModel.from_xml_string(BALL_MJCF)
    data = mujoco.MjData(model)
    camera = ThirdPersonCamera(model, size_px=(160, 120))
    try:
        for x_m, y_m in ((0.0, 0.0), (6.0, -3.0)):
            data.qpos[:3] = (x_m, y_m, 0.5)
            mujoco.mj_kinematics(model, data)
            camera.capture(7, data)
            picture = camera.take(7)
            assert picture.shape == (120, 160, 3)
            np.testing.assert_array_equal(picture[60, 80], (255, 0, 0))  # the red ball
            np.testing.assert_array_equal(picture[119, 80], (0, 0, 255))  # the blue floor
            np.testing.assert_array_equal(picture[0, 0], (0, 0, 0))  # the sky: nothing
        with pytest.raises(FogsimError, match="no third-person picture of frame 7"):
            camera.take(7)  # handed over once
    finally:
        camera.close()


def test_the_third_person_camera_needs_a_robot_and_a_size_that_fits():
    no_robot = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><geom type='plane' size='1 1 0.1'/></worldbody></mujoco>"
    )
    with pytest.raises(FogsimError, match="exactly one free joint"):
        robot_root_body(no_robot)
    model = mujoco.MjModel.from_xml_string(BALL_MJCF)
    assert robot_root_body(model) == 1
    with pytest.raises(FogsimError, match=r"size_px \(641, 480\) must be .* \(640, 480\)"):
        ThirdPersonCamera(model, size_px=(641, 480))


def test_a_simulated_run_with_video_shows_the_robot_beside_depth_and_fog(tmp_path, monkeypatch):
    scenario = load_scenario("flat_floor")
    report = run_scenario(scenario, tmp_path / "run", video=True, pictures=False, max_frames=3)
    assert report.video == "run.mp4"
    assert report.video_codec == video_codec().describe()
    _, pictures = read_with_opencv(tmp_path / "run" / "run.mp4")
    assert len(pictures) == 3
    height, width, _ = pictures[0].shape
    assert height == 360 and width > 480 + 440  # third person, depth, FOG
    panel = pictures[-1][:, :480].astype(np.float64)
    assert panel.std() > 10.0  # a rendered scene, not a flat fill
    assert (panel[:40].max(axis=2) < 10).mean() > 0.5  # the sky above the course is black

    # Rendering the view changes nothing of the run: the maps are those of a run without video,
    # which renders no view at all.
    def no_camera(*args, **kwargs):
        raise AssertionError("a run without video made a third-person camera")

    monkeypatch.setattr("fogsim.sim.third_person.ThirdPersonCamera", no_camera)
    run_scenario(scenario, tmp_path / "plain", pictures=False, max_frames=3)
    with (
        np.load(tmp_path / "run" / "maps.npz") as with_video,
        np.load(tmp_path / "plain" / "maps.npz") as plain,
    ):
        assert sorted(with_video) == sorted(plain)
        for name in plain:
            np.testing.assert_array_equal(with_video[name], plain[name], err_msg=name)
    assert not (tmp_path / "plain" / "run.mp4").exists()
