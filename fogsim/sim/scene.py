"""MuJoCo scenes built from scenarios with ``dm_control.mjcf``; state set and read by name.

The scene is the world of DESIGN.md: z up, a textured ground plane at z = 0 reaching well
beyond the 4 × 1 m stage, one body per scenario object (``obj_<name>``, geom
``geom_<name>``, material ``mat_<name>``; a flat box is a mesh ``mesh_<name>`` with texture
coordinates, a rough top or a terrain a height field ``hf_<name>``; both are MuJoCo's binary
files, in-memory assets of the MJCF, not numeric text: :mod:`fogsim.robot.mj_xml`), the robot
attached from its standalone MJCF (names prefixed ``<model>/``, its free joint moved onto the
attachment frame), or, without a robot, a free-floating camera rig (mocap body
``camera_rig``) carrying ``head_camera``, ``head_camera_left`` and ``head_camera_right``.

What does not depend on the scenario is data: the MJCF pieces in ``assets/mjcf/``
(:data:`WORLD_PIECES`: render and depth-buffer settings, the light, materials, the floor; and
the camera rig), merged in through :func:`fogsim.sim.assets.load_mjcf_piece`, and the
procedural textures of ``assets/mjcf/textures.toml`` (:func:`fogsim.sim.assets.scene_textures`).
Each file says why its values are what they are.

Objects some event moves or removes are mocap bodies: :meth:`Scene.set_time` places them where
:func:`fogsim.world.object_center_at` says (a removed object is parked far away below the
floor). Rough tops are height fields whose bumps are drawn from the scenario seed.
"""

from __future__ import annotations

import functools
import math
from importlib.metadata import version
from pathlib import Path
from typing import TYPE_CHECKING
from xml.etree import ElementTree

import mujoco
import numpy as np
from numpy.typing import ArrayLike, NDArray

from fogsim.config import CameraConfig, Scenario, SceneObject
from fogsim.errors import FogsimError, RobotModelError
from fogsim.geometry import MJ_FROM_CV
from fogsim.robot import CAMERA_NAMES, Robot
from fogsim.robot.mj_xml import hfield_file, mesh_file, model_from_xml_string
from fogsim.robot.mjcf import mjcf_files
from fogsim.sim import assets
from fogsim.sim.assets import MJCF_DIR, load_mjcf_piece, scene_textures
from fogsim.sim.camera.depth import VISIBLE_GEOMGROUPS
from fogsim.sim.camera.stereo import stereo_render_px
from fogsim.sim.model_cache import content_key, load_or_compile
from fogsim.world import moving_objects, object_center_at

if TYPE_CHECKING:  # dm_control builds scenes only: a cached compiled scene does without it
    from dm_control import mjcf
    from dm_control import mujoco as dm_mujoco

WORLD_PIECES = ("visual", "lighting", "materials", "floor")
"""The MJCF pieces every scene starts from, in this order (element order sets MuJoCo's ids)."""
MIN_OFFSCREEN_PX = (640, 480)
"""Smallest off-screen buffer (width, height) [px]: MuJoCo's default (see :func:`offscreen_px`)."""
ROUGH_SAMPLE_M = 0.08
"""Spacing of the height-field samples of rough tops [m]: bumps several pixels wide at 2 m."""
TERRAIN_MIN_SPAN_M = 0.005
"""Smallest height span and base thickness of a terrain's height field [m]: MuJoCo needs both
positive; a terrain whose lowest samples are at the ground gets a 5 mm base hidden under it, a
flat one (every sample equal) a 5 mm span whose top is never reached."""
PARKED_Z_M = -50.0
"""Where removed objects go [m]: below the opaque floor, out of every view."""


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


