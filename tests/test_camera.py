"""Head camera: rendered depth == ray-cast depth, known geometry, error model, stereo."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from fogsim.config import CameraConfig, load_scenario, scenario_from_dict
from fogsim.errors import CameraError
from fogsim.sim.camera import (
    HeadCamera,
    RaycastDepth,
    RendererDepth,
    StereoErrorModel,
    camera_intrinsics,
    set_model_intrinsics,
)
from fogsim.sim.camera.noise_model import (
    MATCHER_DISPARITY_NOISE_PX,
    MATCHER_EDGE_MARGIN_PX,
    MATCHER_FLAT_CONTRAST,
    MATCHER_MEAN_VARIANCE_FACTOR,
    MATCHER_SIDE_STRIP_PX,
    MATCHER_STEP_T,
    MATCHER_STRUCTURE_BORDER_PX,
    heading_noise_fields,
    segmentation_noise_fields,
)
from fogsim.sim.scene import Scene
from mapper.heading import HeadingParams
from mapper.intrinsics import PinholeIntrinsics
from mapper.segmentation import SegmentationParams
from mapper.transforms import apply_transform


def look_transform(position, yaw_deg: float, pitch_down_deg: float) -> np.ndarray:
    """OpenCV camera pose in the world: at ``position``, heading yaw, pitched down."""
    yaw, pitch = math.radians(yaw_deg), math.radians(pitch_down_deg)
    forward = np.array(
        [math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), -math.sin(pitch)]
    )
    right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    down = np.cross(forward, right)
    t = np.eye(4)
    t[:3, :3] = np.stack([right, down, forward], axis=1)
    t[:3, 3] = position
    return t


@pytest.fixture(scope="module")
def stage_scene():
    return Scene(load_scenario("stage"))


@pytest.fixture(scope="module")
def cameras(stage_scene):
    intrinsics = camera_intrinsics(CameraConfig())
    for cam in stage_scene.camera_ids.values():
        set_model_intrinsics(stage_scene.model, cam, intrinsics)
    renderer = RendererDepth(stage_scene.model, intrinsics)
    raycast = RaycastDepth(stage_scene.model, intrinsics)
    yield renderer, raycast
    renderer.close()


@pytest.mark.parametrize(
    "pose",
    [
        ((0.3, 0.5, 0.9), 0.0, 30.0),  # the start view over the stage
        ((1.0, 0.2, 0.7), 35.0, 45.0),  # oblique, boxes and the sill
        ((2.4, 0.6, 0.95), -10.0, 25.0),  # the staircase and the platform
        ((0.5, 0.5, 0.9), 0.0, -5.0),  # nearly horizontal: far pixels without a hit
    ],
)
def test_rendered_depth_equals_raycast_depth(stage_scene, cameras, pose):
    renderer, raycast = cameras
    stage_scene.set_camera_rig_pose(look_transform(*pose))
    stage_scene.forward()
    cam = stage_scene.camera_ids["head_camera"]
    rendered = renderer.render(stage_scene.data, cam)
    cast = raycast.render(stage_scene.data, cam)
    assert rendered.shape == cast.shape == (72, 88)
    assert rendered.dtype == np.float32
    np.testing.assert_array_equal(np.isnan(rendered), np.isnan(cast))
    assert np.isfinite(rendered).sum() > 1000
    # Depth buffer precision: a few micrometres at 5 m; 0.1 mm tolerance, except single
    # pixels grazing an edge where the two methods may see different surfaces.
    close = np.abs(rendered - cast) <= 1e-4
    assert close[np.isfinite(cast)].mean() > 0.995


def test_depth_is_along_the_optical_axis(stage_scene, cameras):
    """Looking straight down from 1.3 m at the floor: every pixel reads 1.3 m (not ray length)."""
    renderer, raycast = cameras
    t = np.eye(4)
    t[:3, :3] = np.diag([1.0, -1.0, -1.0])  # optical z down, x along world x
    t[:3, 3] = (0.2, -0.5, 1.3)
    stage_scene.set_camera_rig_pose(t)
    stage_scene.forward()
    cam = stage_scene.camera_ids["head_camera"]
    for source in (renderer, raycast):
        depth = source.render(stage_scene.data, cam)
        assert np.all(np.abs(depth - 1.3) < 2e-5)


def test_back_projected_floor_pixels_lie_on_the_floor(stage_scene, cameras):
    renderer, _ = cameras
    pose = look_transform((0.0, -0.6, 0.9), 200.0, 40.0)  # away from the stage: floor only
    stage_scene.set_camera_rig_pose(pose)
    stage_scene.forward()
    np.testing.assert_allclose(stage_scene.camera_to_world(), pose, atol=1e-12)
    depth = renderer.render(stage_scene.data, stage_scene.camera_ids["head_camera"])
    points = renderer.intrinsics.depth_to_points_camera(depth).reshape(-1, 3)
    world = apply_transform(pose, points[np.isfinite(points[:, 2])])
    assert world.shape[0] > 0.9 * depth.size
    assert np.abs(world[:, 2]).max() < 1e-4


def test_nothing_hit_is_nan(stage_scene, cameras):
    renderer, raycast = cameras
    stage_scene.set_camera_rig_pose(look_transform((0.3, 0.5, 0.9), 0.0, -60.0))  # the sky
    stage_scene.forward()
    cam = stage_scene.camera_ids["head_camera"]
    assert np.isnan(renderer.render(stage_scene.data, cam)).all()
    assert np.isnan(raycast.render(stage_scene.data, cam)).all()


def test_rough_tops_render_like_raycast():
    scene = Scene(load_scenario("simulated_world"))
    intrinsics = camera_intrinsics(CameraConfig())
    cam = HeadCamera(scene.model, scene.camera_ids, CameraConfig(mode="ideal"))
    cast = RaycastDepth(scene.model, intrinsics)
    scene.set_camera_rig_pose(look_transform((0.45, 0.5, 0.8), 0.0, 50.0))
    scene.forward()
    rendered = cam.capture(scene.data, np.random.default_rng(0))
    ray = cast.render(scene.data, scene.camera_ids["head_camera"])
    ok = np.abs(rendered - ray) <= 1e-4
    assert ok[np.isfinite(ray)].mean() > 0.99
    cam.close()


def error_model(**changes) -> StereoErrorModel:
    """f = 100 px, b = 0.1 m (f b = 10 px m), no noise: only what ``changes`` turns on."""
    values = dict(
        focal_px=100.0,
        baseline_m=0.1,
        disparity_noise_px=0.0,
        disparity_step_px=0.0,
        dropout=0.0,
        range_m=(0.1, 10.0),
        disparity_noise_correlation_px=0.0,
        edge_fattening_px=0,
        occlusion=False,
    )
    return StereoErrorModel(**(values | changes))


def test_error_model_statistics_known_answers():
    model = error_model(disparity_noise_px=0.1)
    depth = np.full((400, 500), 2.0, dtype=np.float32)
    noisy = model.apply(depth, np.random.default_rng(7))
    # d = f b / z = 5 px; sigma_z ~ z^2 sigma_d / (f b) = 4 * 0.1 / 10 = 0.04 m.
    assert model.depth_sigma_m(2.0) == pytest.approx(0.04)
    assert np.std(noisy) == pytest.approx(0.04, rel=0.05)
    assert np.median(noisy) == pytest.approx(2.0, abs=0.002)
    # Same seed, same result bit for bit; another seed differs.
    np.testing.assert_array_equal(noisy, model.apply(depth, np.random.default_rng(7)))
    assert not np.array_equal(noisy, model.apply(depth, np.random.default_rng(8)))


def test_error_model_quantisation_range_and_dropout():
    step = 0.25
    model = StereoErrorModel(100.0, 0.1, 0.0, step, 0.1, (0.5, 3.0), 0.0, 0, False)
    depth = np.linspace(0.2, 5.0, 200_000, dtype=np.float32).reshape(400, 500)
    noisy = model.apply(depth, np.random.default_rng(1))
    valid = np.isfinite(noisy)
    disparity = 10.0 / noisy[valid].astype(np.float64)
    np.testing.assert_allclose(disparity / step, np.round(disparity / step), atol=1e-4)
    assert noisy[valid].min() >= 0.5 and noisy[valid].max() <= 3.0
    in_range = (10.0 / (np.round(10.0 / depth / step) * step) >= 0.5) & (
        10.0 / (np.round(10.0 / depth / step) * step) <= 3.0
    )
    assert (~valid[in_range]).mean() == pytest.approx(0.1, abs=0.005)
    exact = StereoErrorModel(100.0, 0.1, 0.0, 0.0, 0.0, (0.1, 10.0), 0.0, 0, False)
    np.testing.assert_allclose(
        exact.apply(depth, np.random.default_rng(0))[depth >= 0.1], depth[depth >= 0.1], rtol=1e-6
    )


def test_depth_mode_error_grows_with_distance(stage_scene):
    config = load_scenario("stage").camera
    camera = HeadCamera(stage_scene.model, stage_scene.camera_ids, config)
    stage_scene.set_camera_rig_pose(look_transform((0.0, -0.6, 0.9), 200.0, 30.0))
    stage_scene.forward()
    exact = camera.exact_depth(stage_scene.data)
    noisy = camera.capture(stage_scene.data, np.random.default_rng(3))
    error = noisy - exact
    near, far = exact < 1.5, exact > 2.5
    assert np.nanstd(error[near]) < np.nanstd(error[far])
    assert np.nanmedian(np.abs(error[near])) < 0.01
    in_range = exact < 0.9 * config.range_m[1]
    assert np.isnan(noisy[in_range]).mean() == pytest.approx(config.dropout, abs=0.01)
    assert np.isnan(noisy[exact > 1.1 * config.range_m[1]]).all()
    camera.close()


def test_stereo_mode_matches_rendered_images(stage_scene):
    stereo_config = dataclasses.replace(load_scenario("stage").camera, mode="stereo")
    camera = HeadCamera(stage_scene.model, stage_scene.camera_ids, stereo_config)
    stage_scene.set_camera_rig_pose(look_transform((0.3, 0.5, 0.9), 0.0, 35.0))
    stage_scene.forward()
    assert camera.depth_camera == "head_camera_left"
    depth = camera.capture(stage_scene.data, np.random.default_rng(0))
    assert depth.shape == (72, 88) and depth.dtype == np.float32
    reference = camera.exact_depth(stage_scene.data)
    relative = (depth - reference) / reference
    assert np.isfinite(depth).mean() > 0.95
    assert abs(np.nanmedian(relative)) < 0.003  # the old matcher read 1 % too far
    np.testing.assert_array_equal(depth, camera.capture(stage_scene.data, np.random.default_rng(0)))
    camera.close()


def test_bad_camera_requests_raise(stage_scene):
    with pytest.raises(CameraError, match="renderer, raycast"):
        HeadCamera(stage_scene.model, stage_scene.camera_ids, CameraConfig(), backend="opengl")
    with pytest.raises(CameraError, match="stereo"):
        HeadCamera(
            stage_scene.model,
            stage_scene.camera_ids,
            CameraConfig(mode="stereo"),
            backend="raycast",
        )
    with pytest.raises(CameraError, match="dropout"):
        StereoErrorModel(100.0, 0.1, 0.05, 0.0625, 1.5, (0.15, 4.0), 0.0, 0, False)
    with pytest.raises(CameraError, match="edge_fattening_px"):
        StereoErrorModel(100.0, 0.1, 0.05, 0.0625, 0.01, (0.15, 4.0), 0.0, 9, False)
    off_centre = PinholeIntrinsics(88, 72, 100.0, 100.0, 40.0, 30.0)
    with pytest.raises(CameraError, match=r"cy=30.0 for a 88x72 image, allowed cy=35.5"):
        set_model_intrinsics(stage_scene.model, 0, off_centre)


@pytest.mark.parametrize("cx", [43.5 + 16.0, 43.5 - 10.0])
def test_a_horizontally_off_centre_principal_point_renders_like_raycast(stage_scene, cx):
    """The stereo mode renders images extended to the left: MuJoCo's principal offset must
    move the image exactly as the intrinsics say (ray casting uses them directly)."""
    intrinsics = PinholeIntrinsics(88, 72, 101.0, 101.0, cx, 35.5)
    cam = stage_scene.camera_ids["head_camera"]
    set_model_intrinsics(stage_scene.model, cam, intrinsics)
    stage_scene.set_camera_rig_pose(look_transform((1.0, 0.2, 0.7), 35.0, 45.0))
    stage_scene.forward()
    renderer = RendererDepth(stage_scene.model, intrinsics)
    rendered = renderer.render(stage_scene.data, cam)
    renderer.close()
    set_model_intrinsics(stage_scene.model, cam, camera_intrinsics(CameraConfig()))
    cast = RaycastDepth(stage_scene.model, intrinsics).render(stage_scene.data, cam)
    close = np.abs(rendered - cast) <= 1e-4
    assert close[np.isfinite(cast)].mean() > 0.995


def test_intrinsics_follow_the_scenario():
    scenario = scenario_from_dict(
        {"name": "w", "camera": {"width": 64, "height": 48, "fov_deg": [60.0, 45.0]}}
    )
    intrinsics = camera_intrinsics(scenario.camera)
    assert intrinsics.hfov_deg == pytest.approx(60.0)
    assert intrinsics.vfov_deg == pytest.approx(45.0)
    assert intrinsics.shape == (48, 64)


def test_camera_inside_its_mount_sees_through_it_in_both_backends():
    xml = """<mujoco><statistic extent="10"/><visual><map znear="0.005" zfar="2"/>
    <quality offsamples="0"/></visual><worldbody><geom name="floor" type="plane" size="5 5 .1"/>
    <body name="head" pos="0 0 1.2"><geom name="shell" type="box" size=".1 .1 .1"/>
    <camera name="cam" euler="0.3 0 0"/></body></worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    intrinsics = camera_intrinsics(CameraConfig())
    set_model_intrinsics(model, 0, intrinsics)
    renderer = RendererDepth(model, intrinsics)
    rendered = renderer.render(data, 0)
    cast = RaycastDepth(model, intrinsics).render(data, 0)
    renderer.close()
    assert np.isfinite(cast).all() and np.nanmin(cast) > 1.0  # the floor, not the shell
    np.testing.assert_allclose(rendered, cast, atol=1e-4)


