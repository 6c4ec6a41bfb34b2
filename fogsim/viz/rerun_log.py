"""A Rerun recording (``.rrd``) of a run: what the camera saw and what the maps made of it.

:class:`RerunLogger` is the pipeline's frame callback (``run_frames(..., on_frame=logger.add)``,
like :class:`fogsim.viz.video.RunVideoWriter`). Every frame is logged on two timelines,
``frame`` (the frame index) and ``sim_time`` (the frame's time), world frame z up, metres:

============================  ==========================================================
entity                        what
============================  ==========================================================
``camera/depth``              the depth image [m] (0 = no measurement, Rerun's convention)
``world/camera``              the believed camera pose and its pinhole (a frustum in 3D)
``world/points/floor``        the frame's points the segmentation put on a floor plane,
                              coloured by that plane's height (:data:`~fogsim.viz.style.CMAP`)
``world/points/obstacle``     its other points, red
``world/occupied``            the occupied cells of the 3-D grid (``p > p_occ``), as boxes
``world/fog/floor``           the FOG's floor cells: flat tiles at their height, coloured by it
``world/fog/obstacle``        the FOG's obstacle cells: tiles at their coarse height, black
``world/robot/believed``      the robot's believed (x, y, z) (odometry + elevation filter)
``world/robot/true``          its true (x, y, z)
``world/truth``               the scene's objects (wire boxes), logged at the first frame and
                              again only when an event changes them
``world/robot/path_believed`` both paths as lines, static (visible at every time), written
``world/robot/path_true``     when the logger closes
============================  ==========================================================

Work per frame is bounded by the image and the robot-centred grid (the occupancy grid's
``nx·ny·nz`` cells are scanned once), never by the run's length.

The labelled points are the pipeline's own (``Pipeline.last_points``): the frame's points as the
maps received them, with the heading correction and the z shift applied (a withdrawn frame's
points are logged too: what the maps refused).

``rerun-sdk`` is an optional dependency (the ``viewer`` extra, a 170 MB wheel): it is imported
when a logger is made, and its absence is a :class:`~fogsim.errors.FogsimError` saying how to
install it. The file is written beside its target and renamed into place when the logger
closes without an error (complete or absent). Instead of a file the logger can stream to a
Rerun viewer it spawns (``spawn=True``, ``fogsim run --rerun-spawn``): that needs a display,
and on Linux without ``DISPLAY`` or ``WAYLAND_DISPLAY`` (:func:`check_display`) it is a
:class:`~fogsim.errors.FogsimError` before anything runs. Its logged data depend only on the
frames; Rerun stamps its row ids with the wall clock, so two files of one run are not byte for
byte equal.
"""

from __future__ import annotations

import os
import shutil
import sys
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType, TracebackType
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import Normalize
from numpy.typing import NDArray

from fogsim.atomic import OutputError, reason, temporary_path
from fogsim.data.frame import Frame
from fogsim.errors import FogsimError
from fogsim.eval.events import TruthProvider
from fogsim.mapping.pipeline import Pipeline
from fogsim.viz.style import CMAP, OBSTACLE_RGB, height_norm
from fogsim.world.timeline import ObjectState
from mapper import MapperParams
from mapper.grid import CellType
from mapper.transforms import planar_pose_to_matrix

APPLICATION_ID = "fogsim"
"""Rerun application id of every recording the testbed writes."""
FRAME_TIMELINE = "frame"
"""Sequence timeline: the frame index."""
TIME_TIMELINE = "sim_time"
"""Duration timeline: the frame's simulation time [s]."""
OBSTACLE_POINT_RGB = (1.0, 0.0, 0.0)
"""Colour of the points the segmentation left off every floor plane."""
BELIEVED_RGB8 = (40, 120, 255)
"""The believed robot position and path (blue)."""
TRUE_RGB8 = (255, 255, 255)
"""The true robot position and path (white, on Rerun's dark background)."""
WALKABLE_RGB8 = (255, 160, 40)
"""Outline of a walkable object of the truth (warm, as the scene's materials)."""
OBJECT_RGB8 = (80, 140, 255)
"""Outline of any other object of the truth (cool, as the scene's materials)."""
TILE_HALF_THICKNESS_M = 0.002
"""Half thickness of a FOG tile [m]: thin against the 40 mm layers, thick enough to render."""
DISPLAY_VARIABLES = ("DISPLAY", "WAYLAND_DISPLAY")
"""Environment variables that name a display on Linux: X11's and Wayland's. macOS and Windows
always have their desktop."""