def box_mesh(
    size_m: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.int32], NDArray[np.float64]]:
    """A box centred at the origin as a mesh with texture coordinates in metres.

    Each of the six faces has its own four vertices, so its texture coordinates are the face's
    own in-plane coordinates [m]: a 2D texture (scaled by the material's ``texrepeat``) lies on
    every face undistorted, at the same scale as on the ground. MuJoCo's primitive box takes
    only cube maps, which streak on flat boxes.

    Args:
        size_m: Full (x, y, z) side lengths [m].

    Returns:
        Vertices (24, 3) [m], triangles (12, 3) (counter-clockwise seen from outside) and
        texture coordinates (24, 2) [m].
    """
    half = 0.5 * np.asarray(size_m, dtype=np.float64)
    axes = np.eye(3)
    vertices, triangles, texcoords = [], [], []
    for normal_axis in range(3):
        u_axis, v_axis = (normal_axis + 1) % 3, (normal_axis + 2) % 3
        for sign in (1.0, -1.0):
            normal, u, v = sign * axes[normal_axis], axes[u_axis], sign * axes[v_axis]
            first = len(vertices)
            for a, b in ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)):
                corner = (normal + a * u + b * v) * half
                vertices.append(corner)
                texcoords.append((corner @ u, corner @ v))
            triangles += [(first, first + 1, first + 2), (first, first + 2, first + 3)]
    return (
        np.asarray(vertices),
        np.asarray(triangles, dtype=np.int32),
        np.asarray(texcoords),
    )


def quat_wxyz_from_matrix(rotation: ArrayLike) -> NDArray[np.float64]:
    """MuJoCo quaternion (w, x, y, z) of a 3×3 rotation."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=np.float64).ravel())
    return quat


# ---------------------------------------------------------------------- building


def offscreen_px(camera: CameraConfig) -> tuple[int, int]:
    """(width, height) [px] of the off-screen buffer every renderer of ``camera`` fits in.

    MuJoCo renders into one off-screen buffer per model and refuses images larger than it. The
    largest image is the stereo mode's (:func:`fogsim.sim.camera.stereo.stereo_render_px`: twice
    the camera's resolution, extended by the disparity search range and a margin), whatever the
    mode, so one scene serves every mode; the buffer is never smaller than
    :data:`MIN_OFFSCREEN_PX`. The camera's largest side (``fogsim.config.limits``) keeps it
    within OpenGL's renderbuffer limit.
    """
    width, height = stereo_render_px(camera.width, camera.height)
    return (max(MIN_OFFSCREEN_PX[0], width), max(MIN_OFFSCREEN_PX[1], height))


def _set_offscreen(root: mjcf.RootElement, size_px: tuple[int, int]) -> None:
    """Size the model's off-screen buffer (``<visual><global offwidth offheight>``)."""
    offscreen = getattr(root.visual, "global")
    offscreen.offwidth, offscreen.offheight = size_px


def _merge_piece(root: mjcf.RootElement, name: str) -> None:
    """Merge the MJCF piece ``name`` into ``root``, keeping the names of both."""
    model_name = root.model
    root.include_copy(load_mjcf_piece(name))
    root.model = model_name  # include_copy takes the piece's model name


def _world_root(scenario: Scenario) -> mjcf.RootElement:
    """The scene's root: the world pieces, the off-screen buffer for the scenario's camera."""
    from dm_control import mjcf  # only to build a scene (TYPE_CHECKING import)

    root = mjcf.RootElement(model=f"fogsim_{scenario.name}")
    for name, texture in scene_textures().items():
        root.asset.add("texture", name=name, type="2d", file=mjcf.Asset(texture.png(), ".png"))
    for piece in WORLD_PIECES:
        _merge_piece(root, piece)
    _set_offscreen(root, offscreen_px(scenario.camera))
    return root