def test_the_twenty_metre_reading_is_the_far_plane_of_a_small_model():
    """The early probe's 20.0: extent 0.4 m x zfar 50 = 20 m far plane, where no-hit pixels land."""
    xml = """<mujoco><statistic extent="0.4"/><worldbody>
    <geom name="floor" type="plane" size="0 0 .1"/>
    <body name="cam" pos="0 0 1" euler="90 0 0"><camera name="c" fovy="39"/></body>
    </worldbody></mujoco>"""  # camera looking horizontally: the upper half sees nothing
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    raw = mujoco.Renderer(model, 72, 88)
    raw.enable_depth_rendering()
    raw.update_scene(data, camera=0)
    raw_depth = raw.render()
    raw.close()
    assert raw_depth[0, 0] == pytest.approx(0.4 * 50.0, rel=1e-4)
    ours = RendererDepth(model, camera_intrinsics(CameraConfig()))
    set_model_intrinsics(model, 0, ours.intrinsics)
    depth = ours.render(data, 0)
    ours.close()
    assert np.isnan(depth[:30]).all()  # no hit above the horizon
    assert np.isfinite(depth[-10:]).all()  # the floor below it


def test_error_model_equivalent_noise_and_mean_variance_factor_known_answers():
    """σ_eq = hypot(σ_d, step/√12) = hypot(0.05, 0.0625/√12) = 0.05316 px; white noise has
    factor 1; noise smoothed over 0.6 px has 1/Σk² = 2.02 for long row runs, which the drawn
    field shows (n·var(mean of n = 64 row pixels)/var(pixel))."""
    white = error_model(disparity_noise_px=0.05, disparity_step_px=0.0625)
    assert white.equivalent_noise_px() == pytest.approx(0.053156, abs=1e-6)
    assert white.mean_variance_factor() == 1.0
    smooth = error_model(disparity_noise_px=0.1, disparity_step_px=0.0)
    smooth = dataclasses.replace(smooth, disparity_noise_correlation_px=0.6)
    assert smooth.mean_variance_factor() == pytest.approx(2.02, abs=0.01)
    field = smooth.noise_px((256, 1024), np.random.default_rng(3))
    runs = field.reshape(256, -1, 64)
    measured = 64 * np.var(runs.mean(axis=-1)) / np.var(field)
    assert measured == pytest.approx(smooth.mean_variance_factor(), rel=0.1)


