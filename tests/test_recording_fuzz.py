"""Property: any file given to load_recording gives a Recording or a RecordingError naming it.

Hypothesis generates recordings — valid ones, and ones with arrays replaced (wrong dtype, shape,
strings, NaN/inf/1e30), ``meta_json`` values replaced by arbitrary JSON, arrays dropped or added,
``.npy`` headers declaring huge arrays, and files truncated or with bytes overwritten — and
checks that loading (and, when it succeeds, replaying every frame's data) never raises another
exception and stays within a memory bound. Derandomized: the same examples on every run.
"""

import io
import json
import math
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fogsim.config import load_scenario
from fogsim.data.recording import Recording, load_recording
from fogsim.errors import RecordingError

MEMORY_BOUND_BYTES = 16 << 20
"""Peak traced memory of one load and replay: the generated files hold well under 1 MB, so
16 MB means no declared size was trusted."""

FUZZ = settings(
    derandomize=True,
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    database=None,
)

SPECIAL = [math.nan, math.inf, -math.inf, 1e30, -1e30, 1e-300, -1.0, 0.0, 5e3, 2**63]
SCENARIO_TOML = load_scenario("box_removal").to_toml()

ARRAY_KEYS = (
    "meta_json",
    "time_s",
    "depth_m",
    "transform_camera_to_robot_believed",
    "robot_pose_believed",
    "transform_camera_to_world_true",
    "robot_pose_true",
    "self_filtered_pixels",
    "truth_index",
)

json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=8,
)


def _truth(time_s, center_x):
    return {
        "time_s": time_s,
        "objects": [
            {
                "name": "box",
                "center_xy": [center_x, 0.5],
                "size": [0.3, 0.4, 0.05],
                "yaw_rad": 0.0,
                "base_m": 0.0,
                "walkable": True,
                "surface": "flat",
                "roughness_m": 0.02,
            }
        ],
        "surface_names": ["ground", "box"],
        "surface_heights_m": {"ground": 0.0, "box": 0.05},
        "object_names": ["box"],
    }


@st.composite
def valid_arrays(draw):
    """The arrays of a valid recording (1-4 frames of a small image)."""
    count = draw(st.integers(1, 4))
    height, width = draw(st.integers(1, 6)), draw(st.integers(1, 8))
    with_truth = draw(st.booleans())
    meta = {
        "format": "fogsim-recording",
        "version": 2,
        "intrinsics": {
            "width": width,
            "height": height,
            "fx": 9.0,
            "fy": 9.0,
            "cx": (width - 1) / 2,
            "cy": (height - 1) / 2,
        },
        "scenario_toml": SCENARIO_TOML if draw(st.booleans()) else None,
        "truths": [_truth(0.0, 1.0), _truth(0.1, 1.2)] if with_truth else [],
        "created_by": "fogsim",
    }
    poses = np.zeros((count, 4))
    poses[:, 0] = 0.3 + 0.01 * np.arange(count)
    camera = np.tile(np.eye(4), (count, 1, 1))
    camera[:, 2, 3] = 0.9
    depth = np.linspace(0.5, 3.0, count * height * width, dtype=np.float32)
    arrays = {
        "meta_json": np.array(json.dumps(meta)),
        "time_s": np.arange(count) / 12.5,
        "depth_m": depth.reshape(count, height, width),
        "transform_camera_to_robot_believed": camera,
        "robot_pose_believed": poses,
        "transform_camera_to_world_true": camera.copy(),
        "robot_pose_true": poses.copy(),
        "self_filtered_pixels": np.zeros(count, dtype=np.int32),
        "truth_index": (np.arange(count) % 2 if with_truth else np.full(count, -1)).astype(
            np.int32
        ),
    }
    for key in ARRAY_KEYS[5:]:
        if draw(st.booleans()):
            del arrays[key]
    return arrays, meta


def _filled(dtype, shape, fill):
    """An array of ``shape`` full of ``fill`` cast to ``dtype`` (NaN to int included)."""
    with np.errstate(invalid="ignore", over="ignore"):
        return np.full(shape, fill).astype(dtype)


random_arrays = st.builds(
    _filled,
    st.sampled_from(["f8", "f4", "f2", "i4", "u1", "i8", "?", "c16", "U3", ">f8"]),
    st.lists(st.integers(0, 5), max_size=4).map(tuple),
    st.sampled_from([*SPECIAL, 1, "7"]),
)


@st.composite
def mutated_arrays(draw):
    """A valid recording's arrays with one to three mutations."""
    arrays, meta = draw(valid_arrays())
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["replace", "element", "meta", "drop", "add"]))
        key = draw(st.sampled_from(ARRAY_KEYS))
        if kind == "replace":
            arrays[key] = draw(random_arrays)
        elif kind == "element" and key in arrays and arrays[key].size and key != "meta_json":
            value = arrays[key].astype(np.float64) if arrays[key].dtype.kind != "f" else arrays[key]
            flat = value.copy().reshape(-1)
            flat[draw(st.integers(0, flat.size - 1))] = draw(st.sampled_from(SPECIAL))
            arrays[key] = flat.reshape(arrays[key].shape)
        elif kind == "meta":
            path = draw(st.sampled_from(META_PATHS))
            _set(meta, path, draw(json_values))
            arrays["meta_json"] = np.array(json.dumps(meta))
        elif kind == "drop":
            arrays.pop(key, None)
        else:
            arrays[draw(st.sampled_from(["extra", key]))] = draw(random_arrays)
    return arrays