def _add_object(
    root: mjcf.RootElement, obj: SceneObject, index: int, seed: int, mocap: bool
) -> mjcf.Element:
    """Add one scenario object (a box mesh, a height field for a rough top or a terrain)."""
    textured = {"dclass": "object"} if obj.texture == "noise" else {}  # the class's texture
    material = root.asset.add(
        "material", name=f"mat_{obj.name}", rgba=_object_colour(index, obj.walkable), **textured
    )
    sz = obj.size[2]
    body = root.worldbody.add(
        "body",
        name=f"obj_{obj.name}",
        pos=[obj.center[0], obj.center[1], obj.base],
        euler=[0.0, 0.0, math.radians(obj.yaw_deg)],
        mocap=mocap,
    )
    if obj.heightfield is not None:
        heights_m = obj.heightfield_m()  # row 0 at +y in both (MuJoCo flips its rows)
        low_m, high_m = float(heights_m.min()), float(heights_m.max())
        span_m = max(high_m - low_m, TERRAIN_MIN_SPAN_M)
        shape = _height_field(root, obj, (heights_m - low_m) / span_m, span_m, low_m)
        kind, z = "hfield", low_m
    elif obj.surface == "rough":
        bumps_from_m = sz - obj.roughness_m
        elevation = rough_elevation(obj, seed, index)
        shape = _height_field(root, obj, elevation, obj.roughness_m, bumps_from_m)
        kind, z = "hfield", bumps_from_m
    else:
        from dm_control import mjcf  # only to build a scene (TYPE_CHECKING import)

        mesh = mesh_file(*box_mesh(obj.size))
        shape = root.asset.add(
            "mesh", name=f"mesh_{obj.name}", file=mjcf.Asset(mesh, ".msh", f"mesh_{obj.name}")
        )
        kind, z = "mesh", 0.5 * sz
    body.add(
        "geom",
        name=f"geom_{obj.name}",
        type=kind,
        pos=[0.0, 0.0, z],
        material=material,
        group=0,
        **{kind: shape},
    )
    return body


def _height_field(
    root: mjcf.RootElement,
    obj: SceneObject,
    elevation: NDArray[np.float64],
    span_m: float,
    low_m: float,
) -> mjcf.Element:
    """The asset ``hf_<name>``: a height field over ``obj``'s footprint.

    Its geom goes ``low_m`` above the object's base (the body's origin, on the footprint centre).

    Args:
        root: The scene's root.
        obj: The object (name and x, y size).
        elevation: (rows, columns) heights in [0, 1], row 0 at the object's +y edge, column 0
            at its -x edge (as an image seen from above: MuJoCo's ``elevation`` order, whose
            rows it flips); the outer samples lie on the footprint's edges.
        span_m: Height of the elevation 1 above the elevation 0 [m].
        low_m: Height of the elevation 0 above the object's base [m]; the solid below it goes
            down to the base, or :data:`TERRAIN_MIN_SPAN_M` below the base when ``low_m`` is 0
            (MuJoCo needs a base).
    """
    from dm_control import mjcf  # only to build a scene (TYPE_CHECKING import)

    return root.asset.add(
        "hfield",
        name=f"hf_{obj.name}",
        file=mjcf.Asset(hfield_file(elevation), ".bin", f"hf_{obj.name}"),
        size=[
            0.5 * obj.size[0],
            0.5 * obj.size[1],
            span_m,
            low_m if low_m > 0.0 else TERRAIN_MIN_SPAN_M,
        ],
    )


def _find(root: mjcf.RootElement, kind: str, name: str, source: str) -> mjcf.Element:
    """The element ``kind`` named ``name``; raises naming ``source`` if it is missing."""
    element = root.find(kind, name)
    if element is None:
        raise FogsimError(f"{source}: no {kind} named {name!r}")
    return element


def _add_camera_rig(root: mjcf.RootElement, camera: CameraConfig) -> None:
    """Merge in the camera rig piece, set up for the scenario's camera.

    The left and right cameras sit half the stereo baseline left and right of ``head_camera``
    (MuJoCo camera frame: x right).
    """
    _merge_piece(root, "camera_rig")
    _find(root, "body", "camera_rig", "assets/mjcf/camera_rig.xml")
    cameras = [_find(root, "camera", name, "assets/mjcf/camera_rig.xml") for name in CAMERA_NAMES]
    offsets_m = (0.0, -0.5 * camera.baseline_m, 0.5 * camera.baseline_m)
    for element, dx in zip(cameras, offsets_m, strict=True):
        element.pos = [dx, 0.0, 0.0]
        element.fovy = camera.fov_deg[1]


