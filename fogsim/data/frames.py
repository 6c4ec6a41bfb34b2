"""A recording's frames, built one at a time: only one frame's depth image is in memory.

:class:`RecordedFrames` is the ``frames`` of a loaded :class:`~fogsim.data.recording.Recording`:
a sequence of :class:`~fogsim.data.frame.Frame` whose small per-frame arrays (times, poses,
transforms: :class:`FrameColumns`) were read and checked at load, and whose depth images are
read from the file when a frame is asked for (iteration reads the file once, front to back;
``frames[i]`` inflates the file up to frame ``i``). A replay's memory is thus bounded by one
frame's depth, not by the file's size.

Sent to another process (pickled: tune's Ray workers), the frames take their depth along in
memory (:class:`DepthArray`), since the file may not exist where they go.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, overload

import numpy as np
from numpy.typing import NDArray

from fogsim.data.frame import Frame
from fogsim.data.limits import MAX_PICKLED_DEPTH_BYTES
from fogsim.data.npz import ArrayHeader, NpzArchive
from fogsim.errors import RecordingError
from mapper.intrinsics import PinholeIntrinsics


@dataclass(frozen=True)
class FrameColumns:
    """Every per-frame value of a recording except the depth images, one row per frame.

    Attributes:
        intrinsics: Depth camera intrinsics shared by all frames.
        time_s: (T,) frame times [s], strictly increasing.
        transform_camera_to_robot_believed: (T, 4, 4) believed camera pose in the robot frame.
        robot_pose_believed: (T, 4) believed robot pose (x, y, z [m], yaw [rad]) in the world.
        transform_camera_to_world_true: (T, 4, 4) true camera pose, NaN = unknown.
        robot_pose_true: (T, 4) true robot pose, NaN = unknown.
        self_filtered_pixels: (T,) pixels the self-filter removed.
    """

    intrinsics: PinholeIntrinsics
    time_s: NDArray[np.float64]
    transform_camera_to_robot_believed: NDArray[np.float64]
    robot_pose_believed: NDArray[np.float64]
    transform_camera_to_world_true: NDArray[np.float64]
    robot_pose_true: NDArray[np.float64]
    self_filtered_pixels: NDArray[np.int64]

    def frame(self, row: int, depth_m: NDArray[np.float32]) -> Frame:
        """Frame ``row`` with its depth image."""
        return Frame(
            index=row,
            time_s=float(self.time_s[row]),
            depth_m=depth_m,
            intrinsics=self.intrinsics,
            transform_camera_to_robot_believed=self.transform_camera_to_robot_believed[row],
            robot_pose_believed=self.robot_pose_believed[row],
            transform_camera_to_world_true=self.transform_camera_to_world_true[row],
            robot_pose_true=self.robot_pose_true[row],
            self_filtered_pixels=int(self.self_filtered_pixels[row]),
        )


class DepthSource(Protocol):
    """Where the depth images of a recording's frames come from."""

    def images(self, start: int, stop: int) -> Iterator[NDArray[np.float32]]:
        """(height, width) float32 depth [m] of frames ``start`` to ``stop`` (excluded)."""
        ...

    def load(self, start: int, stop: int) -> DepthArray:
        """The images of frames ``start`` to ``stop`` (excluded) in memory."""
        ...


@dataclass(frozen=True)
class DepthArray:
    """Depth images held in memory.

    Attributes:
        first_row: Frame number of ``depth_m[0]``.
        depth_m: (N, height, width) float32 depth [m] of frames ``first_row`` onwards.
    """

    first_row: int
    depth_m: NDArray[np.float32]

    def images(self, start: int, stop: int) -> Iterator[NDArray[np.float32]]:
        """Views of the frames' images (no copies)."""
        yield from self.depth_m[start - self.first_row : stop - self.first_row]

    def load(self, start: int, stop: int) -> DepthArray:
        """A view of the frames' images."""
        return DepthArray(start, self.depth_m[start - self.first_row : stop - self.first_row])


