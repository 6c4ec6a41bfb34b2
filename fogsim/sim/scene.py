"""MuJoCo scenes built from scenarios with ``dm_control.mjcf``; state set and read by name.

The scene is the world of DESIGN.md: z up, a textured ground plane at z = 0 reaching well
beyond the 4 × 1 m stage, one body per scenario object (``obj_<name>``, geom
``geom_<name>``), the robot attached from its standalone MJCF (names prefixed ``<model>/``,
its free joint moved onto the attachment frame), or, without a robot, a free-floating camera
rig (mocap body ``camera_rig``) carrying ``head_camera``, ``head_camera_left`` and
``head_camera_right``.

Objects some event moves or removes are mocap bodies: :meth:`Scene.set_time` places them where
:func:`fogsim.world.truth.object_center_at` says (a removed object is parked far away below
the floor). Rough tops are height fields whose bumps are drawn from the scenario seed. Every
surface is textured (checker + random marks) so stereo matching has something to match.
Rendering settings: no shadows, ``statistic.extent`` = 10 m so that the depth buffer's near
plane is 5 cm and its far plane 20 m (MuJoCo scales both by the extent — a too small extent
is what turned a 1 m depth into 20.0 in an early probe: the far plane clipped the view).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Protocol

import mujoco
import numpy as np
from dm_control import mjcf
from numpy.typing import ArrayLike, NDArray

from fogsim.config.scenario import Scenario, SceneObject
from fogsim.errors import FogsimError
from fogsim.geometry import MJ_FROM_CV
from fogsim.world.truth import moving_objects, object_center_at

CAMERA_NAMES = ("head_camera", "head_camera_left", "head_camera_right")
EXTENT_M = 10.0  # statistic.extent: MuJoCo scales znear/zfar (and some visuals) by it
ZNEAR_M = 0.05  # depth buffer near plane [m]
ZFAR_M = 20.0  # depth buffer far plane [m]; pixels at the far plane have no measurement
FLOOR_HALF_SIZE_M = 12.0
ROUGH_SAMPLE_M = (
    0.08  # spacing of the height-field samples of rough tops [m]: bumps several pixels wide at 2 m
)
PARKED_Z_M = -50.0  # where removed objects go (below the opaque floor, out of every view)


class RobotLike(Protocol):
    """What the scene needs of a robot (``fogsim.robot.model.Robot`` fits)."""

    name: str
    mjcf_path: Any
    mujoco_joint_names: tuple[str, ...]


def _object_colour(index: int, walkable: bool) -> list[float]:
    """A distinct colour per object: warm for walkable surfaces, cool for obstacles."""
    hue = (0.11 * index) % 1.0
    base = np.array([0.85, 0.6, 0.35]) if walkable else np.array([0.35, 0.5, 0.8])
    shift = 0.15 * np.array([math.sin(6.28 * hue), math.cos(6.28 * hue), -math.sin(6.28 * hue)])
    return [*np.clip(base + shift, 0.05, 0.95).tolist(), 1.0]


def rough_elevation(obj: SceneObject, seed: int, index: int) -> NDArray[np.float64]:
    """Normalised bump heights (nrow, ncol) in [0, 1] of a rough top, deterministic in seed.

    Rows run along the object's local y, columns along x; the maximum is exactly 1 and the
    minimum exactly 0, so the top's highest point is ``obj.top_m``.
    """
    ncol = max(3, round(obj.size[0] / ROUGH_SAMPLE_M) + 1)
    nrow = max(3, round(obj.size[1] / ROUGH_SAMPLE_M) + 1)
    rng = np.random.default_rng([seed, 1009, index])
    z = rng.random((nrow, ncol))
    return (z - z.min()) / (z.max() - z.min())


def quat_wxyz_from_matrix(rotation: ArrayLike) -> NDArray[np.float64]:
    """MuJoCo quaternion (w, x, y, z) of a 3×3 rotation."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).ravel())
    return quat


