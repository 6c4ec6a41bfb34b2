"""The robot seen from outside: a camera following it over the course, for the run video.

:class:`ThirdPersonCamera` renders the scene off-screen (``mujoco.Renderer``; EGL when headless,
as the head camera's depth) from a free camera that looks at the robot's root body (the body of
the scene's free joint: the iCub's and TALOS's pelvis) from a fixed distance and direction in
the world, so the robot stays in the middle of the picture while the course passes by. The
look-at point is the root body's position (``data.xpos``, set by ``mj_kinematics``), nothing
the physics would have to compute.

The simulation calls :meth:`ThirdPersonCamera.capture` once per frame with the frame's index,
after it posed the robot (``Simulation.frames(on_pose=...)``), and the video writer takes the
picture of that frame with :meth:`ThirdPersonCamera.take`: pictures wait between the two only
while the frame is in the pipeline. Nothing is rendered unless a video is asked for.
"""

from __future__ import annotations

import weakref
from collections.abc import Iterator

import mujoco
import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.sim.camera.depth import VISIBLE_GEOMGROUPS, scene_option
from fogsim.sim.simulation import Simulation
from fogsim.world import SceneTruth

VIEW_PX = (480, 360)
"""(width, height) of the picture [px]: the run video's panel height (360 px), 4:3, and within
every scene's off-screen buffer (at least 640 × 480, :data:`fogsim.sim.scene.MIN_OFFSCREEN_PX`).
About 50–90 ms a picture on this 2-core machine's CPU renderer (llvmpipe)."""
DISTANCE_M = 3.0
"""Distance from the robot's root body to the camera [m]: with MuJoCo's 45° vertical field of
view the 1.04 m iCub fills about a third of the picture's height and the next 1–2 m of the
course (the stage's boxes, the sill, the staircase) are in view around it."""
AZIMUTH_DEG = 60.0
"""Direction the camera looks in, from the world's +x axis, counter-clockwise [deg]: the scenario
routes run along +x, so the camera stands 30° behind the robot's right side and sees both the
robot and where it walks to."""
ELEVATION_DEG = -20.0
"""Camera pitch [deg], negative looking down: the treads of steps and the tops of boxes show."""


def robot_root_body(model: mujoco.MjModel) -> int:
    """Id of the robot's root body: the body of the scene's only free joint.

    Scene objects are fixed or mocap bodies, so the free joint is the robot's
    (:mod:`fogsim.sim.scene`).

    Raises:
        FogsimError: The scene has no free joint (no robot: the camera-rig scene) or several.
    """
    free = np.flatnonzero(model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    if free.size != 1:
        raise FogsimError(
            f"the third-person view follows the robot: the scene needs exactly one free joint "
            f"(the robot's), it has {free.size}"
        )
    return int(model.jnt_bodyid[free[0]])


class ThirdPersonCamera:
    """Pictures of the robot from a camera following it (see the module docstring).

    Args:
        model: The scene's compiled model (with the robot).
        size_px: (width, height) of the pictures [px]; within the model's off-screen buffer.
        distance_m: Distance from the robot's root body [m].
        azimuth_deg: Viewing direction from the world's +x axis [deg].
        elevation_deg: Pitch [deg], negative looking down.
        geomgroups: Geom groups that are visible (the head camera's).

    Raises:
        FogsimError: The scene has no robot, or the size does not fit the off-screen buffer.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        size_px: tuple[int, int] = VIEW_PX,
        distance_m: float = DISTANCE_M,
        azimuth_deg: float = AZIMUTH_DEG,
        elevation_deg: float = ELEVATION_DEG,
        geomgroups: tuple[int, ...] = VISIBLE_GEOMGROUPS,
    ) -> None:
        self._body = robot_root_body(model)
        width, height = size_px
        buffer_px = (model.vis.global_.offwidth, model.vis.global_.offheight)
        if not (0 < width <= buffer_px[0] and 0 < height <= buffer_px[1]):
            raise FogsimError(
                f"third-person size_px {size_px} must be positive and within the model's "
                f"off-screen buffer {buffer_px}"
            )
        self._renderer = mujoco.Renderer(model, height, width)
        # Free the GL context when collected or at exit, before EGL itself is torn down.
        self._finalizer = weakref.finalize(self, self._renderer.close)
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._camera.distance = distance_m
        self._camera.azimuth = azimuth_deg
        self._camera.elevation = elevation_deg
        self._option = scene_option(geomgroups)
        self._pictures: dict[int, NDArray[np.uint8]] = {}

    def render(self, data: mujoco.MjData) -> NDArray[np.uint8]:
        """(height, width, 3) RGB picture of the current state (after ``mj_kinematics``)."""
        self._camera.lookat[:] = data.xpos[self._body]
        self._renderer.update_scene(data, camera=self._camera, scene_option=self._option)
        return self._renderer.render()

    def capture(self, index: int, data: mujoco.MjData) -> None:
        """Render frame ``index``'s picture and keep it for :meth:`take` (the simulation's hook)."""
        self._pictures[index] = self.render(data)

    def take(self, index: int) -> NDArray[np.uint8]:
        """Frame ``index``'s picture, handed over once.

        Raises:
            FogsimError: No picture was captured for that frame (or it was taken already).
        """
        try:
            return self._pictures.pop(index)
        except KeyError:
            raise FogsimError(
                f"no third-person picture of frame {index}: the simulation captures one per "
                f"frame (Simulation.frames(on_pose=camera.capture)); captured: "
                f"{sorted(self._pictures)}"
            ) from None

    def close(self) -> None:
        """Free the OpenGL context (idempotent)."""
        self._finalizer()


class FilmedSimulation:
    """A simulation whose frames come with third-person pictures (the run video's panel).

    Made on the thread that steps the simulation (:class:`~fogsim.sim.background.
    BackgroundSimulation` builds it there): the camera's OpenGL context is created, used and
    freed on that thread; :meth:`ThirdPersonCamera.take` may be called from any thread.

    Args:
        simulation: The simulation to film; its scene must hold the robot.
    """

    def __init__(self, simulation: Simulation) -> None:
        self.simulation = simulation
        self.camera = ThirdPersonCamera(simulation.scene.model)

    @property
    def frame_count(self) -> int:
        """Frames :meth:`frames` yields."""
        return self.simulation.frame_count

    def frames(self) -> Iterator[Frame]:
        """The simulation's frames, each with its picture captured."""
        return self.simulation.frames(on_pose=self.camera.capture)

    def truth_at(self, time_s: float) -> SceneTruth:
        """The simulation's ground truth at ``time_s`` [s]."""
        return self.simulation.truth_at(time_s)

    def close(self) -> None:
        """Free the camera's and the simulation's renderers."""
        self.camera.close()
        self.simulation.close()