@dataclass(frozen=True)
class DepthMember:
    """Depth images read from the recording file, one frame at a time.

    Attributes:
        path: The recording file.
        header: The checked ``.npy`` header of ``depth_m`` (C order, (T, height, width)).
        file_stamp: (size [bytes], modification time [ns]) of the file when it was loaded:
            a file changed since is refused rather than read as if it were the same.
    """

    path: Path
    header: ArrayHeader
    file_stamp: tuple[int, int]

    def images(self, start: int, stop: int) -> Iterator[NDArray[np.float32]]:
        """Each frame's image, read when asked for (float32; other float types converted)."""
        if file_stamp(self.path) != self.file_stamp:
            raise RecordingError(f"{self.path} changed since it was loaded; load it again")
        image_shape = self.header.shape[1:]
        with NpzArchive(self.path) as archive:
            if archive.header(self.header.key) != self.header:
                raise RecordingError(f"{self.path} changed since it was loaded; load it again")
            for record in archive.records(self.header, start, stop):
                image = np.frombuffer(record, dtype=self.header.dtype).reshape(image_shape)
                yield image.astype(np.float32, copy=False)

    def load(self, start: int, stop: int) -> DepthArray:
        """The frames' images read into memory (at most :data:`MAX_PICKLED_DEPTH_BYTES`)."""
        shape = (stop - start, *self.header.shape[1:])
        size = int(np.prod(shape)) * np.dtype(np.float32).itemsize
        if size > MAX_PICKLED_DEPTH_BYTES:
            raise RecordingError(
                f"{self.path}: {size} bytes of depth are too many to hold in memory (at most "
                f"{MAX_PICKLED_DEPTH_BYTES}, MAX_PICKLED_DEPTH_BYTES); replay the file in one "
                "process or cut it to fewer frames"
            )
        depth = np.empty(shape, dtype=np.float32)
        for row, image in enumerate(self.images(start, stop)):
            depth[row] = image
        return DepthArray(start, depth)


def file_stamp(path: Path) -> tuple[int, int]:
    """(size [bytes], modification time [ns]) of a file."""
    try:
        status = os.stat(path)
    except OSError as exc:
        raise RecordingError(f"{path} cannot be read any more: {exc}") from exc
    return (status.st_size, status.st_mtime_ns)


class RecordedFrames(Sequence[Frame]):
    """The frames of a recording, built when asked for.

    Args:
        columns: The per-frame arrays (times, poses, transforms).
        depth: Where the depth images come from.
        rows: The frame numbers this sequence holds (a slice of a recording holds fewer).
    """

    def __init__(self, columns: FrameColumns, depth: DepthSource, rows: range) -> None:
        self.columns = columns
        self.depth = depth
        self.rows = rows

    def __len__(self) -> int:
        return len(self.rows)

    @overload
    def __getitem__(self, index: int) -> Frame: ...

    @overload
    def __getitem__(self, index: slice) -> RecordedFrames: ...

    def __getitem__(self, index: int | slice) -> Frame | RecordedFrames:
        if isinstance(index, slice):
            return RecordedFrames(self.columns, self.depth, self.rows[index])
        row = self.rows[index]
        (image,) = self.depth.images(row, row + 1)
        return self.columns.frame(row, image)

    def __iter__(self) -> Iterator[Frame]:
        """The frames in order; consecutive frames read the depth images once, front to back."""
        if self.rows.step != 1:
            yield from (self[i] for i in range(len(self.rows)))
            return
        images = self.depth.images(self.rows.start, self.rows.stop)
        for row, image in zip(self.rows, images, strict=True):
            yield self.columns.frame(row, image)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled, the frames take their depth along in memory.

        The file may not exist where they go (tune's Ray workers).
        """
        start, stop = (min(self.rows), max(self.rows) + 1) if self.rows else (0, 0)
        return (RecordedFrames, (self.columns, self.depth.load(start, stop), self.rows))

    def in_memory(self) -> RecordedFrames:
        """These frames with their depth images read into memory once, read-only.

        For a caller that replays the frames many times (``fogsim tune``: every trial
        inflated the file again, 0.26 s of a 4.4 s stage trial). The images are the values
        and the read-only arrays the file hands out (the same kernels' argument types).

        Raises:
            RecordingError: More than :data:`~fogsim.data.limits.MAX_PICKLED_DEPTH_BYTES` of
                depth (:meth:`DepthMember.load`), or the file changed since it was loaded.
        """
        start, stop = (min(self.rows), max(self.rows) + 1) if self.rows else (0, 0)
        loaded = self.depth.load(start, stop)
        depth_m = loaded.depth_m if loaded.depth_m.base is None else loaded.depth_m.copy()
        depth_m.flags.writeable = False
        return RecordedFrames(self.columns, DepthArray(start, depth_m), self.rows)

    @property
    def time_s(self) -> NDArray[np.float64]:
        """(N,) times [s] of these frames (no depth is read)."""
        return self.columns.time_s[np.asarray(self.rows, dtype=np.int64)]


def frame_times_s(frames: Sequence[Frame]) -> NDArray[np.float64]:
    """(N,) times [s] of frames; a recording's are read without reading its depth."""
    if isinstance(frames, RecordedFrames):
        return frames.time_s
    return np.array([frame.time_s for frame in frames], dtype=np.float64)
