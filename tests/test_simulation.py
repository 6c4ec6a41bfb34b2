"""Simulation: frames from scenarios, deterministic, with true poses that match the scene."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from fogsim.config import find_scenario_files, load_scenario
from fogsim.data.frame import Frame
from fogsim.geometry import PoseError, pose_error
from fogsim.paths import HOLDOUT_DIR
from fogsim.sim.simulation import Simulation
from mapper.transforms import apply_transform, planar_pose_to_matrix

FIRST_FRAMES = 3


def first_frames(simulation: Simulation, n: int = FIRST_FRAMES) -> list[Frame]:
    return list(itertools.islice(simulation.frames(), n))


def assert_frames_identical(a: list[Frame], b: list[Frame]) -> None:
    assert len(a) == len(b)
    for fa, fb in zip(a, b, strict=True):
        np.testing.assert_array_equal(fa.depth_m, fb.depth_m)
        np.testing.assert_array_equal(
            fa.transform_camera_to_robot_believed, fb.transform_camera_to_robot_believed
        )
        np.testing.assert_array_equal(fa.robot_pose_believed, fb.robot_pose_believed)
        np.testing.assert_array_equal(
            fa.transform_camera_to_world_true, fb.transform_camera_to_world_true
        )
        assert fa.time_s == fb.time_s and fa.self_filtered_pixels == fb.self_filtered_pixels


@pytest.fixture(scope="module")
def flat_ideal():
    scenario = load_scenario("flat_floor").with_overrides(["camera.mode=ideal"])
    with Simulation(scenario) as simulation:
        yield simulation


@pytest.mark.parametrize(
    "path", [*find_scenario_files(), *find_scenario_files(HOLDOUT_DIR)], ids=lambda p: p.stem
)
def test_registry_every_scenario_simulates_deterministically(path):
    scenario = load_scenario(path)
    with Simulation(scenario) as simulation:
        assert simulation.frame_count == simulation.trajectory.times_s.size > FIRST_FRAMES
        assert simulation.duration_s == pytest.approx(
            (simulation.frame_count - 1) / scenario.frame_rate_hz
        )
        frames = first_frames(simulation)
        for frame in frames:
            assert frame.depth_m.shape == (scenario.camera.height, scenario.camera.width)
            assert frame.depth_m.dtype == np.float32
            assert np.isfinite(frame.depth_m).mean() > 0.5
            assert np.all(frame.depth_m[np.isfinite(frame.depth_m)] > 0)
            for array in (
                frame.transform_camera_to_robot_believed,
                frame.transform_camera_to_world_true,
                frame.robot_pose_believed,
                frame.robot_pose_true,
            ):
                assert np.all(np.isfinite(array))
        # The same simulation run again gives the same frames bit for bit.
        assert_frames_identical(frames, first_frames(simulation))


def test_same_seed_same_frames_across_instances_and_seed_changes_noise():
    scenario = load_scenario("flat_floor")
    with Simulation(scenario) as a:
        frames_a = first_frames(a)
    with Simulation(scenario) as b:
        assert_frames_identical(frames_a, first_frames(b))
    with Simulation(scenario.with_overrides(["seed=99"])) as c:
        frames_c = first_frames(c)
    assert not np.array_equal(frames_a[0].depth_m, frames_c[0].depth_m, equal_nan=True)


def test_true_camera_pose_and_ideal_depth_see_the_floor(flat_ideal):
    robot = flat_ideal.robot
    for frame in first_frames(flat_ideal, 2):
        q = flat_ideal.trajectory.q[frame.index]
        np.testing.assert_allclose(
            frame.transform_camera_to_world_true,
            robot.transform_camera_to_world(q, "head_camera"),
            atol=1e-9,
        )
        points = frame.intrinsics.depth_to_points_camera(frame.depth_m).reshape(-1, 3)
        world = apply_transform(frame.transform_camera_to_world_true, points)
        world = world[np.isfinite(world[:, 2])]
        away = np.hypot(*(world[:, :2] - frame.robot_pose_true[:2]).T) > 0.35
        assert away.sum() > 2000
        # Exact depth along the optical axis + exact pose: the floor is at z = 0 to 0.1 mm.
        assert np.abs(world[away, 2]).max() < 1e-4
    assert flat_ideal.intrinsics.hfov_deg == pytest.approx(47.0)
    assert flat_ideal.intrinsics.vfov_deg == pytest.approx(39.0)


def test_raycast_backend_gives_the_renderer_depth():
    scenario = load_scenario("flat_floor").with_overrides(["camera.mode=ideal"])
    with Simulation(scenario) as rendered, Simulation(scenario, depth_backend="raycast") as cast:
        a, b = first_frames(rendered, 1)[0], first_frames(cast, 1)[0]
    both = np.isfinite(a.depth_m) & np.isfinite(b.depth_m)
    assert both.mean() > 0.9
    assert (np.abs(a.depth_m - b.depth_m)[both] <= 1e-4).mean() > 0.995


def test_truth_follows_events():
    scenario = load_scenario("box_removal")
    with Simulation(scenario) as simulation:
        at = scenario.events[0].at
        assert simulation.truth_at(at - 0.5).object_state("flat_box") is not None
        assert simulation.truth_at(at + 0.5).object_state("flat_box") is None
        # The box is in view at the start (depth where it stands is shorter than the floor's).
        frame = first_frames(simulation, 1)[0]
        points = frame.intrinsics.depth_to_points_camera(frame.depth_m).reshape(-1, 3)
        world = apply_transform(frame.transform_camera_to_world_true, points)
        box = simulation.truth_at(0.0).object_state("flat_box")
        on_box = box.contains(world[:, :2]) & (np.abs(world[:, 2] - 0.05) < 0.02)
        assert on_box.sum() > 100  # depth mode: noisy, but the box top is there


def camera_pose_errors(frame: Frame) -> tuple[PoseError, PoseError]:
    """Believed-vs-true camera pose in the robot frame (encoders) and in the world (+ odometry)."""
    camera_in_robot_true = (
        np.linalg.inv(planar_pose_to_matrix(frame.robot_pose_true))
        @ frame.transform_camera_to_world_true
    )
    return (
        pose_error(frame.transform_camera_to_robot_believed, camera_in_robot_true),
        pose_error(frame.transform_camera_to_world_believed, frame.transform_camera_to_world_true),
    )


def test_believed_poses_come_from_the_encoders_and_the_odometry(flat_ideal):
    """Exact encoders: the believed poses are the true ones; the scenario's encoder errors put
    the camera off by degrees and millimetres (the paper's "up to 7° and 10 mm"), never 0."""
    exact_encoders = flat_ideal.scenario.with_overrides(
        [
            f"encoders.{key}=0"
            for key in ("bias_deg", "noise_deg", "head_bias_deg", "head_noise_deg")
        ]
    )
    with Simulation(exact_encoders) as exact:
        for frame in first_frames(exact, 10):
            for error in camera_pose_errors(frame):
                assert error.rotation_deg < 1e-4 and error.translation_mm < 1e-3
            np.testing.assert_allclose(frame.robot_pose_believed, frame.robot_pose_true, atol=1e-6)
    frames = first_frames(flat_ideal, 10)
    for frame in frames:
        in_robot, in_world = camera_pose_errors(frame)
        assert 1.0 < in_robot.rotation_deg < 7.0 and 1.0 < in_robot.translation_mm < 10.0
        assert in_world.rotation_deg > 1.0 and in_world.translation_mm > 1.0
    # The odometry starts at the true pose and drifts from there.
    np.testing.assert_allclose(frames[0].robot_pose_believed, frames[0].robot_pose_true, atol=1e-12)
    assert np.abs(frames[-1].robot_pose_believed - frames[-1].robot_pose_true).max() > 1e-5


def test_stereo_mode_depth_belongs_to_the_left_camera():
    scenario = load_scenario("flat_floor")
    stereo = dataclasses.replace(
        scenario, camera=dataclasses.replace(scenario.camera, mode="stereo")
    )
    with Simulation(stereo) as simulation:
        assert simulation.depth_camera == "head_camera_left"
        frame = first_frames(simulation, 1)[0]
        q = simulation.trajectory.q[0]
        np.testing.assert_allclose(
            frame.transform_camera_to_world_true,
            simulation.robot.transform_camera_to_world(q, "head_camera_left"),
            atol=1e-9,
        )
        points = frame.intrinsics.depth_to_points_camera(frame.depth_m).reshape(-1, 3)
        world = apply_transform(frame.transform_camera_to_world_true, points)
        world = world[np.isfinite(world[:, 2])]
        away = np.hypot(*(world[:, :2] - frame.robot_pose_true[:2]).T) > 0.35
        assert away.sum() > 1000
        assert np.median(np.abs(world[away, 2])) < 0.02  # matched stereo: floor within 2 cm
