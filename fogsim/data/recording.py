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

``meta_json`` keys: ``format`` (``"fogsim-recording"``), ``version`` (2), ``intrinsics``
(``width``, ``height`` [px], ``fx``, ``fy``, ``cx``, ``cy`` [px], pixel centres at integer
coordinates), ``scenario_toml`` (the scenario file text, or null for real data: the mapper then
uses its default parameters and the run is not scored), ``truths`` (list of
``SceneTruth.to_dict()`` objects, one per distinct world state; may be empty), ``created_by``.

Frames: world z up with the ground at z = 0; R on the ground between the robot's feet, x forward.
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import DTypeLike, NDArray

from fogsim.atomic import write_atomic
from fogsim.config import Scenario, scenario_from_toml
from fogsim.data.frame import Frame
from fogsim.errors import RecordingError
from fogsim.world import SceneTruth
from mapper.intrinsics import PinholeIntrinsics

FORMAT_NAME = "fogsim-recording"
FORMAT_VERSION = 2
"""2: ground-truth states name every scenario object (``object_names``, for per-object truth)."""
SUPPORTED_VERSIONS = (1, 2)
"""Version 1 files load when they hold no ground truth (real data); their truths are refused."""
REQUIRED_ARRAYS = (
    "meta_json",
    "time_s",
    "depth_m",
    "transform_camera_to_robot_believed",
    "robot_pose_believed",
)


@dataclass
class Recording:
    """A loaded recording.

    Attributes:
        frames: The frames in order (``Frame.index`` = position in the list).
        scenario: The scenario the frames came from, or None (real robot data).
        truths: Ground truth per frame, None where unknown.
        intrinsics: Depth camera intrinsics shared by all frames.
        source_path: The file it was read from, if any.
        meta: The file's ``meta_json`` object without ``truths`` (JSON values).
    """

    frames: list[Frame]
    scenario: Scenario | None
    truths: list[SceneTruth | None]
    intrinsics: PinholeIntrinsics
    source_path: Path | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if len(self.truths) != len(self.frames):
            raise RecordingError(
                f"recording has {len(self.frames)} frames but {len(self.truths)} truth entries"
            )

    @property
    def has_truth(self) -> bool:
        """True if every frame has a ground truth (the run can be scored)."""
        return bool(self.truths) and all(t is not None for t in self.truths)

    def truth_at(self, time_s: float) -> SceneTruth | None:
        """Ground truth of the last frame at or before ``time_s`` (the first frame if earlier)."""
        times = np.array([f.time_s for f in self.frames])
        i = int(np.searchsorted(times, time_s + 1e-9, side="right")) - 1
        return self.truths[max(0, min(i, len(self.truths) - 1))]


def _frame_array(frames: Sequence[Frame], name: str, dtype: DTypeLike) -> NDArray[Any]:
    """The per-frame array ``name`` of every frame stacked along a new first axis."""
    return np.stack([np.asarray(getattr(f, name), dtype=dtype) for f in frames])


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

    truth_dicts: list[dict[str, Any]] = []
    truth_keys: dict[str, int] = {}
    truth_index = np.full(len(frames), -1, dtype=np.int32)
    seen_objects: dict[int, int] = {}
    for i, truth in enumerate(truths or []):
        if truth is None:
            continue
        if id(truth) in seen_objects:
            truth_index[i] = seen_objects[id(truth)]
            continue
        as_dict = truth.to_dict()
        key = json.dumps({k: v for k, v in as_dict.items() if k != "time_s"}, sort_keys=True)
        if key not in truth_keys:
            truth_keys[key] = len(truth_dicts)
            truth_dicts.append(as_dict)
        seen_objects[id(truth)] = truth_keys[key]
        truth_index[i] = truth_keys[key]

    meta = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "intrinsics": {
            "width": intrinsics.width,
            "height": intrinsics.height,
            "fx": intrinsics.fx,
            "fy": intrinsics.fy,
            "cx": intrinsics.cx,
            "cy": intrinsics.cy,
        },
        "scenario_toml": scenario.to_toml() if scenario is not None else None,
        "truths": truth_dicts,
        "created_by": "fogsim",
    }
    arrays = {
        "meta_json": np.array(json.dumps(meta)),
        "time_s": np.array([f.time_s for f in frames], dtype=np.float64),
        "depth_m": _frame_array(frames, "depth_m", np.float32),
        "transform_camera_to_robot_believed": _frame_array(
            frames, "transform_camera_to_robot_believed", np.float64
        ),
        "robot_pose_believed": _frame_array(frames, "robot_pose_believed", np.float64),
        "transform_camera_to_world_true": _frame_array(
            frames, "transform_camera_to_world_true", np.float64
        ),
        "robot_pose_true": _frame_array(frames, "robot_pose_true", np.float64),
        "self_filtered_pixels": np.array([f.self_filtered_pixels for f in frames], dtype=np.int32),
        "truth_index": truth_index,
    }
    return write_atomic(path, lambda handle: np.savez_compressed(handle, **arrays))