def _robot_namespace(robot: Robot) -> str:
    """The robot MJCF's model name: dm_control prefixes the robot's names with ``<name>/``.

    Raises:
        RobotModelError: The robot MJCF's root has no ``model`` attribute.
    """
    for _, element in ElementTree.iterparse(robot.mjcf_path, events=("start",)):
        name = element.get("model")
        if not name:
            raise RobotModelError(f"{robot.mjcf_path}: the <mujoco> root has no model name")
        return name
    raise RobotModelError(f"{robot.mjcf_path}: empty MJCF")


def _attach_robot(root: mjcf.RootElement, robot: Robot, offscreen_size_px: tuple[int, int]) -> None:
    """Attach the robot's MJCF; its free joint moves onto the attachment frame.

    The robot's own MJCF sizes its off-screen buffer for itself; attaching demands equal
    values, so it takes the scene's (``offscreen_size_px``).
    """
    from dm_control import mjcf  # only to build a scene (TYPE_CHECKING import)

    robot_model = mjcf.from_path(str(robot.mjcf_path))
    _set_offscreen(robot_model, offscreen_size_px)
    free = robot_model.find("joint", "root")
    if free is None:
        raise FogsimError(f"{robot.mjcf_path}: the robot MJCF has no free joint named 'root'")
    free.remove()
    frame = root.attach(robot_model)
    frame.add("freejoint", name="root")


def build_scene_mjcf(scenario: Scenario, robot: Robot | None) -> mjcf.RootElement:
    """The scene's MJCF: world pieces, one body per object, the robot or the camera rig."""
    root = _world_root(scenario)
    moving = moving_objects(scenario)
    for index, obj in enumerate(scenario.objects):
        _add_object(root, obj, index, scenario.seed, obj.name in moving)
    if robot is not None:
        _attach_robot(root, robot, offscreen_px(scenario.camera))
    else:
        _add_camera_rig(root, scenario.camera)
    return root


def compile_scene(scenario: Scenario, robot: Robot | None) -> mujoco.MjModel:
    """Compile the scene's MJCF as ``dm_control.mjcf.Physics.from_mjcf_model`` does."""
    root = build_scene_mjcf(scenario, robot)
    return model_from_xml_string(root.to_xml_string(), root.get_assets())


def _scene_inputs(scenario: Scenario) -> tuple[object, ...]:
    """What :func:`build_scene_mjcf` reads of the scenario.

    The camera's mode and noise, the encoders and the route do not enter the model, so
    changing them reuses the compiled scene.
    """
    camera = scenario.camera
    return (
        scenario.name,
        scenario.seed,
        scenario.objects,
        (camera.width, camera.height, camera.fov_deg, camera.baseline_m),
        tuple(sorted(moving_objects(scenario))),
    )


def scene_key(scenario: Scenario, robot: Robot | None) -> str:
    """Content key of the compiled scene: everything :func:`compile_scene` reads.

    The scenario's part that builds the model (its ``repr``), the robot's MJCF file and its
    mesh files (:func:`fogsim.robot.mjcf.mjcf_files`), every file of ``assets/mjcf`` (pieces,
    textures), the source of this module and of :mod:`fogsim.sim.assets` (which generates the
    textures), the MuJoCo and dm_control versions and the heights of every terrain's image.
    """
    pieces = tuple(path.read_bytes() for path in sorted(MJCF_DIR.iterdir()) if path.is_file())
    terrains = tuple(
        obj.heightfield_m().tobytes() for obj in scenario.objects if obj.heightfield is not None
    )
    return content_key(
        (
            repr(_scene_inputs(scenario)).encode(),
            *(path.read_bytes() for path in (mjcf_files(robot.mjcf_path) if robot else ())),
            *pieces,
            *terrains,
            Path(__file__).read_bytes(),
            Path(assets.__file__).read_bytes(),
            f"mujoco {mujoco.__version__} dm_control {version('dm_control')}".encode(),
        )
    )


def _id(model: mujoco.MjModel, kind: mujoco.mjtObj, name: str) -> int:
    """MuJoCo id of the element ``kind`` named ``name``; raises if the model has none."""
    element_id = mujoco.mj_name2id(model, kind, name)
    if element_id < 0:
        raise FogsimError(f"compiled scene: no {kind.name} named {name!r}")
    return element_id


