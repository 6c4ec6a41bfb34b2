"""Step a scenario: the robot walks its route, the head camera sees the scene, frames come out.

Per frame (``Simulation.frames``), at the trajectory's time ``t``:
    1. the world's events are applied (``Scene.set_time``), the robot's true configuration is
       set by joint name and MuJoCo computes positions only (``mj_kinematics``, no dynamics);
    2. the head camera captures depth (mode ``ideal`` / ``depth`` / ``stereo``);
    3. the encoders are read (true angles + per-run bias + noise), the believed camera pose in
       the robot frame is pinocchio's forward kinematics of the readings, the believed robot
       pose comes from odometry of the readings, and the self-filter blanks pixels on the
       robot's own body at the believed configuration;
    4. a :class:`fogsim.data.frame.Frame` is built with the true poses for scoring.

Everything random is drawn from generators seeded by ``scenario.seed`` (camera noise per frame
from ``(seed, 17, index)``, encoders from ``(seed, 23)``), so every call of :meth:`frames`
gives the same frames bit for bit. In ``stereo`` mode the depth image belongs to
``head_camera_left`` and every camera transform in the frame is that camera's.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fogsim.config.scenario import Scenario
from fogsim.data.frame import Frame
from fogsim.sim.camera import HeadCamera
from fogsim.sim.scene import Scene
from fogsim.world.truth import SceneTruth
from mapper.intrinsics import PinholeIntrinsics
from mapper.transforms import planar_pose_to_matrix, rotation_angle_deg

_CAMERA_NOISE_STREAM = 17
_ENCODER_STREAM = 23


def _stats(values: list[float]) -> dict[str, float]:
    array = np.asarray(values, dtype=np.float64)
    if array.size == 0:
        return {"median": math.nan, "max": math.nan}
    return {"median": float(np.median(array)), "max": float(np.max(array))}


def pose_difference(
    believed: NDArray[np.float64], true: NDArray[np.float64]
) -> tuple[float, float]:
    """(rotation [deg], translation [mm]) between two 4×4 poses."""
    rotation = rotation_angle_deg(believed[:3, :3].T @ true[:3, :3])
    translation = 1000.0 * float(np.linalg.norm(believed[:3, 3] - true[:3, 3]))
    return rotation, translation


class Simulation:
    """A scenario running in MuJoCo with the robot walking its route.

    Args:
        scenario: The scenario to run.
        depth_backend: ``renderer`` (OpenGL, default) or ``raycast`` (``mj_multiRay``).

    Attributes:
        scenario: The scenario.
        robot: The loaded robot (``fogsim.robot.model.Robot``).
        scene: The MuJoCo :class:`~fogsim.sim.scene.Scene`.
        camera: The :class:`~fogsim.sim.camera.HeadCamera`.
        intrinsics: Intrinsics of the depth images.
        trajectory: The planned walk (``fogsim.robot.walking.Trajectory``), one sample per frame.
    """

    def __init__(self, scenario: Scenario, *, depth_backend: str = "renderer") -> None:
        from fogsim.robot.model import load_robot
        from fogsim.robot.walking import plan_route

        self.scenario = scenario
        self.robot = load_robot(scenario.robot.model)
        initial_truth = SceneTruth.from_scenario(scenario, 0.0)
        self.trajectory = plan_route(
            self.robot,
            scenario.robot.start,
            scenario.route,
            initial_truth.support_height_m,
            scenario.frame_rate_hz,
        )
        self.scene = Scene(scenario, self.robot)
        self.scene.set_robot_qpos(self.robot.qpos_mujoco(self.trajectory.q[0]))
        self.scene.forward()
        baseline = float(
            np.linalg.norm(
                self.scene.camera_to_world("head_camera_left")[:3, 3]
                - self.scene.camera_to_world("head_camera_right")[:3, 3]
            )
        )
        self.camera = HeadCamera(
            self.scene.model,
            self.scene.camera_ids,
            scenario.camera,
            backend=depth_backend,
            baseline_m=baseline,
            geomgroups=self.scene.render_geomgroups,
        )
        self.depth_backend = depth_backend
        self.intrinsics: PinholeIntrinsics = self.camera.intrinsics
        self._pose_errors: dict[str, list[list[float]]] | None = None

    # ------------------------------------------------------------------ sizes

    @property
    def frame_count(self) -> int:
        """Number of frames of the run."""
        return self.trajectory.frame_count

    @property
    def duration_s(self) -> float:
        """Time of the last frame [s]."""
        return self.trajectory.duration_s

    @property
    def depth_camera(self) -> str:
        """Name of the camera the depth images belong to."""
        return self.camera.depth_camera

    # ------------------------------------------------------------------ frames

    def truth_at(self, time_s: float) -> SceneTruth:
        """The world's ground truth at ``time_s`` (events applied)."""
        return SceneTruth.from_scenario(self.scenario, time_s)

    def _encoder_reader(self) -> Any:
        """Encoder model of the robot helper, or exact readings if it is not available."""
        try:
            from fogsim.robot.encoders import EncoderModel
        except ImportError:
            return None
        rng = np.random.default_rng([self.scenario.seed, _ENCODER_STREAM])
        config = self.scenario.encoders
        return EncoderModel.for_robot(
            self.robot,
            config.bias_deg,
            config.noise_deg,
            rng,
            head_bias_deg=config.head_bias_deg,
            head_noise_deg=config.head_noise_deg,
        )

    def frames(self) -> Iterator[Frame]:
        """Run the scenario from the start and yield one :class:`Frame` per camera frame."""
        robot, scene, trajectory = self.robot, self.scene, self.trajectory
        encoders = self._encoder_reader()
        odometry = _make_odometry(robot, trajectory)
        self_filter = _make_self_filter(robot, self.depth_camera)
        errors: dict[str, list[list[float]]] = {"camera_in_robot": [], "camera_in_world": []}
        self._pose_errors = errors
        for index, time_s in enumerate(trajectory.times_s):
            q_true = trajectory.q[index]
            scene.set_time(float(time_s))
            scene.set_robot_qpos(robot.qpos_mujoco(q_true))
            scene.forward()
            rng = np.random.default_rng([self.scenario.seed, _CAMERA_NOISE_STREAM, index])
            depth = self.camera.capture(scene.data, rng)

            joints_true = q_true[7:]
            joints_read = encoders.read(q_true) if encoders is not None else joints_true.copy()
            reference_foot = int(trajectory.reference_foot[index])
            camera_in_robot_believed = robot.transform_camera_to_robot(
                joints_read, reference_foot, self.depth_camera
            )
            robot_pose_true = np.asarray(trajectory.robot_pose_true[index], dtype=np.float64)
            robot_pose_believed = (
                odometry(index, joints_read) if odometry is not None else robot_pose_true.copy()
            )
            filtered = 0
            if self_filter is not None:
                mask = self_filter.mask(
                    depth, self.intrinsics, joints_read, camera_in_robot_believed
                )
                filtered = int(np.count_nonzero(mask & np.isfinite(depth)))
                depth = depth.copy()
                depth[mask] = np.nan
            camera_in_world_true = scene.camera_to_world(self.depth_camera)
            frame = Frame(
                index=index,
                time_s=float(time_s),
                depth_m=depth,
                intrinsics=self.intrinsics,
                transform_camera_to_robot_believed=camera_in_robot_believed,
                robot_pose_believed=np.asarray(robot_pose_believed, dtype=np.float64),
                transform_camera_to_world_true=camera_in_world_true,
                robot_pose_true=robot_pose_true,
                self_filtered_pixels=filtered,
            )
            camera_in_robot_true = (
                np.linalg.inv(planar_pose_to_matrix(robot_pose_true)) @ camera_in_world_true
            )
            errors["camera_in_robot"].append(
                list(pose_difference(camera_in_robot_believed, camera_in_robot_true))
            )
            errors["camera_in_world"].append(
                list(
                    pose_difference(frame.transform_camera_to_world_believed, camera_in_world_true)
                )
            )
            yield frame

    def pose_error_stats(self) -> dict[str, dict[str, dict[str, float]]]:
        """Believed-vs-true camera pose errors over the frames produced so far.

        Returns:
            ``{"camera_in_robot" | "camera_in_world": {"rotation_deg" | "translation_mm":
            {"median", "max"}}}`` — ``camera_in_robot`` is the encoders' error (the paper's
            "up to 7° and 10 mm"), ``camera_in_world`` adds the odometry drift. If no frames
            were produced yet, the whole run is simulated first.
        """
        if not self._pose_errors or not self._pose_errors["camera_in_robot"]:
            for _ in self.frames():
                pass
        assert self._pose_errors is not None
        out: dict[str, dict[str, dict[str, float]]] = {}
        for key, rows in self._pose_errors.items():
            array = np.asarray(rows, dtype=np.float64).reshape(-1, 2)
            out[key] = {
                "rotation_deg": _stats(array[:, 0].tolist()),
                "translation_mm": _stats(array[:, 1].tolist()),
            }
        return out

    def close(self) -> None:
        """Free the OpenGL contexts."""
        self.camera.close()

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _make_odometry(robot: Any, trajectory: Any) -> Any:
    """Believed robot pose per frame from the robot helper's odometry, None if unavailable.

    The odometry starts at the true initial pose (the robot knows where it starts) and then
    integrates foot-to-foot kinematics of the readings.
    """
    try:
        from fogsim.robot.encoders import Odometry
    except ImportError:
        return None
    state: dict[str, Any] = {}

    def update(index: int, joints_read: NDArray[np.float64]) -> NDArray[np.float64]:
        stance = int(trajectory.stance[index])
        if "odometry" not in state:
            state["odometry"] = Odometry(
                robot, trajectory.robot_pose_true[index], joints_read, stance
            )
        return state["odometry"].update(joints_read, stance)

    return update


def _make_self_filter(robot: Any, camera: str) -> Any:
    """The robot helper's self-filter for the depth camera, None if unavailable."""
    try:
        from fogsim.robot.self_filter import SelfFilter
    except ImportError:
        return None
    return SelfFilter(robot, camera=camera)