def test_segmentation_noise_fields_per_mode():
    """stereo: the matcher's measured figures and the robot's baseline; depth: the error
    model's; both the camera's range; ideal: none (the segmentation estimates the noise from
    the image)."""
    camera = CameraConfig()
    stereo = segmentation_noise_fields(dataclasses.replace(camera, mode="stereo"), 0.068)
    assert stereo == {
        "disparity_noise_px": MATCHER_DISPARITY_NOISE_PX,
        "stereo_baseline_m": 0.068,
        "noise_correlation_factor": MATCHER_MEAN_VARIANCE_FACTOR,
        "floor_edge_margin_px": MATCHER_EDGE_MARGIN_PX,
        "floor_side_strip_px": MATCHER_SIDE_STRIP_PX,
        "tilt_max_step_t": MATCHER_STEP_T,
        "structure_border_px": MATCHER_STRUCTURE_BORDER_PX,
        "floor_occluding_border_px": 1,
        "floor_occluding_border_rows_only": True,
        "floor_occluding_border_min_width_m": 0.15,
        "max_depth_m": camera.range_m[1],
    }
    depth = segmentation_noise_fields(dataclasses.replace(camera, mode="depth"), 0.068)
    assert depth["stereo_baseline_m"] == camera.baseline_m
    assert depth["max_depth_m"] == camera.range_m[1]
    assert depth["disparity_noise_px"] == pytest.approx(
        math.hypot(camera.disparity_noise_px, camera.disparity_step_px / math.sqrt(12.0))
    )
    assert segmentation_noise_fields(dataclasses.replace(camera, mode="ideal"), 0.068) == {}
    SegmentationParams(**stereo)
    SegmentationParams(**depth)
    assert "structure_border_px" not in depth  # it harms the depth head (its docstring)
    assert "floor_occluding_border_px" not in depth  # no fattened edges to take out
    assert "floor_step_split_t" not in stereo  # measured, no default (its docstring)


def test_heading_noise_fields_per_mode():
    """stereo: the edge score stands in wherever the structure score has not stood out; the
    other modes keep the heading's defaults."""
    camera = CameraConfig()
    stereo = heading_noise_fields(dataclasses.replace(camera, mode="stereo"))
    assert stereo == {"head.flat_contrast": MATCHER_FLAT_CONTRAST}
    assert MATCHER_FLAT_CONTRAST == HeadingParams().min_contrast != HeadingParams().flat_contrast
    for mode in ("depth", "ideal"):
        assert heading_noise_fields(dataclasses.replace(camera, mode=mode)) == {}