class Scene:
    """A compiled scene: dm_control ``Physics`` plus by-name access to its state.

    Attributes:
        scenario: The scenario it was built from.
        mjcf_model: The dm_control MJCF root element.
        physics: ``dm_control.mjcf.Physics`` of the compiled model.
        model: The raw ``mujoco.MjModel``.
        data: The raw ``mujoco.MjData``.
        has_robot: True if a robot is attached, False for the free camera rig.
        camera_ids: MuJoCo camera id of each of ``CAMERA_NAMES``.
        render_geomgroups: Geom groups the renderer draws (0, 1, 2); ray casts use the same.
    """

    def __init__(self, scenario: Scenario, robot: RobotLike | None = None) -> None:
        self.scenario = scenario
        self.has_robot = robot is not None
        self._moving = moving_objects(scenario)
        root = mjcf.RootElement(model=f"fogsim_{scenario.name}")
        self.mjcf_model = root
        self._add_settings(root, scenario)
        self._add_floor(root)
        self._object_bodies: dict[str, Any] = {}
        for index, obj in enumerate(scenario.objects):
            self._object_bodies[obj.name] = self._add_object(root, obj, index, scenario.seed)
        self._robot_frame = None
        self._robot_joints: list[Any] = []
        if robot is not None:
            camera_elements = self._attach_robot(root, robot)
        else:
            camera_elements = self._add_camera_rig(root, scenario.camera.baseline_m)
        self.physics = mjcf.Physics.from_mjcf_model(root)
        self.model: mujoco.MjModel = self.physics.model.ptr
        self.data: mujoco.MjData = self.physics.data.ptr
        self.camera_ids = {
            name: int(self.physics.bind(element).element_id)
            for name, element in zip(CAMERA_NAMES, camera_elements, strict=True)
        }
        self.render_geomgroups = (0, 1, 2)
        self._mocap_ids = {
            name: int(self.physics.bind(self._object_bodies[name]).mocapid) for name in self._moving
        }
        if robot is not None:
            self._robot_qpos_address = self._robot_qpos_addresses(robot)
        else:
            self._rig_mocap_id = int(self.physics.bind(self._rig).mocapid)
        self.set_time(0.0)
        self.forward()

    # ------------------------------------------------------------------ building

    @staticmethod
    def _add_settings(root: Any, scenario: Scenario) -> None:
        root.compiler.angle = "radian"
        root.statistic.extent = EXTENT_M
        root.statistic.center = [2.0, 0.5, 0.3]
        root.visual.map.znear = ZNEAR_M / EXTENT_M
        root.visual.map.zfar = ZFAR_M / EXTENT_M
        root.visual.quality.shadowsize = 0  # shadows make CPU (llvmpipe) rendering ~20x slower
        root.visual.quality.offsamples = 0  # no multisampling: faster, depth at pixel centres
        width, height = scenario.camera.width, scenario.camera.height
        getattr(root.visual, "global").offwidth = max(640, 2 * width)
        getattr(root.visual, "global").offheight = max(480, 2 * height)
        root.visual.headlight.ambient = [0.35, 0.35, 0.35]
        root.visual.headlight.diffuse = [0.4, 0.4, 0.4]
        root.worldbody.add(
            "light",
            name="sun",
            directional=True,
            castshadow=False,
            pos=[2.0, 0.0, 5.0],
            dir=[0.3, 0.2, -1.0],
            diffuse=[0.6, 0.6, 0.6],
        )
        root.asset.add(
            "texture",
            name="tex_speckle",
            type="2d",
            builtin="checker",
            rgb1=[0.55, 0.55, 0.55],
            rgb2=[0.4, 0.4, 0.4],
            mark="random",
            random=0.35,
            markrgb=[0.95, 0.95, 0.95],
            width=128,
            height=128,
        )
        root.asset.add(
            "texture",
            name="tex_box",
            type="cube",
            builtin="flat",
            rgb1=[0.7, 0.7, 0.7],
            mark="random",
            random=0.35,
            markrgb=[0.15, 0.15, 0.15],
            width=64,
            height=64,
        )

    @staticmethod
    def _add_floor(root: Any) -> None:
        root.asset.add(
            "material",
            name="mat_floor",
            texture="tex_speckle",
            texuniform=True,
            texrepeat=[1.0, 1.0],
            rgba=[1.0, 1.0, 1.0, 1.0],
        )
        root.worldbody.add(
            "geom",
            name="floor",
            type="plane",
            size=[FLOOR_HALF_SIZE_M, FLOOR_HALF_SIZE_M, 0.1],
            pos=[2.0, 0.5, 0.0],
            material="mat_floor",
            group=0,
        )

    def _add_object(self, root: Any, obj: SceneObject, index: int, seed: int) -> Any:
        material = root.asset.add(
            "material",
            name=f"mat_{obj.name}",
            texture="tex_box",
            texuniform=True,
            texrepeat=[2.0, 2.0],
            rgba=_object_colour(index, obj.walkable),
        )
        sx, sy, sz = obj.size
        mocap = obj.name in self._moving
        body = root.worldbody.add(
            "body",
            name=f"obj_{obj.name}",
            pos=[obj.center[0], obj.center[1], obj.base],
            euler=[0.0, 0.0, math.radians(obj.yaw_deg)],
            mocap=mocap,
        )
        if obj.surface == "rough":
            elevation = rough_elevation(obj, seed, index)
            hfield = root.asset.add(
                "hfield",
                name=f"hf_{obj.name}",
                nrow=elevation.shape[0],
                ncol=elevation.shape[1],
                size=[0.5 * sx, 0.5 * sy, obj.roughness_m, sz - obj.roughness_m],
                elevation=elevation.ravel(),
            )
            body.add(
                "geom",
                name=f"geom_{obj.name}",
                type="hfield",
                hfield=hfield,
                pos=[0.0, 0.0, sz - obj.roughness_m],
                material=material,
                group=0,
            )
        else:
            body.add(
                "geom",
                name=f"geom_{obj.name}",
                type="box",
                size=[0.5 * sx, 0.5 * sy, 0.5 * sz],
                pos=[0.0, 0.0, 0.5 * sz],
                material=material,
                group=0,
            )
        return body

    def _add_camera_rig(self, root: Any, baseline_m: float) -> list[Any]:
        """A mocap body carrying the three head cameras (MuJoCo convention, x right)."""
        fovy = self.scenario.camera.fov_deg[1]
        self._rig = root.worldbody.add("body", name="camera_rig", mocap=True, pos=[0, 0, 1])
        offsets = (0.0, -0.5 * baseline_m, 0.5 * baseline_m)
        return [
            self._rig.add("camera", name=name, pos=[dx, 0.0, 0.0], fovy=fovy)
            for name, dx in zip(CAMERA_NAMES, offsets, strict=True)
        ]

    def _attach_robot(self, root: Any, robot: RobotLike) -> list[Any]:
        """Attach the robot's MJCF; its free joint moves onto the attachment frame."""
        robot_model = mjcf.from_path(str(robot.mjcf_path))
        free = robot_model.find("joint", "root")
        if free is None:
            raise FogsimError(f"{robot.mjcf_path}: the robot MJCF has no free joint named 'root'")
        free.remove()
        self._robot_frame = root.attach(robot_model)
        self._robot_free_joint = self._robot_frame.add("freejoint", name="root")
        self._robot_joints = [
            robot_model.find("joint", name) for name in robot.mujoco_joint_names[1:]
        ]
        if any(j is None for j in self._robot_joints):
            missing = [
                n
                for n, j in zip(robot.mujoco_joint_names[1:], self._robot_joints, strict=True)
                if j is None
            ]
            raise FogsimError(f"{robot.mjcf_path}: joints {missing} not found in the MJCF")
        cameras = [robot_model.find("camera", name) for name in CAMERA_NAMES]
        if any(c is None for c in cameras):
            raise FogsimError(f"{robot.mjcf_path}: the robot needs cameras {CAMERA_NAMES}")
        return cameras

    def _robot_qpos_addresses(self, robot: RobotLike) -> NDArray[np.intp]:
        """Scene qpos index of every entry of the robot's standalone qpos."""
        free_address = int(self.physics.bind(self._robot_free_joint).qposadr)
        addresses = list(range(free_address, free_address + 7))
        for joint in self._robot_joints:
            addresses.append(int(self.physics.bind(joint).qposadr))
        return np.asarray(addresses, dtype=np.intp)

    # ------------------------------------------------------------------ state

    def set_time(self, time_s: float) -> None:
        """Place the moving/removed objects where the events put them at ``time_s``."""
        for k, name in enumerate(self._moving):
            center = object_center_at(self.scenario, name, time_s)
            mocap_id = self._mocap_ids[name]
            if center is None:
                self.data.mocap_pos[mocap_id] = [1000.0 + 10.0 * k, 1000.0, PARKED_Z_M]
            else:
                base = self.scenario.object(name).base
                self.data.mocap_pos[mocap_id] = [center[0], center[1], base]

    def set_robot_qpos(self, qpos_standalone: ArrayLike) -> None:
        """Set the robot's configuration from its standalone-model qpos (free joint first)."""
        if not self.has_robot:
            raise FogsimError("this scene has no robot (it was built with the camera rig)")
        qpos = np.asarray(qpos_standalone, dtype=np.float64)
        if qpos.shape != self._robot_qpos_address.shape:
            raise FogsimError(
                f"robot qpos must have {self._robot_qpos_address.size} entries, got {qpos.shape}"
            )
        self.data.qpos[self._robot_qpos_address] = qpos

    def set_camera_rig_pose(self, transform_camera_to_world: ArrayLike) -> None:
        """Place the free camera rig so ``head_camera`` has this OpenCV pose (4×4, world)."""
        if self.has_robot:
            raise FogsimError("this scene has a robot; move it with set_robot_qpos")
        t = np.asarray(transform_camera_to_world, dtype=np.float64)
        self.data.mocap_pos[self._rig_mocap_id] = t[:3, 3]
        self.data.mocap_quat[self._rig_mocap_id] = quat_wxyz_from_matrix(t[:3, :3] @ MJ_FROM_CV)

    def forward(self) -> None:
        """Positions only: body, geom and camera poses for rendering (no dynamics)."""
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def camera_to_world(self, name: str = "head_camera") -> NDArray[np.float64]:
        """4×4 pose of a head camera in the world, OpenCV convention (after :meth:`forward`)."""
        cam = self.camera_ids[name]
        t = np.eye(4)
        t[:3, :3] = self.data.cam_xmat[cam].reshape(3, 3) @ MJ_FROM_CV
        t[:3, 3] = self.data.cam_xpos[cam]
        return t

    def transform_between_cameras(self, source: str, target: str) -> NDArray[np.float64]:
        """4×4 pose of camera ``source`` in camera ``target``'s frame (both OpenCV)."""
        return np.linalg.inv(self.camera_to_world(target)) @ self.camera_to_world(source)

    def geom_names(self, ids: Sequence[int]) -> list[str]:
        """Names of geoms by id (for diagnostics)."""
        return [self.model.geom(int(i)).name for i in ids]