def check_display(environ: Mapping[str, str] | None = None, platform: str = sys.platform) -> None:
    """Check that a spawned Rerun viewer has a display to open its window on.

    Args:
        environ: The environment (default ``os.environ``).
        platform: ``sys.platform``; only Linux and the BSDs are checked.

    Raises:
        FogsimError: Neither :data:`DISPLAY_VARIABLES` is set (a headless machine); the message
            says to write a file instead.
    """
    environ = os.environ if environ is None else environ
    if platform in ("darwin", "win32", "cygwin") or any(environ.get(v) for v in DISPLAY_VARIABLES):
        return
    raise FogsimError(
        "the Rerun viewer needs a display to open its window on, and this machine has none: "
        f"neither {' nor '.join(DISPLAY_VARIABLES)} is set; write a file instead "
        "(fogsim run ... --rerun FILE.rrd) and open it with `rerun FILE.rrd` where there is a "
        "display"
    )


def _import_rerun() -> ModuleType:
    """The ``rerun`` module.

    Raises:
        FogsimError: rerun-sdk is not installed (the message says how to install it).
    """
    try:
        import rerun
    except ImportError as exc:
        raise FogsimError(
            "the Rerun viewer file needs the optional dependency rerun-sdk: "
            "pip install 'fogsim[viewer]'"
        ) from exc
    return rerun


def _rgb_u8(rgb: NDArray[np.float64]) -> NDArray[np.uint8]:
    """(N, 3) colours in [0, 1] → (N, 3) uint8."""
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)


def height_colours(heights_m: NDArray[np.float64], norm: Normalize) -> NDArray[np.uint8]:
    """(N, 3) uint8 colours of heights [m] on :data:`~fogsim.viz.style.CMAP` over ``norm`` [mm]."""
    return _rgb_u8(plt.get_cmap(CMAP)(norm(np.asarray(heights_m) * 1000.0))[:, :3])


def colour_norm(truth_objects: tuple[ObjectState, ...] | None, params: MapperParams) -> Normalize:
    """Height colours [mm] of a recording, fixed for all its frames.

    From the ground to the highest object top of the truth when there is one (the heights the
    map should show); without truth the mapper grid's z range (every height it can hold).
    """
    if truth_objects is None:
        return Normalize(params.z_min_m * 1000.0, params.z_max_m * 1000.0)
    return height_norm(np.array([0.0, *(o.top_m for o in truth_objects)]))


def viewer_executable() -> str:
    """The Rerun viewer to spawn: ``rerun`` on the PATH, else the one beside this Python.

    rerun-sdk installs the viewer as the ``rerun`` command next to the interpreter; Rerun itself
    looks for it on the PATH only, which misses it when a virtual environment's Python runs
    without the environment activated (``.venv/bin/fogsim``, as the README's commands do).
    """
    return shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))