META_PATHS = [
    ("format",),
    ("version",),
    ("intrinsics",),
    ("intrinsics", "width"),
    ("intrinsics", "height"),
    ("intrinsics", "fx"),
    ("intrinsics", "cx"),
    ("intrinsics", "cy"),
    ("scenario_toml",),
    ("truths",),
    ("truths", 0),
    ("truths", 0, "objects"),
    ("truths", 0, "objects", 0, "size"),
    ("truths", 0, "surface_heights_m"),
    ("truths", 1, "object_names"),
    ("created_by",),
    ("unknown",),
]


def _set(document, path, value):
    """Set ``document[path]`` where the path exists (else the top-level key ``path[0]``)."""
    target = document
    for step in path[:-1]:
        try:
            target = target[step]
        except (KeyError, IndexError, TypeError):
            document[str(path[0])] = value
            return
    try:
        target[path[-1]] = value
    except (IndexError, TypeError):
        document[str(path[0])] = value


def _write(path, arrays, compressed):
    (np.savez_compressed if compressed else np.savez)(path, **arrays)


def _header_member(shape, descr, data):
    """A ``.npy`` member whose header declares ``shape`` but holds ``data``."""
    out = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        out, {"descr": descr, "fortran_order": False, "shape": shape}
    )
    return out.getvalue() + data


def check_load(path: Path) -> None:
    """Load (and replay the frames of) ``path`` within the memory bound; only RecordingError."""
    tracemalloc.start()
    try:
        try:
            recording = load_recording(path)
        except RecordingError as exc:
            assert str(path) in str(exc), exc
        else:
            assert isinstance(recording, Recording)
            for frame in recording.frames:
                assert frame.depth_m.shape == recording.intrinsics.shape
                assert np.isfinite(frame.robot_pose_believed).all()
            recording.truth_at(recording.times_s[-1])
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < MEMORY_BOUND_BYTES, peak


@FUZZ
@given(arrays=valid_arrays(), compressed=st.booleans())
def test_valid_recordings_load_and_replay(tmp_path_factory, arrays, compressed):
    path = tmp_path_factory.mktemp("valid") / "rec.npz"
    _write(path, arrays[0], compressed)
    recording = load_recording(path)
    assert len(recording.frames) == len(arrays[0]["time_s"])
    for frame, expected in zip(recording.frames, arrays[0]["depth_m"], strict=True):
        np.testing.assert_array_equal(frame.depth_m, expected)
    check_load(path)


@FUZZ
@given(arrays=mutated_arrays(), compressed=st.booleans())
def test_mutated_arrays_and_meta_give_a_recording_or_a_recording_error(
    tmp_path_factory, arrays, compressed
):
    path = tmp_path_factory.mktemp("mutated") / "rec.npz"
    _write(path, arrays, compressed)
    check_load(path)


@FUZZ
@given(
    arrays=valid_arrays(),
    compressed=st.booleans(),
    cut=st.none() | st.floats(0.0, 1.0),
    patches=st.lists(st.tuples(st.floats(0.0, 0.9), st.binary(min_size=1, max_size=8)), max_size=3),
)
def test_truncated_and_overwritten_files_give_a_recording_or_a_recording_error(
    tmp_path_factory, arrays, compressed, cut, patches
):
    """Bytes overwritten anywhere in the members (the first 90 % of the file), or the file cut."""
    path = tmp_path_factory.mktemp("bytes") / "rec.npz"
    _write(path, arrays[0], compressed)
    data = bytearray(path.read_bytes())
    for where, patch in patches:
        start = int(where * len(data))
        data[start : start + len(patch)] = patch
    path.write_bytes(bytes(data if cut is None else data[: round(cut * len(data))]))
    check_load(path)


@FUZZ
@given(
    arrays=valid_arrays(),
    key=st.sampled_from(ARRAY_KEYS),
    shape=st.lists(st.integers(0, 2**40), min_size=0, max_size=3).map(tuple),
    descr=st.sampled_from(["<f8", "<f4", "<i4", "<U100000000", "|b1", "<c16"]),
    data_bytes=st.integers(0, 256),
)
def test_headers_declaring_any_size_are_checked_before_reading(
    tmp_path_factory, arrays, key, shape, descr, data_bytes
):
    path = tmp_path_factory.mktemp("header") / "rec.npz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, array in arrays[0].items():
            member = io.BytesIO()
            np.save(member, array)
            content = member.getvalue()
            if name == key:
                content = _header_member(shape, descr, b"\0" * data_bytes)
            archive.writestr(f"{name}.npy", content)
    check_load(path)
