"""Record and replay a run's frames: one versioned ``.npz`` file per run.

A recording holds everything the mapper sees per frame (depth, intrinsics, the poses the robot
believes), the true poses and the scene's ground truth, so tuning and regression runs replay the
mapper without MuJoCo. It is also how real robot data comes to the mapper: write the arrays
below with numpy (``numpy.savez_compressed``) and run ``fogsim run --replay FILE``.

File format, version 2 (a NumPy ``.npz`` zip archive, loaded with ``allow_pickle=False``):

=======================================  ==================  ======================================
key                                      shape, dtype        meaning
=======================================  ==================  ======================================
``meta_json``                            0-d str             JSON object, see below
``time_s``                               (T,) float64        frame time [s], increasing
``depth_m``                              (T, H, W) float32   depth along the optical axis [m],
                                                             NaN (or 0) = no measurement; pixels
                                                             on the robot's own body already NaN
``transform_camera_to_robot_believed``   (T, 4, 4) float64   camera (OpenCV optical frame: x
                                                             right, y down, z forward) in the
                                                             robot frame R as the robot believes
                                                             it (forward kinematics of encoders)
``robot_pose_believed``                  (T, 4) float64      R in the world: x, y, z [m], yaw
                                                             [rad] (odometry), zero roll/pitch
``transform_camera_to_world_true``       (T, 4, 4) float64   optional: true camera pose, NaN if
                                                             unknown
``robot_pose_true``                      (T, 4) float64      optional: true pose of R, NaN if
                                                             unknown
``self_filtered_pixels``                 (T,) int32          optional: pixels the self-filter
                                                             removed
``truth_index``                          (T,) int32          optional: index into
                                                             ``meta.truths`` of the world state
                                                             at this frame, -1 = none
=======================================  ==================  ======================================

``meta_json`` keys (decoded strictly, :mod:`fogsim.data.meta`): ``format``
(``"fogsim-recording"``), ``version`` (2), ``intrinsics`` (``width``, ``height`` [px], ``fx``,
``fy``, ``cx``, ``cy`` [px], pixel centres at integer coordinates, the principal point inside
the image), ``scenario_toml`` (the scenario file text, or null for real data: the mapper then
uses its default parameters and the run is not scored), ``truths`` (list of world states, one
per distinct state, :class:`~fogsim.data.meta.SceneTruthMeta`; may be empty), ``created_by``.
No other key is allowed.

Frames: world z up with the ground at z = 0; R on the ground between the robot's feet, x forward.

Loading is bounded (limits in :mod:`fogsim.data.limits`): every array's ``.npy`` header is read
and checked against the frame count and the per-frame limits (at most
:data:`~fogsim.data.limits.MAX_FRAMES` frames of at most
:data:`~fogsim.data.limits.MAX_IMAGE_PIXELS` pixels) before its data, and the sizes the zip
directory declares must match; times must be finite and strictly increasing, poses and
transforms finite, rigid and within the world's limits, the believed position may move at most
:data:`~fogsim.data.limits.MAX_POSE_STEP_M` between frames. The depth images are checked
(length, checksum) but not kept: :class:`~fogsim.data.frames.RecordedFrames` reads them one
frame at a time when the frames are used. Every failure is a :class:`RecordingError` naming the
file and the array or key.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import msgspec
import numpy as np
from numpy.typing import DTypeLike, NDArray

from fogsim.atomic import write_atomic
from fogsim.config import Scenario, scenario_from_toml
from fogsim.data.checks import pose_problem, step_problem, transform_problem
from fogsim.data.frame import Frame
from fogsim.data.frames import (
    DepthMember,
    FrameColumns,
    RecordedFrames,
    file_stamp,
    frame_times_s,
)
from fogsim.data.limits import (
    MAX_CAMERA_OFFSET_M,
    MAX_FRAMES,
    MAX_POSITION_M,
    META_JSON_CHARS_PER_FRAME,
    META_JSON_FIXED_CHARS,
)
from fogsim.data.meta import (
    FORMAT_NAME,
    FORMAT_VERSION,
    SUPPORTED_VERSIONS,
    IntrinsicsMeta,
    RecordingMeta,
    SceneTruthMeta,
    decode_meta,
    decode_truths,
    encode_meta,
)
from fogsim.data.npz import ArrayHeader, NpzArchive
from fogsim.data.spool import spooled_array
from fogsim.errors import FogsimError, RecordingError
from fogsim.world import SceneTruth
from mapper.intrinsics import PinholeIntrinsics

__all__ = [
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "OPTIONAL_ARRAYS",
    "REQUIRED_ARRAYS",
    "SUPPORTED_VERSIONS",
    "Recording",
    "load_recording",
    "save_recording",
]

REQUIRED_ARRAYS = (
    "meta_json",
    "time_s",
    "depth_m",
    "transform_camera_to_robot_believed",
    "robot_pose_believed",
)
OPTIONAL_ARRAYS = (
    "transform_camera_to_world_true",
    "robot_pose_true",
    "self_filtered_pixels",
    "truth_index",
)
_REAL = "real numbers (float or int)"
_KINDS = {_REAL: "fiu", "floating-point numbers": "f", "integers": "iu", "text": "U"}
"""What an array may hold: numpy dtype kinds, by how messages name them."""


@dataclass
class Recording:
    """A loaded recording.

    Attributes:
        frames: The frames in order (``Frame.index`` = position in the file); a loaded file's
            are :class:`~fogsim.data.frames.RecordedFrames`, built when used.
        scenario: The scenario the frames came from, or None (real robot data).
        truths: Ground truth per frame, None where unknown.
        intrinsics: Depth camera intrinsics shared by all frames.
        source_path: The file it was read from, if any.
        meta: The file's decoded ``meta_json``, if read from a file.
        times_s: (T,) frame times [s] (set from ``frames``).
    """

    frames: Sequence[Frame]
    scenario: Scenario | None
    truths: Sequence[SceneTruth | None]
    intrinsics: PinholeIntrinsics
    source_path: Path | None = None
    meta: RecordingMeta | None = None
    times_s: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if len(self.truths) != len(self.frames):
            raise RecordingError(
                f"recording has {len(self.frames)} frames but {len(self.truths)} truth entries"
            )
        self.times_s = frame_times_s(self.frames)

    @property
    def has_truth(self) -> bool:
        """True if every frame has a ground truth (the run can be scored)."""
        return bool(self.truths) and all(t is not None for t in self.truths)

    def truth_at(self, time_s: float) -> SceneTruth | None:
        """Ground truth of the last frame at or before ``time_s`` (the first frame if earlier)."""
        i = int(np.searchsorted(self.times_s, time_s + 1e-9, side="right")) - 1
        return self.truths[max(0, min(i, len(self.truths) - 1))]


def _frame_array(frames: Sequence[Frame], name: str, dtype: DTypeLike) -> NDArray[Any]:
    """The per-frame array ``name`` of every frame stacked along a new first axis."""
    return np.stack([np.asarray(getattr(f, name), dtype=dtype) for f in frames])


def _check_depth_shapes(frames: Sequence[Frame], intrinsics: PinholeIntrinsics) -> None:
    """Raise :class:`RecordingError` naming the first frame whose depth is not H×W."""
    shape = (intrinsics.height, intrinsics.width)
    for f in frames:
        if np.shape(f.depth_m) != shape:
            raise RecordingError(
                f"frame {f.index}: depth_m has shape {np.shape(f.depth_m)}, the intrinsics "
                f"say {shape} (height, width)"
            )


def _spooled_depth(
    frames: Sequence[Frame], intrinsics: PinholeIntrinsics, folder: Path
) -> NDArray[np.float32]:
    """Every frame's depth stacked in a :func:`~fogsim.data.spool.spooled_array` (not in memory).

    ``numpy.savez_compressed`` writes such an array in 16 MB chunks, so saving a recording holds
    one frame's images at a time whatever the frame count.
    """
    shape = (intrinsics.height, intrinsics.width)
    stack = spooled_array((len(frames), *shape), np.float32, folder)
    for i, f in enumerate(frames):
        stack[i] = f.depth_m
    return stack


def _stored_truths(
    truths: Sequence[SceneTruth | None], count: int
) -> tuple[tuple[SceneTruthMeta, ...], NDArray[np.int32]]:
    """The distinct world states and each frame's index into them (-1 = none).

    States equal apart from their time are stored once.
    """
    stored: list[SceneTruthMeta] = []
    keys: dict[bytes, int] = {}
    truth_index = np.full(count, -1, dtype=np.int32)
    seen_objects: dict[int, int] = {}
    for i, truth in enumerate(truths):
        if truth is None:
            continue
        if id(truth) in seen_objects:
            truth_index[i] = seen_objects[id(truth)]
            continue
        state = SceneTruthMeta.from_truth(truth)
        key = msgspec.json.encode(msgspec.structs.replace(state, time_s=0.0), order="sorted")
        if key not in keys:
            keys[key] = len(stored)
            stored.append(state)
        seen_objects[id(truth)] = keys[key]
        truth_index[i] = keys[key]
    return tuple(stored), truth_index


def save_recording(
    path: str | os.PathLike[str],
    frames: Sequence[Frame],
    *,
    scenario: Scenario | None = None,
    truths: Sequence[SceneTruth | None] | None = None,
) -> Path:
    """Write frames (and optionally the scenario and ground truth) to one file atomically.

    Args:
        path: Target file (``.npz`` is conventional).
        frames: Frames in order; all must share one intrinsics.
        scenario: The scenario (stored as its TOML text), or None (real robot data).
        truths: One ground truth or None per frame; equal states are stored once.

    Returns:
        The written path.

    Raises:
        RecordingError: No frames, mixed intrinsics, or a value :func:`load_recording` would
            refuse (the message names the frame and the array or key); nothing is written.
    """
    frames = list(frames)
    if not frames:
        raise RecordingError("cannot save a recording without frames")
    intrinsics = frames[0].intrinsics
    for f in frames:
        if f.intrinsics != intrinsics:
            raise RecordingError(
                f"frame {f.index} has intrinsics {f.intrinsics}, expected the same for all "
                f"frames: {intrinsics}"
            )
    if truths is not None and len(truths) != len(frames):
        raise RecordingError(f"got {len(truths)} truths for {len(frames)} frames")
    stored_truths, truth_index = _stored_truths(truths or [], len(frames))
    meta = RecordingMeta(
        format=FORMAT_NAME,
        version=FORMAT_VERSION,
        intrinsics=IntrinsicsMeta.from_intrinsics(intrinsics),
        scenario_toml=scenario.to_toml() if scenario is not None else None,
        truths=stored_truths,
        created_by="fogsim",
    )
    columns = FrameColumns(
        intrinsics=intrinsics,
        time_s=np.array([f.time_s for f in frames], dtype=np.float64),
        transform_camera_to_robot_believed=_frame_array(
            frames, "transform_camera_to_robot_believed", np.float64
        ),
        robot_pose_believed=_frame_array(frames, "robot_pose_believed", np.float64),
        transform_camera_to_world_true=_frame_array(
            frames, "transform_camera_to_world_true", np.float64
        ),
        robot_pose_true=_frame_array(frames, "robot_pose_true", np.float64),
        self_filtered_pixels=np.array([f.self_filtered_pixels for f in frames], dtype=np.int64),
    )
    _check_columns(columns, str(path))
    _check_depth_shapes(frames, intrinsics)
    arrays = {
        "meta_json": np.array(encode_meta(meta, f"{path}: meta_json")),
        "time_s": columns.time_s,
        "transform_camera_to_robot_believed": columns.transform_camera_to_robot_believed,
        "robot_pose_believed": columns.robot_pose_believed,
        "transform_camera_to_world_true": columns.transform_camera_to_world_true,
        "robot_pose_true": columns.robot_pose_true,
        "self_filtered_pixels": columns.self_filtered_pixels.astype(np.int32),
        "truth_index": truth_index,
    }

    def write(handle: IO[bytes]) -> None:
        depth_m = _spooled_depth(frames, intrinsics, Path(path).parent)
        np.savez_compressed(handle, depth_m=depth_m, **arrays)

    return write_atomic(path, write)


def _check_columns(columns: FrameColumns, origin: str) -> None:
    """Check the per-frame arrays against the limits of :mod:`fogsim.data.limits`.

    Times finite and strictly increasing; poses and transforms finite, rigid, in bounds;
    believed steps plausible; self-filtered pixel counts within the image.

    Raises:
        RecordingError: Naming ``origin``, the array and the frame.
    """
    time_s = columns.time_s
    infinite = np.flatnonzero(~np.isfinite(time_s))
    if infinite.size:
        i = int(infinite[0])
        raise RecordingError(f"{origin}: time_s[{i}] = {time_s[i]} must be a finite time [s]")
    backwards = np.flatnonzero(~(np.diff(time_s) > 0))
    if backwards.size:
        i = int(backwards[0])
        raise RecordingError(
            f"{origin}: time_s must be strictly increasing, got time_s[{i + 1}] = "
            f"{time_s[i + 1]} after time_s[{i}] = {time_s[i]}"
        )
    problems = (
        ("robot_pose_believed", pose_problem(columns.robot_pose_believed)),
        ("robot_pose_believed", step_problem(columns.robot_pose_believed)),
        (
            "transform_camera_to_robot_believed",
            transform_problem(
                columns.transform_camera_to_robot_believed, max_translation_m=MAX_CAMERA_OFFSET_M
            ),
        ),
        ("robot_pose_true", pose_problem(columns.robot_pose_true, unknown_allowed=True)),
        (
            "transform_camera_to_world_true",
            transform_problem(
                columns.transform_camera_to_world_true,
                max_translation_m=MAX_POSITION_M,
                unknown_allowed=True,
            ),
        ),
    )
    for key, problem in problems:
        if problem is not None:
            raise RecordingError(
                f"{origin}: {key}[{problem.row}] (frame {problem.row}): {problem.what}"
            )
    pixels = columns.intrinsics.width * columns.intrinsics.height
    filtered = columns.self_filtered_pixels
    outside = np.flatnonzero((filtered < 0) | (filtered > pixels))
    if outside.size:
        i = int(outside[0])
        raise RecordingError(
            f"{origin}: self_filtered_pixels[{i}] = {filtered[i]} must be in [0, {pixels}] "
            "(the image's pixels)"
        )


def _checked_header(
    archive: NpzArchive, key: str, shape: tuple[int, ...], holds: str
) -> ArrayHeader:
    """The header of array ``key``: it must declare ``shape`` and elements of ``holds``.

    ``holds`` is a key of ``_KINDS``.
    """
    header = archive.header(key)
    if header.dtype.kind not in _KINDS[holds]:
        raise RecordingError(
            f"{archive.path}: array '{key}' must hold {holds}, got dtype {header.dtype}"
        )
    if header.shape != shape:
        raise RecordingError(
            f"{archive.path}: recording array '{key}' must have shape {shape}, got {header.shape}"
        )
    return header


def _column(
    archive: NpzArchive,
    key: str,
    shape: tuple[int, ...],
    holds: str,
    dtype: DTypeLike,
    absent: float,
) -> NDArray[Any]:
    """Array ``key`` read after its header was checked, as ``dtype``.

    An optional array missing from the file is filled with ``absent``.
    """
    if key not in archive.keys:
        return np.full(shape, absent, dtype=dtype)
    return archive.read(_checked_header(archive, key, shape, holds)).astype(dtype)


def _frame_count(archive: NpzArchive) -> int:
    """The number of frames, from the ``time_s`` header (1 to :data:`MAX_FRAMES`)."""
    header = archive.header("time_s")
    count = header.shape[0] if len(header.shape) == 1 else -1
    if count == 0:
        raise RecordingError(f"{archive.path}: recording has no frames")
    if not 1 <= count <= MAX_FRAMES:
        raise RecordingError(
            f"{archive.path}: recording array 'time_s' must have shape (T,) with 1 <= T <= "
            f"{MAX_FRAMES} frames (MAX_FRAMES), got {header.shape}"
        )
    return count


def _read_meta(archive: NpzArchive, count: int) -> RecordingMeta:
    """``meta_json``, decoded; its size is checked before it is read.

    At most :data:`META_JSON_FIXED_CHARS` plus :data:`META_JSON_CHARS_PER_FRAME` per frame.
    """
    header = _checked_header(archive, "meta_json", (), "text")
    chars = header.dtype.itemsize // np.dtype("U1").itemsize
    allowed = META_JSON_FIXED_CHARS + count * META_JSON_CHARS_PER_FRAME
    if chars > allowed:
        raise RecordingError(
            f"{archive.path}: array 'meta_json' declares {chars} characters; a recording of "
            f"{count} frames may hold at most {allowed}"
        )
    text = str(archive.read(header)[()])
    return decode_meta(text, f"{archive.path}: meta_json")


def _read_columns(
    archive: NpzArchive, count: int, intrinsics: PinholeIntrinsics
) -> tuple[FrameColumns, NDArray[np.int64]]:
    """Every per-frame array but the depth, and ``truth_index``, shapes and types checked."""
    columns = FrameColumns(
        intrinsics=intrinsics,
        time_s=_column(archive, "time_s", (count,), _REAL, np.float64, np.nan),
        transform_camera_to_robot_believed=_column(
            archive, "transform_camera_to_robot_believed", (count, 4, 4), _REAL, np.float64, 0
        ),
        robot_pose_believed=_column(
            archive, "robot_pose_believed", (count, 4), _REAL, np.float64, 0
        ),
        transform_camera_to_world_true=_column(
            archive, "transform_camera_to_world_true", (count, 4, 4), _REAL, np.float64, np.nan
        ),
        robot_pose_true=_column(archive, "robot_pose_true", (count, 4), _REAL, np.float64, np.nan),
        self_filtered_pixels=_column(
            archive, "self_filtered_pixels", (count,), "integers", np.int64, 0
        ),
    )
    truth_index = _column(archive, "truth_index", (count,), "integers", np.int64, -1)
    return columns, truth_index


def _truths_per_frame(
    meta: RecordingMeta, truth_index: NDArray[np.int64], origin: str
) -> list[SceneTruth | None]:
    """Each frame's world state (None where ``truth_index`` is -1)."""
    outside = np.flatnonzero((truth_index < -1) | (truth_index >= len(meta.truths)))
    if outside.size:
        i = int(outside[0])
        raise RecordingError(
            f"{origin}: truth_index[{i}] = {truth_index[i]} must be -1 or in "
            f"[0, {len(meta.truths)}) (meta.truths)"
        )
    states = decode_truths(meta, f"{origin}: meta_json")
    return [states[i] if i >= 0 else None for i in truth_index.tolist()]