class RerunLogger:
    """Writes a run into a Rerun ``.rrd`` file, one frame at a time (see the module docstring).

    Use as a context manager: the file is moved into place when the block ends without an
    exception, its temporary removed otherwise. :meth:`add` is the pipeline's frame callback.

    Args:
        path: The ``.rrd`` file to write; None with ``spawn``.
        recording_id: Rerun's recording id (the viewer merges files of one id; name the run,
            e.g. ``stage-seed1``).
        truth_at: The ground truth at a time [s]; None for real data (no ``world/truth``).
        spawn: Stream to a Rerun viewer spawned now instead of writing a file (the viewer can
            save what it shows).

    Raises:
        FogsimError: rerun-sdk is not installed; a path and ``spawn`` both or neither given;
            ``spawn`` without a display (:func:`check_display`) or the viewer does not start.
        OutputError: The file's folder cannot be made or the file cannot be created.
    """

    def __init__(
        self,
        path: str | os.PathLike[str] | None,
        recording_id: str,
        truth_at: TruthProvider | None = None,
        *,
        spawn: bool = False,
    ) -> None:
        if (path is None) != spawn:
            raise FogsimError(
                "a Rerun log goes to a file or to a spawned viewer: give a path or spawn=True, "
                f"got path={path!r}, spawn={spawn}"
            )
        if spawn:
            check_display()
        self._rr = _import_rerun()
        self.path = Path(path) if path is not None else None
        self._truth_at = truth_at
        self._stream: Any = self._rr.RecordingStream(
            APPLICATION_ID, recording_id=recording_id, send_properties=False
        )
        self._rr.set_log_time_enabled(False, recording=self._stream)
        self._rr.set_log_tick_enabled(False, recording=self._stream)
        self._tmp = self._open_file(self.path) if self.path is not None else None
        if spawn:
            try:
                self._rr.spawn(recording=self._stream, executable_path=viewer_executable())
            except RuntimeError as exc:  # Rerun reports a viewer that cannot start as text
                raise FogsimError(f"cannot start the Rerun viewer: {exc}") from exc
        self._stream.log("world", self._rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._norm: Normalize | None = None
        self._objects: tuple[ObjectState, ...] | None = None
        self._path_believed: list[NDArray[np.float64]] = []
        self._path_true: list[NDArray[np.float64]] = []

    def _open_file(self, path: Path) -> Path:
        """Start writing into the temporary beside ``path``; returns the temporary.

        Raises:
            OutputError: The folder cannot be made or the file cannot be created.
        """
        tmp = temporary_path(path, suffix=".rrd")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._stream.save(str(tmp))
        except OSError as exc:
            raise OutputError(f"cannot write {path}: {reason(exc)}") from exc
        except RuntimeError as exc:  # Rerun's file sink reports its OS error as text
            raise OutputError(f"cannot write {path}: {exc}") from exc
        return tmp

    def __enter__(self) -> RerunLogger:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.close()
        else:
            self._stream.disconnect()
            if self._tmp is not None:
                self._tmp.unlink(missing_ok=True)

    def add(self, frame: Frame, pipeline: Pipeline) -> None:
        """Log one frame: depth, camera, labelled points, occupied cells, FOG, poses, truth."""
        rr, stream = self._rr, self._stream
        stream.set_time(FRAME_TIMELINE, sequence=frame.index)
        stream.set_time(TIME_TIMELINE, duration=frame.time_s)
        truth = self._truth_at(frame.time_s) if self._truth_at is not None else None
        if self._norm is None:
            self._norm = colour_norm(
                truth.objects if truth is not None else None, pipeline.mapper_params
            )
        if truth is not None and truth.objects != self._objects:
            self._objects = truth.objects
            stream.log("world/truth", _truth_boxes(rr, truth.objects))
        pose = pipeline.robot_pose(frame)
        self._log_camera(frame, pose)
        self._log_points(pipeline, self._norm)
        self._log_maps(pipeline, self._norm)
        self._path_believed.append(pose[:3].copy())
        self._path_true.append(np.asarray(frame.robot_pose_true, dtype=np.float64)[:3].copy())
        stream.log("world/robot/believed", rr.Points3D([pose[:3]], colors=[BELIEVED_RGB8]))
        stream.log("world/robot/true", rr.Points3D([self._path_true[-1]], colors=[TRUE_RGB8]))

    def _log_camera(self, frame: Frame, pose: NDArray[np.float64]) -> None:
        """The depth image and the believed camera pose with its pinhole."""
        rr, stream = self._rr, self._stream
        depth = np.nan_to_num(np.asarray(frame.depth_m, dtype=np.float32), nan=0.0)
        stream.log("camera/depth", rr.DepthImage(depth, meter=1.0))
        camera_to_world = planar_pose_to_matrix(pose) @ np.asarray(
            frame.transform_camera_to_robot_believed, dtype=np.float64
        )
        intr = frame.intrinsics
        stream.log(
            "world/camera",
            rr.Transform3D(translation=camera_to_world[:3, 3], mat3x3=camera_to_world[:3, :3]),
            rr.Pinhole(
                focal_length=[intr.fx, intr.fy],
                principal_point=[intr.cx, intr.cy],
                width=intr.width,
                height=intr.height,
                camera_xyz=rr.ViewCoordinates.RDF,  # OpenCV: x right, y down, z forward
                image_plane_distance=0.2,
            ),
        )

    def _log_points(self, pipeline: Pipeline, norm: Normalize) -> None:
        """The frame's points in the world: on a floor plane by its height, the others red."""
        rr, stream = self._rr, self._stream
        labelled = pipeline.last_points
        if labelled is None:
            return
        points_world, floor_heights_m = labelled.points_world, labelled.floor_heights_m
        on_floor = np.isfinite(floor_heights_m)
        stream.log(
            "world/points/floor",
            rr.Points3D(
                points_world[on_floor],
                colors=height_colours(floor_heights_m[on_floor], norm),
            ),
        )
        stream.log(
            "world/points/obstacle",
            rr.Points3D(
                points_world[~on_floor],
                colors=_rgb_u8(np.array([OBSTACLE_POINT_RGB])),
            ),
        )

    def _log_maps(self, pipeline: Pipeline, norm: Normalize) -> None:
        """The occupied cells of the 3-D grid and the FOG of the robot-centred grid."""
        rr, stream = self._rr, self._stream
        mapper, params = pipeline.mapper, pipeline.mapper_params
        ix, iy, iz = np.nonzero(mapper.occupancy_levels() > params.occ_threshold_level)
        occupied = np.asarray(mapper.cell_center(ix, iy, iz), dtype=np.float64).reshape(-1, 3)
        stream.log(
            "world/occupied",
            rr.Boxes3D(
                centers=occupied,
                half_sizes=[(0.5 * params.cell_m, 0.5 * params.cell_m, 0.5 * params.layer_m)],
                colors=height_colours(occupied[:, 2], norm),
            ),
        )
        types, heights_m, _ = pipeline.maps()
        centers_xy = pipeline.cell_centers_xy()
        tile = [(0.5 * params.cell_m, 0.5 * params.cell_m, TILE_HALF_THICKNESS_M)]
        for kind, name in ((CellType.FLOOR, "floor"), (CellType.OBSTACLE, "obstacle")):
            cells = types == kind
            centers = np.column_stack([centers_xy[cells], heights_m[cells]])
            colours = (
                height_colours(heights_m[cells], norm)
                if kind == CellType.FLOOR
                else _rgb_u8(np.array([OBSTACLE_RGB]))
            )
            stream.log(
                f"world/fog/{name}",
                rr.Boxes3D(centers=centers, half_sizes=tile, colors=colours, fill_mode="solid"),
            )

    def close(self) -> None:
        """Log both robot paths, finish the file and move it into place (or end the stream).

        Raises:
            OutputError: The file cannot be finished or moved into place.
            FogsimError: The spawned viewer did not take the log (it could not open its window
                or was closed).
        """
        rr, stream = self._rr, self._stream
        for name, path, colour in (
            ("path_believed", self._path_believed, BELIEVED_RGB8),
            ("path_true", self._path_true, TRUE_RGB8),
        ):
            if path:
                stream.log(
                    f"world/robot/{name}",
                    rr.LineStrips3D([np.stack(path)], colors=[colour]),
                    static=True,
                )
        try:
            stream.flush()
        except RuntimeError as exc:  # Rerun reports a sink that failed as text
            stream.disconnect()
            if self._tmp is None or self.path is None:
                raise FogsimError(f"the Rerun viewer did not take the log: {exc}") from exc
            self._tmp.unlink(missing_ok=True)
            raise OutputError(f"cannot write {self.path}: {exc}") from exc
        stream.disconnect()
        if self._tmp is None or self.path is None:
            return
        try:
            os.replace(self._tmp, self.path)
        except OSError as exc:
            self._tmp.unlink(missing_ok=True)
            raise OutputError(f"cannot write {self.path}: {reason(exc)}") from exc


def _truth_boxes(rr: ModuleType, objects: tuple[ObjectState, ...]) -> Any:
    """The objects as wire boxes (walkable ones orange, the others blue), labelled by name."""
    return rr.Boxes3D(
        centers=[(*o.center_xy, o.base_m + 0.5 * o.size[2]) for o in objects],
        half_sizes=[tuple(0.5 * s for s in o.size) for o in objects],
        rotation_axis_angles=[
            rr.RotationAxisAngle(axis=(0, 0, 1), radians=o.yaw_rad) for o in objects
        ],
        colors=[WALKABLE_RGB8 if o.walkable else OBJECT_RGB8 for o in objects],
        labels=[o.name for o in objects],
    )
