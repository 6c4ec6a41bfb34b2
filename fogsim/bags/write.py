"""The FOG of every frame into a rosbag2 bag in MCAP storage (``fogsim run --mcap BAG``).

Per frame, at the frame's stamp: ``/fogsim/grid_map`` (``grid_map_msgs/msg/GridMap``, the
robot-centred grid, :mod:`fogsim.bags.gridmap`) and ``/fogsim/robot_pose``
(``geometry_msgs/msg/PoseStamped``, the believed robot pose R: odometry's x, y, z, yaw). Both
in the frame :data:`WORLD_FRAME_ID`. Foxglove opens ``BAG/BAG.mcap``; ROS 2 plays ``BAG``
(``ros2 bag play BAG``; grid_map's RViz plugin shows the GridMap).

The bag is a folder (``metadata.yaml`` and one ``.mcap`` file, rosbags'
:class:`~rosbags.rosbag2.Writer`), written into an owned temporary folder beside ``BAG`` and
renamed into place when the run ends: complete or absent; a failed run leaves an earlier bag
there as it was. Only a new path or an earlier bag (those two files and nothing else) may be
written over.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from types import TracebackType
from typing import Any

from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.errors import WriterError
from rosbags.typesys import Stores, get_typestore

from fogsim.atomic import make_temporary_folder, reason, remove_stale_temporaries, temporary_path
from fogsim.bags.gridmap import (
    GRID_MAP_TYPE,
    grid_map_message,
    pose_message,
    register_grid_map_types,
    stamp,
)
from fogsim.data.frame import Frame
from fogsim.errors import OutputError
from fogsim.mapping.pipeline import Pipeline

WORLD_FRAME_ID = "odom"
"""The maps' frame: the world of the believed poses, which is odometry's (REP 105 ``odom``;
a simulated run's world is the stage's, where odometry starts)."""

GRID_MAP_TOPIC = "/fogsim/grid_map"
POSE_TOPIC = "/fogsim/robot_pose"
POSE_TYPE = "geometry_msgs/msg/PoseStamped"
TYPE_STORE = Stores.ROS2_HUMBLE
"""The message definitions written into the bag: Humble's (the oldest supported ROS 2 LTS);
Header, Pose and Float32MultiArray are the same in every ROS 2 release since."""


def check_bag_target(path: str | os.PathLike[str], what: str) -> Path:
    """``path`` may receive a bag: it is new, or an earlier bag (``metadata.yaml`` + ``.mcap``).

    Raises:
        OutputError: It is a file, or a folder holding anything else (naming it).
    """
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise OutputError(f"{what} {target}: is a file; a bag is a folder (give a new path)")
    if target.is_dir():
        allowed = {"metadata.yaml", f"{target.name}.mcap"}
        foreign = sorted(p.name for p in target.iterdir() if p.name not in allowed)
        if foreign:
            raise OutputError(
                f"{what} {target}: holds {target / foreign[0]}, which is not a bag fogsim wrote; "
                "a bag is replaced whole: choose a new path or move it away"
            )
    return target


class McapMapWriter:
    """Writes the pipeline's FOG per frame; a frame callback (:meth:`add`) and context manager.

    ``with McapMapWriter(path) as writer: ... writer.add(frame, pipeline) ...``: on a normal
    exit the bag is moved into place; on an error nothing of it is left.
    """

    def __init__(self, path: str | os.PathLike[str], frame_id: str = WORLD_FRAME_ID) -> None:
        self.path = check_bag_target(path, "--mcap")
        self.frame_id = frame_id
        self.typestore = get_typestore(TYPE_STORE)
        register_grid_map_types(self.typestore)
        self._folder: Path | None = None
        self._writer: Writer | None = None
        self._connections: dict[str, Any] = {}
        self.messages = 0

    def __enter__(self) -> McapMapWriter:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            remove_stale_temporaries(self.path.parent)
            self._folder = make_temporary_folder(self.path)
            self._writer = Writer(
                self._folder / self.path.name, version=9, storage_plugin=StoragePlugin.MCAP
            )
            # MCAP's own zstd chunk compression (every MCAP reader has it): a grid is mostly
            # unknown (NaN): the tests' 10 frames of 100 × 100 cells shrink from 2 MB to 17 kB.
            self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
            self._writer.set_custom_data("created_by", "fogsim")
            self._writer.open()
        except (OSError, WriterError) as exc:
            self._discard()
            raise OutputError(f"cannot write {self.path}: {_why(exc)}") from exc
        for topic, msgtype in ((GRID_MAP_TOPIC, GRID_MAP_TYPE), (POSE_TOPIC, POSE_TYPE)):
            self._connections[topic] = self._writer.add_connection(
                topic, msgtype, typestore=self.typestore
            )
        return self

    def add(self, frame: Frame, pipeline: Pipeline) -> None:
        """Write the frame's GridMap and robot pose at the frame's stamp."""
        assert self._writer is not None, "use McapMapWriter as a context manager"
        stamp_ns = round(frame.time_s * 1e9)
        if stamp_ns < 0:
            raise OutputError(
                f"--mcap {self.path}: frame {frame.index} has time_s = {frame.time_s} s; a bag's "
                "stamps start at 0 (ROS time)"
            )
        types, heights = pipeline.mapper.fog()
        layers = {
            "fog_height": heights,
            "fog_type": types,
            "floor": pipeline.mapper.floor(),
            "obstacle": pipeline.mapper.obstacle(),
            "ceiling": pipeline.mapper.ceiling(),
        }
        grid_map = grid_map_message(
            self.typestore, pipeline.mapper.geometry, layers, stamp_ns, self.frame_id
        )
        x, y, z, yaw = (float(v) for v in frame.robot_pose_believed)
        pose = self.typestore.types[POSE_TYPE](
            header=self.typestore.types["std_msgs/msg/Header"](
                stamp=stamp(self.typestore, stamp_ns), frame_id=self.frame_id
            ),
            pose=pose_message(self.typestore, (x, y, z), yaw),
        )
        for topic, msgtype, message in (
            (GRID_MAP_TOPIC, GRID_MAP_TYPE, grid_map),
            (POSE_TOPIC, POSE_TYPE, pose),
        ):
            data = self.typestore.serialize_cdr(message, msgtype)
            try:
                self._writer.write(self._connections[topic], stamp_ns, data)
            except OSError as exc:
                raise OutputError(f"cannot write {self.path}: {reason(exc)}") from exc
            self.messages += 1

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        if exc_type is not None:
            self._discard()
            return
        assert self._writer is not None and self._folder is not None
        try:
            self._writer.close()
            self._writer = None
            check_bag_target(self.path, "--mcap")
            old = None
            if self.path.exists():
                old = temporary_path(self.path, "old")
                os.replace(self.path, old)
            os.replace(self._folder / self.path.name, self.path)
            if old is not None:
                shutil.rmtree(old)
        except (OSError, WriterError) as exc:
            self._discard()
            raise OutputError(f"cannot write {self.path}: {_why(exc)}") from exc
        self._discard()

    def _discard(self) -> None:
        """Remove the temporary folder (and whatever of the bag is in it)."""
        if self._writer is not None:
            writer, self._writer = self._writer, None
            writer.abort()  # closes the storage's file; the folder goes next
        if self._folder is not None:
            shutil.rmtree(self._folder, ignore_errors=True)
            self._folder = None


def _why(exc: BaseException) -> str:
    """The system's reason for an OSError, else the message."""
    return reason(exc) if isinstance(exc, OSError) else str(exc)