def _check_shape(name: str, array: NDArray[Any], shape: tuple[int, ...]) -> None:
    if array.shape != shape:
        raise RecordingError(f"recording array '{name}' must have shape {shape}, got {array.shape}")


def load_recording(path: str | os.PathLike[str]) -> Recording:
    """Read a recording written by :func:`save_recording` (or by hand, see the module doc).

    Raises:
        RecordingError: The file is missing, not a recording, of an unsupported version, or an
            array has the wrong shape (the message names it).
    """
    source = Path(path)
    if not source.is_file():
        raise RecordingError(f"recording file not found: {source}")
    try:
        raw = source.read_bytes()
        with np.load(io.BytesIO(raw), allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except (OSError, ValueError) as exc:
        raise RecordingError(f"{source} is not a readable .npz recording: {exc}") from exc
    missing = [key for key in REQUIRED_ARRAYS if key not in arrays]
    if missing:
        raise RecordingError(
            f"{source} lacks required arrays {missing}; a recording needs {list(REQUIRED_ARRAYS)}"
        )
    try:
        meta = json.loads(str(arrays["meta_json"]))
    except json.JSONDecodeError as exc:
        raise RecordingError(f"{source}: meta_json is not valid JSON: {exc}") from exc
    if meta.get("format") != FORMAT_NAME:
        raise RecordingError(f"{source}: meta.format must be '{FORMAT_NAME}'")
    if meta.get("version") not in SUPPORTED_VERSIONS:
        raise RecordingError(
            f"{source}: recording version {meta.get('version')!r} is not supported; "
            f"supported versions: {list(SUPPORTED_VERSIONS)}"
        )
    if meta["version"] == 1 and meta.get("truths"):
        raise RecordingError(
            f"{source}: a version 1 recording's ground truth lacks the scenario's object names "
            "(version 2 scores per object); record the scenario again with `fogsim record`"
        )
    try:
        k = meta["intrinsics"]
        intrinsics = PinholeIntrinsics(
            int(k["width"]), int(k["height"]), k["fx"], k["fy"], k["cx"], k["cy"]
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise RecordingError(
            f"{source}: meta.intrinsics needs width, height, fx, fy, cx, cy: {exc}"
        ) from exc

    time_s = arrays["time_s"].astype(np.float64)
    count = time_s.shape[0]
    _check_shape("time_s", time_s, (count,))
    if count == 0:
        raise RecordingError(f"{source}: recording has no frames")
    if np.any(np.diff(time_s) <= 0):
        raise RecordingError(f"{source}: time_s must be strictly increasing")
    _check_shape("depth_m", arrays["depth_m"], (count, intrinsics.height, intrinsics.width))
    _check_shape(
        "transform_camera_to_robot_believed",
        arrays["transform_camera_to_robot_believed"],
        (count, 4, 4),
    )
    _check_shape("robot_pose_believed", arrays["robot_pose_believed"], (count, 4))
    nan44 = np.full((count, 4, 4), np.nan)
    camera_true = arrays.get("transform_camera_to_world_true", nan44)
    robot_true = arrays.get("robot_pose_true", np.full((count, 4), np.nan))
    filtered = arrays.get("self_filtered_pixels", np.zeros(count, dtype=np.int32))
    truth_index = arrays.get("truth_index", np.full(count, -1, dtype=np.int32))
    _check_shape("transform_camera_to_world_true", camera_true, (count, 4, 4))
    _check_shape("robot_pose_true", robot_true, (count, 4))
    _check_shape("self_filtered_pixels", filtered, (count,))
    _check_shape("truth_index", truth_index, (count,))

    truth_dicts = meta.get("truths") or []
    if np.any(truth_index >= len(truth_dicts)) or np.any(truth_index < -1):
        raise RecordingError(
            f"{source}: truth_index must be -1 or in [0, {len(truth_dicts)}) (meta.truths)"
        )
    truth_objects = [SceneTruth.from_dict(d) for d in truth_dicts]
    truths = [truth_objects[i] if i >= 0 else None for i in truth_index.tolist()]

    depth = arrays["depth_m"].astype(np.float32)
    frames = [
        Frame(
            index=i,
            time_s=float(time_s[i]),
            depth_m=depth[i],
            intrinsics=intrinsics,
            transform_camera_to_robot_believed=arrays["transform_camera_to_robot_believed"][i],
            robot_pose_believed=arrays["robot_pose_believed"][i],
            transform_camera_to_world_true=camera_true[i],
            robot_pose_true=robot_true[i],
            self_filtered_pixels=int(filtered[i]),
        )
        for i in range(count)
    ]
    scenario = None
    if meta.get("scenario_toml"):
        scenario = scenario_from_toml(meta["scenario_toml"], where=f"recording {source}")
    return Recording(
        frames=frames,
        scenario=scenario,
        truths=truths,
        intrinsics=intrinsics,
        source_path=source,
        meta={k: v for k, v in meta.items() if k != "truths"},
    )