# ---------------------------------------------------------------------- the scene


class Scene:
    """A compiled scene and by-name access to its state.

    The compiled model comes from the content-keyed cache (:mod:`fogsim.sim.model_cache`):
    the MJCF is built and compiled only when the scenario, robot, pieces or this module change.

    Args:
        scenario: The scenario to build.
        robot: The robot to attach, or None for the free camera rig.

    Attributes:
        scenario: The scenario it was built from.
        model: The compiled ``mujoco.MjModel``.
        data: Its ``mujoco.MjData``.
        physics: dm_control's view of ``model`` and ``data`` (made on first use).
        has_robot: True if a robot is attached, False for the free camera rig.
        camera_ids: MuJoCo camera id of each of ``CAMERA_NAMES``.
        render_geomgroups: Geom groups the renderer draws (0, 1, 2); ray casts use the same.
    """

    def __init__(self, scenario: Scenario, robot: Robot | None = None) -> None:
        self.scenario = scenario
        self.has_robot = robot is not None
        self._moving = moving_objects(scenario)
        self.model: mujoco.MjModel = load_or_compile(
            scene_key(scenario, robot), lambda: compile_scene(scenario, robot)
        )
        self.data = mujoco.MjData(self.model)
        # dm_control's Physics ran one mj_forward on a fresh MjData; kept so the state matches.
        mujoco.mj_forward(self.model, self.data)
        prefix = f"{_robot_namespace(robot)}/" if robot is not None else ""
        self.camera_ids = {
            name: _id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, prefix + name)
            for name in CAMERA_NAMES
        }
        self.render_geomgroups = VISIBLE_GEOMGROUPS
        self._mocap_ids = {name: self._mocap_id(f"obj_{name}") for name in self._moving}
        self._robot_qpos_address = (
            self._robot_qpos_addresses(robot, prefix) if robot is not None else None
        )
        self._rig_mocap_id = self._mocap_id("camera_rig") if robot is None else None
        self.set_time(0.0)
        self.forward()

    @functools.cached_property
    def physics(self) -> dm_mujoco.Physics:
        """A ``dm_control.mujoco.Physics`` over this scene's model and data (shared, not copied).

        For dm_control's renderer and named indexing; creating it runs one ``mj_forward``.
        """
        from dm_control import mujoco as dm_mujoco  # only for dm_control users
        from dm_control.mujoco import wrapper as dm_wrapper

        return dm_mujoco.Physics(dm_wrapper.MjData(self.data))

    def _mocap_id(self, body_name: str) -> int:
        """Mocap id of the mocap body ``body_name``."""
        return int(self.model.body_mocapid[_id(self.model, mujoco.mjtObj.mjOBJ_BODY, body_name)])

    def _robot_qpos_addresses(self, robot: Robot, prefix: str) -> NDArray[np.intp]:
        """Scene qpos index of every entry of the robot's standalone qpos.

        The free joint on dm_control's attachment frame is named ``<prefix>root/``.
        """
        free = _id(self.model, mujoco.mjtObj.mjOBJ_JOINT, f"{prefix}root/")
        free_address = int(self.model.jnt_qposadr[free])
        addresses = list(range(free_address, free_address + 7))
        for name in robot.mujoco_joint_names[1:]:
            joint = _id(self.model, mujoco.mjtObj.mjOBJ_JOINT, prefix + name)
            addresses.append(int(self.model.jnt_qposadr[joint]))
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
        if self._robot_qpos_address is None:
            raise FogsimError("this scene has no robot (it was built with the camera rig)")
        qpos = np.asarray(qpos_standalone, dtype=np.float64)
        if qpos.shape != self._robot_qpos_address.shape:
            raise FogsimError(
                f"robot qpos must have {self._robot_qpos_address.size} entries, got {qpos.shape}"
            )
        self.data.qpos[self._robot_qpos_address] = qpos

    def set_camera_rig_pose(self, transform_camera_to_world: ArrayLike) -> None:
        """Place the free camera rig so ``head_camera`` has this OpenCV pose (4×4, world)."""
        if self._rig_mocap_id is None:
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
