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

The simulation yields frames only: how far the believed poses are off is measured from the
frames by the evaluation layer.

Everything random is drawn from generators seeded by ``scenario.seed`` (camera noise per frame
from ``(seed, 17, index)``, encoders from ``(seed, 23)``), so every call of :meth:`frames`
gives the same frames bit for bit. In ``stereo`` mode the depth image belongs to
``head_camera_left`` and every camera transform in the frame is that camera's.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import mujoco
import numpy as np

from fogsim.config import Scenario
from fogsim.data.frame import Frame
from fogsim.robot import EncoderModel, Odometry, Robot, SelfFilter, Trajectory, load_robot
from fogsim.sim.camera import HeadCamera
from fogsim.sim.route_cache import planned_route
from fogsim.sim.scene import Scene
from fogsim.world import SceneTruth
from mapper.intrinsics import PinholeIntrinsics

_CAMERA_NOISE_STREAM = 17
_ENCODER_STREAM = 23


class Simulation:
    """A scenario running in MuJoCo with the robot walking its route.

    Args:
        scenario: The scenario to run.
        depth_backend: ``renderer`` (OpenGL, default) or ``raycast`` (``mj_multiRay``).

    Attributes:
        scenario: The scenario.
        robot: The loaded robot.
        trajectory: The planned walk, one sample per frame.
        scene: The MuJoCo :class:`~fogsim.sim.scene.Scene`.
        camera: The :class:`~fogsim.sim.camera.HeadCamera`.
        depth_backend: The depth backend.
        intrinsics: Intrinsics of the depth images.
    """

    def __init__(self, scenario: Scenario, *, depth_backend: str = "renderer") -> None:
        self.scenario = scenario
        self.robot: Robot = load_robot(scenario.robot.model)
        self.trajectory: Trajectory = planned_route(scenario, self.robot)
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

    def _encoder_model(self) -> EncoderModel:
        """The run's encoders: per-run bias and per-frame noise from stream (seed, 23)."""
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

    def frames(
        self, on_pose: Callable[[int, mujoco.MjData], None] | None = None
    ) -> Iterator[Frame]:
        """Run the scenario from the start and yield one :class:`Frame` per camera frame.

        The odometry starts at the true initial pose (the robot knows where it starts) and then
        integrates foot-to-foot kinematics of the readings.

        Args:
            on_pose: Called with the frame's index and the scene's data once the robot is posed
                (the run video's third-person camera,
                :meth:`fogsim.sim.third_person.ThirdPersonCamera.capture`); None: nothing.
        """
        robot, scene, trajectory = self.robot, self.scene, self.trajectory
        encoders = self._encoder_model()
        self_filter = SelfFilter(robot, camera=self.depth_camera)
        odometry: Odometry | None = None
        for index, time_s in enumerate(trajectory.times_s):
            q_true = trajectory.q[index]
            scene.set_time(float(time_s))
            scene.set_robot_qpos(robot.qpos_mujoco(q_true))
            scene.forward()
            if on_pose is not None:
                on_pose(index, scene.data)
            rng = np.random.default_rng([self.scenario.seed, _CAMERA_NOISE_STREAM, index])
            depth = self.camera.capture(scene.data, rng)

            joints_read = encoders.read(q_true)
            reference_foot = int(trajectory.reference_foot[index])
            camera_in_robot_believed = robot.transform_camera_to_robot(
                joints_read, reference_foot, self.depth_camera
            )
            robot_pose_true = np.asarray(trajectory.robot_pose_true[index], dtype=np.float64)
            stance = int(trajectory.stance[index])
            if odometry is None:
                odometry = Odometry(robot, trajectory.robot_pose_true[index], joints_read, stance)
            robot_pose_believed = odometry.update(joints_read, stance)
            mask = self_filter.mask(depth, self.intrinsics, joints_read, camera_in_robot_believed)
            filtered = int(np.count_nonzero(mask & np.isfinite(depth)))
            depth = depth.copy()
            depth[mask] = np.nan
            yield Frame(
                index=index,
                time_s=float(time_s),
                depth_m=depth,
                intrinsics=self.intrinsics,
                transform_camera_to_robot_believed=camera_in_robot_believed,
                robot_pose_believed=np.asarray(robot_pose_believed, dtype=np.float64),
                transform_camera_to_world_true=scene.camera_to_world(self.depth_camera),
                robot_pose_true=robot_pose_true,
                self_filtered_pixels=filtered,
            )

    def close(self) -> None:
        """Free the OpenGL contexts."""
        self.camera.close()

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