def load_recording(path: str | os.PathLike[str]) -> Recording:
    """Read a recording written by :func:`save_recording` (or by hand, see the module doc).

    The frames' depth images are checked but not kept: they are read from the file, one
    frame at a time, when the frames are used.

    Raises:
        RecordingError: The file is missing, not a zip archive, truncated or corrupt, not a
            recording, of an unsupported version, or an array or key is missing, unknown, of
            the wrong type or shape, too large or holds a value out of its limits (the message
            names the file, the array or key, and the frame).
    """
    source = Path(path)
    if not source.is_file():
        raise RecordingError(f"recording file not found: {source}")
    stamp = file_stamp(source)
    with NpzArchive(source) as archive:
        missing = [key for key in REQUIRED_ARRAYS if key not in archive.keys]
        if missing:
            raise RecordingError(
                f"{source} lacks required arrays {missing}; a recording needs "
                f"{list(REQUIRED_ARRAYS)}"
            )
        unknown = [key for key in archive.keys if key not in REQUIRED_ARRAYS + OPTIONAL_ARRAYS]
        if unknown:
            raise RecordingError(
                f"{source} holds unknown arrays {unknown}; allowed: "
                f"{list(REQUIRED_ARRAYS + OPTIONAL_ARRAYS)}"
            )
        count = _frame_count(archive)
        meta = _read_meta(archive, count)
        intrinsics = meta.intrinsics.to_intrinsics()
        depth = _checked_header(
            archive,
            "depth_m",
            (count, intrinsics.height, intrinsics.width),
            "floating-point numbers",
        )
        if depth.fortran_order:
            raise RecordingError(
                f"{source}: array 'depth_m' is stored in Fortran (column-major) order; frames "
                "are read one at a time, so it must be C order (numpy.ascontiguousarray)"
            )
        columns, truth_index = _read_columns(archive, count, intrinsics)
        _check_columns(columns, str(source))
        truths = _truths_per_frame(meta, truth_index, str(source))
        scenario = None
        if meta.scenario_toml:
            try:
                scenario = scenario_from_toml(
                    meta.scenario_toml, where=f"{source}: meta_json scenario_toml"
                )
            except FogsimError as exc:
                raise RecordingError(str(exc)) from exc
        archive.verify(depth)
    return Recording(
        frames=RecordedFrames(columns, DepthMember(source, depth, stamp), range(count)),
        scenario=scenario,
        truths=truths,
        intrinsics=intrinsics,
        source_path=source,
        meta=meta,
    )
