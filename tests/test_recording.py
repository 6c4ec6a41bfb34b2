"""Recording format: round trip, truths, validation errors naming what is wrong."""

import dataclasses
import io
import json
import pickle
import tracemalloc
import zipfile

import numpy as np
import pytest

from fogsim.config import load_scenario
from fogsim.data.frame import Frame
from fogsim.data.frames import RecordedFrames
from fogsim.data.limits import MAX_FRAMES
from fogsim.data.recording import FORMAT_VERSION, load_recording, save_recording
from fogsim.errors import RecordingError
from fogsim.world import ObjectState, SceneTruth
from mapper.intrinsics import PinholeIntrinsics

INTR = PinholeIntrinsics.from_fov(8, 6, 47.0, 39.0)


def traced_peak(call):
    """Peak of Python and numpy allocations [bytes] while ``call()`` runs."""
    tracemalloc.start()
    try:
        call()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def make_frames(n=4, seed=0):
    rng = np.random.default_rng(seed)
    frames = []
    for i in range(n):
        depth = rng.uniform(0.5, 3.0, INTR.shape).astype(np.float32)
        depth[0, i] = np.nan
        cam = np.eye(4)
        cam[:3, 3] = [0.05, 0.0, 0.9 + 0.001 * i]
        world = np.eye(4)
        world[:3, 3] = [0.3 + 0.01 * i, 0.5, 0.9]
        frames.append(
            Frame(
                index=i,
                time_s=i / 12.5,
                depth_m=depth,
                intrinsics=INTR,
                transform_camera_to_robot_believed=cam,
                robot_pose_believed=np.array([0.3 + 0.01 * i, 0.5, 0.0, 0.01 * i]),
                transform_camera_to_world_true=world,
                robot_pose_true=np.array([0.3 + 0.01 * i, 0.5, 0.0, 0.0]),
                self_filtered_pixels=i,
            )
        )
    return frames


BOX = ObjectState("box", (1.0, 0.5), (0.3, 0.4, 0.05), 0.0, 0.0, True)
NAMES = ("ground", "box")


def test_round_trip_keeps_every_field_bit_for_bit(tmp_path):
    frames = make_frames()
    with_box = SceneTruth(0.0, (BOX,), NAMES, {"ground": 0.0, "box": 0.05})
    without = SceneTruth(0.2, (), NAMES, {"ground": 0.0, "box": 0.05})
    truths = [with_box, with_box, without, without]
    scenario = load_scenario("box_removal")
    path = save_recording(tmp_path / "run.npz", frames, scenario=scenario, truths=truths)
    rec = load_recording(path)
    assert len(rec.frames) == 4 and rec.intrinsics == INTR
    for a, b in zip(frames, rec.frames, strict=True):
        assert a.index == b.index and a.time_s == b.time_s
        np.testing.assert_array_equal(a.depth_m, b.depth_m)  # NaN positions included
        for name in (
            "transform_camera_to_robot_believed",
            "robot_pose_believed",
            "transform_camera_to_world_true",
            "robot_pose_true",
        ):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert a.self_filtered_pixels == b.self_filtered_pixels
    assert rec.scenario.name == "box_removal"
    assert rec.scenario.events == scenario.events
    assert rec.has_truth
    assert [len(t.objects) for t in rec.truths] == [1, 1, 0, 0]
    # Equal world states are stored once.
    with np.load(path) as data:
        assert len(json.loads(str(data["meta_json"]))["truths"]) == 2
    assert rec.truth_at(0.1).objects == (BOX,)
    assert rec.truth_at(10.0).objects == ()


def test_real_data_without_scenario_and_truth(tmp_path):
    path = save_recording(tmp_path / "real.npz", make_frames(2))
    rec = load_recording(path)
    assert rec.scenario is None and not rec.has_truth and rec.truths == [None, None]


def test_hand_written_minimal_file_loads(tmp_path):
    """The documented minimum a user must write for real robot data."""
    n = 3
    meta = {
        "format": "fogsim-recording",
        "version": 1,
        "intrinsics": {"width": 8, "height": 6, "fx": 9.0, "fy": 9.0, "cx": 3.5, "cy": 2.5},
    }
    np.savez(
        tmp_path / "mine.npz",
        meta_json=np.array(json.dumps(meta)),
        time_s=np.arange(n) * 0.08,
        depth_m=np.ones((n, 6, 8), np.float32),
        transform_camera_to_robot_believed=np.tile(np.eye(4), (n, 1, 1)),
        robot_pose_believed=np.zeros((n, 4)),
    )
    rec = load_recording(tmp_path / "mine.npz")
    assert len(rec.frames) == 3
    assert np.all(np.isnan(rec.frames[0].robot_pose_true))


def test_version_1_truth_is_refused_with_the_way_out(tmp_path):
    """Version 1 truths lack the object names that per-object scores need: record again."""
    frames = make_frames(2)
    truth = SceneTruth(0.0, (BOX,), NAMES, {"ground": 0.0, "box": 0.05})
    path = save_recording(tmp_path / "v2.npz", frames, truths=[truth, truth])
    with np.load(path) as data:
        meta = json.loads(str(data["meta_json"]))
    assert meta["version"] == 2
    meta["version"] = 1
    _rewrite(path, tmp_path / "v1.npz", meta_json=np.array(json.dumps(meta)))
    with pytest.raises(RecordingError, match=r"version 1 .* record the scenario again"):
        load_recording(tmp_path / "v1.npz")


def _rewrite(path, out, **changes):
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    arrays.update(changes)
    np.savez(out, **arrays)


def test_errors_name_the_problem(tmp_path):
    path = save_recording(tmp_path / "ok.npz", make_frames())
    with pytest.raises(RecordingError, match="not found"):
        load_recording(tmp_path / "missing.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(RecordingError, match="not a readable"):
        load_recording(tmp_path / "junk.npz")
    with np.load(path) as data:
        meta = json.loads(str(data["meta_json"]))
    meta["version"] = FORMAT_VERSION + 1
    _rewrite(path, tmp_path / "v.npz", meta_json=np.array(json.dumps(meta)))
    with pytest.raises(RecordingError, match=r"version 3 is not supported; supported versions"):
        load_recording(tmp_path / "v.npz")
    _rewrite(path, tmp_path / "s.npz", robot_pose_believed=np.zeros((4, 3)))
    with pytest.raises(RecordingError, match=r"'robot_pose_believed' must have shape \(4, 4\)"):
        load_recording(tmp_path / "s.npz")
    _rewrite(path, tmp_path / "t.npz", time_s=np.zeros(4))
    with pytest.raises(RecordingError, match="strictly increasing"):
        load_recording(tmp_path / "t.npz")


def test_save_rejects_mixed_intrinsics(tmp_path):
    frames = make_frames(2)
    other = PinholeIntrinsics.from_fov(8, 6, 60.0, 45.0)
    frames[1] = Frame(**{**frames[1].__dict__, "intrinsics": other})
    with pytest.raises(RecordingError, match="same for all frames"):
        save_recording(tmp_path / "x.npz", frames)
    assert not (tmp_path / "x.npz").exists()


# --- Hardening (issue 13): every bad file is a RecordingError naming the file and the key. ---


def _saved(tmp_path, n=4):
    return save_recording(tmp_path / "ok.npz", make_frames(n))


def _meta(path):
    with np.load(path) as data:
        return json.loads(str(data["meta_json"]))


def _with_meta(path, out, meta):
    _rewrite(path, out, meta_json=np.array(json.dumps(meta)))
    return out


def assert_refused(path, pattern):
    with pytest.raises(RecordingError, match=pattern) as caught:
        load_recording(path)
    assert str(path) in str(caught.value)


@pytest.mark.parametrize("keep", [0.0, 0.01, 0.3, 0.6, 0.99])
def test_empty_truncated_and_foreign_files_are_refused(tmp_path, keep):
    data = _saved(tmp_path).read_bytes()
    cut = tmp_path / "cut.npz"
    cut.write_bytes(data[: int(keep * len(data))])
    assert_refused(cut, "not a readable .npz")


def test_corrupt_depth_is_found_at_load_not_mid_replay(tmp_path):
    data = bytearray(_saved(tmp_path).read_bytes())
    with zipfile.ZipFile(tmp_path / "ok.npz") as archive:
        info = archive.getinfo("depth_m.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra) + 200
    data[start : start + 8] = b"\xff" * 8
    (tmp_path / "bad.npz").write_bytes(bytes(data))
    assert_refused(tmp_path / "bad.npz", r"array 'depth_m' .*(corrupt|cannot be read)")


@pytest.mark.parametrize(
    ("key", "value", "pattern"),
    [
        ("width", "8", r"meta_json: intrinsics.width: Expected `int`, got `str`"),
        ("fx", "nine", r"meta_json: intrinsics.fx: Expected `float`, got `str`"),
        ("cx", float("nan"), r"meta_json: JSON is malformed"),  # JSON has no NaN
        ("cx", 100.0, r"intrinsics: cx = 100.0 must lie in the image, in \[-0.5, 7.5\] px"),
        ("fx", 0.0, r"intrinsics.fx: Expected `float` >= 1.0"),
        ("width", 4000, r"intrinsics.width: Expected `int` <= 1280"),
    ],
)
def test_wrong_types_and_values_in_meta_json_name_the_key(tmp_path, key, value, pattern):
    path = _saved(tmp_path)
    meta = _meta(path)
    meta["intrinsics"][key] = value
    assert_refused(_with_meta(path, tmp_path / "m.npz", meta), pattern)


def test_meta_json_must_be_the_documented_object(tmp_path):
    path = _saved(tmp_path)
    meta = _meta(path)
    assert_refused(_with_meta(path, tmp_path / "a.npz", [meta]), r"meta_json: Expected `object`")
    assert_refused(_with_meta(path, tmp_path / "u.npz", {**meta, "scenario": "x"}), "unknown field")
    truths = {**meta, "truths": [{"time_s": "0"}]}
    assert_refused(
        _with_meta(path, tmp_path / "t.npz", truths), r"truths\[0\].time_s: Expected `float`"
    )
    huge = json.dumps(meta).replace('"cx": 3.5', '"cx": 1e400')
    _rewrite(path, tmp_path / "h.npz", meta_json=np.array(huge))
    assert_refused(tmp_path / "h.npz", r"meta_json: intrinsics.cx: Number out of range")
    _rewrite(path, tmp_path / "n.npz", meta_json=np.array(5))
    assert_refused(tmp_path / "n.npz", r"array 'meta_json' must hold text, got dtype int64")


@pytest.mark.parametrize(
    ("key", "value", "pattern"),
    [
        ("time_s", np.array(["0", "1", "2", "3"]), r"'time_s' must hold real numbers"),
        ("robot_pose_believed", np.full((4, 4), "0"), r"'robot_pose_believed' must hold real"),
        ("depth_m", np.ones((4, 6, 8), np.uint16), r"'depth_m' must hold floating-point numbers"),
        ("truth_index", np.zeros(4), r"'truth_index' must hold integers, got dtype float64"),
        ("robot_pose_true", np.zeros((4, 4), complex), r"'robot_pose_true' must hold real"),
        ("time_s", np.array([0, 1, 2, "a"], dtype=object), r"'time_s' holds Python objects"),
        ("extra", np.zeros(3), r"unknown arrays \['extra'\]; allowed"),
        ("depth_m", np.ones((4, 8, 6), np.float32), r"'depth_m' must have shape \(4, 6, 8\)"),
    ],
)
def test_strings_and_wrong_arrays_where_numbers_belong_name_the_array(
    tmp_path, key, value, pattern
):
    path = _saved(tmp_path)
    _rewrite(path, tmp_path / "x.npz", **{key: value})
    assert_refused(tmp_path / "x.npz", pattern)


def test_fortran_ordered_depth_is_refused(tmp_path):
    path = _saved(tmp_path)
    _rewrite(path, tmp_path / "f.npz", depth_m=np.asfortranarray(np.ones((4, 6, 8), np.float32)))
    assert_refused(tmp_path / "f.npz", r"'depth_m' is stored in Fortran .* must be C order")


def _npy(header_shape, descr, data):
    out = io.BytesIO()
    header = {"descr": descr, "fortran_order": False, "shape": header_shape}
    np.lib.format.write_array_header_1_0(out, header)
    return out.getvalue() + data


def _replace_member(path, out, key, content):
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(out, "w") as target:
        for info in source.infolist():
            data = content if info.filename == f"{key}.npy" else source.read(info)
            target.writestr(info.filename, data)


@pytest.mark.parametrize(
    ("key", "shape", "pattern"),
    [
        ("time_s", (10**12,), r"'time_s' declares shape \(1000000000000,\) .* holds 64 bytes"),
        ("depth_m", (4, 10**6, 10**6), r"'depth_m' declares shape \(4, 1000000, 1000000\)"),
        ("meta_json", (), r"'meta_json' declares shape \(\) of <U100000000 \(400000000 bytes"),
    ],
)
def test_headers_declaring_huge_arrays_are_refused_before_reading(tmp_path, key, shape, pattern):
    path = _saved(tmp_path)
    descr = "<U100000000" if key == "meta_json" else "<f8"
    _replace_member(path, tmp_path / "h.npz", key, _npy(shape, descr, b"\0" * 64))
    peak = traced_peak(lambda: assert_refused(tmp_path / "h.npz", pattern))
    assert peak < 4 << 20, peak


def test_sizes_are_limited_by_the_frame_count(tmp_path):
    """A consistent header of more frames than MAX_FRAMES, a meta_json too long for its frames."""
    path = _saved(tmp_path)
    frames = MAX_FRAMES + 1
    huge = _npy((frames,), "<f8", b"\0" * (8 * frames))
    _replace_member(path, tmp_path / "t.npz", "time_s", huge)
    assert_refused(
        tmp_path / "t.npz", rf"'time_s' must have shape \(T,\) with 1 <= T <= {MAX_FRAMES}"
    )
    long_text = json.dumps({**_meta(path), "created_by": "x" * (2 << 20)})
    _rewrite(path, tmp_path / "m.npz", meta_json=np.array(long_text))
    assert_refused(
        tmp_path / "m.npz", r"'meta_json' declares \d+ characters; a recording of 4 frames"
    )


def _declare_size(path, key, size):
    """Make the zip directory declare ``size`` uncompressed bytes for member ``key``."""
    data = bytearray(path.read_bytes())
    name = f"{key}.npy".encode()
    at = 0
    while True:
        at = data.index(b"PK\x01\x02", at + 1)
        if data[at + 46 : at + 46 + len(name)] == name:
            break
    data[at + 24 : at + 28] = size.to_bytes(4, "little")
    path.write_bytes(bytes(data))


def test_a_zip_directory_declaring_gigabytes_is_refused_before_reading(tmp_path):
    path = _saved(tmp_path)
    _declare_size(path, "depth_m", 0xFFFFFFF0)
    assert_refused(
        path, r"'depth_m' declares shape \(4, 6, 8\) .* its zip entry holds \d{10} bytes"
    )


def _inflating_recording(path, count, height, width):
    """A recording of ``count`` all-zero depth images (no measurement), deflated as it is
    written, chunk by chunk: a small file that inflates to count × height × width × 4 bytes."""
    arrays = {
        "time_s": np.arange(count) / 12.5,
        "transform_camera_to_robot_believed": np.tile(np.eye(4), (count, 1, 1)),
        "robot_pose_believed": np.zeros((count, 4)),
    }
    meta = {
        "format": "fogsim-recording",
        "version": 2,
        "intrinsics": {"width": width, "height": height, "fx": 500.0, "fy": 500.0}
        | {"cx": (width - 1) / 2, "cy": (height - 1) / 2},
    }
    arrays["meta_json"] = np.array(json.dumps(meta))
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for key, array in arrays.items():
            member = io.BytesIO()
            np.save(member, array)
            archive.writestr(f"{key}.npy", member.getvalue())
        with archive.open("depth_m.npy", "w", force_zip64=True) as member:
            header = {"descr": "<f4", "fortran_order": False, "shape": (count, height, width)}
            np.lib.format.write_array_header_1_0(member, header)
            zeros = bytes(height * width * 4)
            for _ in range(count):
                member.write(zeros)


def test_a_small_file_inflating_to_many_frames_replays_in_one_frames_memory(tmp_path):
    count, height, width = 60, 480, 640
    path = tmp_path / "inflating.npz"
    _inflating_recording(path, count, height, width)
    frame_bytes = height * width * 4
    assert path.stat().st_size < count * frame_bytes / 100  # 74 MB of depth in < 1 MB
    tracemalloc.start()
    try:
        recording = load_recording(path)
        replayed = sum(1 for frame in recording.frames if not frame.depth_m.any())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert replayed == count
    assert peak < 4 * frame_bytes, peak  # bounded by a frame, not by the 74 MB declared


@pytest.mark.parametrize(
    ("key", "row", "column", "value", "pattern"),
    [
        ("time_s", 2, None, np.nan, r"time_s\[2\] = nan must be a finite time"),
        ("time_s", 3, None, np.inf, r"time_s\[3\] = inf must be a finite time"),
        ("time_s", 2, None, 0.0, r"strictly increasing, got time_s\[2\] = 0.0 after time_s\[1\]"),
        ("robot_pose_believed", 1, 0, np.nan, r"robot_pose_believed\[1\] \(frame 1\): x = nan"),
        ("robot_pose_believed", 2, 1, -np.inf, r"robot_pose_believed\[2\] \(frame 2\): .*y = -inf"),
        ("robot_pose_believed", 3, 2, 1e30, r"\(frame 3\): .*z = 1e\+30.* <= 10000 m"),
        ("robot_pose_believed", 0, 3, 1e30, r"\(frame 0\): .*yaw = 1e\+30 rad"),
        ("robot_pose_true", 2, 0, np.inf, r"robot_pose_true\[2\] \(frame 2\): x = inf"),
        ("transform_camera_to_robot_believed", 1, 5, np.nan, r"\[1\] \(frame 1\): must be finite"),
        ("transform_camera_to_world_true", 2, 3, 1e30, r"\[2\] \(frame 2\): translation"),
        (
            "self_filtered_pixels",
            1,
            None,
            49,
            r"self_filtered_pixels\[1\] = 49 must be in \[0, 48\]",
        ),
    ],
)
def test_values_out_of_their_limits_name_the_array_and_the_frame(
    tmp_path, key, row, column, value, pattern
):
    path = _saved(tmp_path)
    with np.load(path) as data:
        array = data[key].astype(np.float64 if key != "self_filtered_pixels" else np.int32)
    flat_row = array[row].reshape(-1) if array.ndim > 1 else array
    flat_row[row if column is None else column] = value
    _rewrite(path, tmp_path / "x.npz", **{key: array})
    assert_refused(tmp_path / "x.npz", pattern)


@pytest.mark.parametrize("jump_m", [100.0, 300.0, 3000.0])
def test_a_believed_pose_jump_is_refused_naming_the_frame(tmp_path, jump_m):
    path = _saved(tmp_path)
    with np.load(path) as data:
        poses = data["robot_pose_believed"].copy()
    poses[2:, 0] += jump_m
    _rewrite(path, tmp_path / "j.npz", robot_pose_believed=poses)
    assert_refused(
        tmp_path / "j.npz", rf"\(frame 2\): the believed position jumped {jump_m:g}(\.\d+)? m"
    )


def test_reflected_or_partly_unknown_transforms_are_refused(tmp_path):
    path = _saved(tmp_path)
    mirror = np.tile(np.eye(4), (4, 1, 1))
    mirror[1, 2, 2] = -1.0
    _rewrite(path, tmp_path / "r.npz", transform_camera_to_robot_believed=mirror)
    assert_refused(
        tmp_path / "r.npz", r"\(frame 1\): rotation block must be orthonormal .* reflection"
    )
    partly = np.tile(np.eye(4), (4, 1, 1))
    partly[3, 0, 3] = np.nan
    _rewrite(path, tmp_path / "p.npz", transform_camera_to_world_true=partly)
    assert_refused(tmp_path / "p.npz", r"\(frame 3\): must be finite \(or all sixteen entries NaN")


def test_frames_are_built_on_demand_and_pickle_with_their_depth(tmp_path):
    frames = make_frames(5)
    path = save_recording(tmp_path / "run.npz", frames)
    rec = load_recording(path)
    assert isinstance(rec.frames, RecordedFrames)
    np.testing.assert_array_equal(rec.frames[3].depth_m, frames[3].depth_m)
    assert [f.index for f in rec.frames[1:4]] == [1, 2, 3]
    assert [f.index for f in rec.frames[::2]] == [0, 2, 4]
    np.testing.assert_array_equal(rec.times_s, [f.time_s for f in frames])
    copied = pickle.loads(
        pickle.dumps(dataclasses.replace(rec, frames=rec.frames[1:3], truths=rec.truths[1:3]))
    )
    path.unlink()  # the copy holds its depth in memory, as tune's Ray workers need
    assert [f.index for f in copied.frames] == [1, 2]
    for a, b in zip(frames[1:3], copied.frames, strict=True):
        np.testing.assert_array_equal(a.depth_m, b.depth_m)


def test_a_file_changed_after_loading_is_refused_when_read(tmp_path):
    path = save_recording(tmp_path / "run.npz", make_frames(3))
    rec = load_recording(path)
    save_recording(path, make_frames(4, seed=1))
    with pytest.raises(RecordingError, match="changed since it was loaded; load it again"):
        list(rec.frames)


def test_save_refuses_what_load_would_refuse(tmp_path):
    frames = make_frames(3)
    frames[1] = Frame(**{**frames[1].__dict__, "robot_pose_believed": np.array([np.nan] * 4)})
    with pytest.raises(RecordingError, match=r"robot_pose_believed\[1\] \(frame 1\)"):
        save_recording(tmp_path / "x.npz", frames)
    assert not (tmp_path / "x.npz").exists()


def test_saving_holds_one_frame_not_the_run(tmp_path):
    """60 VGA frames (74 MB of depth) sharing one image: the stack goes to disk, not memory."""
    intrinsics = PinholeIntrinsics.from_fov(640, 480, 47.0, 39.0)
    depth = np.full(intrinsics.shape, 2.0, dtype=np.float32)
    frames = [
        dataclasses.replace(f, index=i, time_s=0.1 * i, depth_m=depth, intrinsics=intrinsics)
        for i, f in enumerate(make_frames(1) * 60)
    ]
    peak = traced_peak(lambda: save_recording(tmp_path / "big.npz", frames))
    assert peak < 48 << 20, peak  # numpy writes in 16 MB chunks; the stack alone is 74 MB
    assert list(tmp_path.iterdir()) == [tmp_path / "big.npz"]  # the spool left nothing
    loaded = load_recording(tmp_path / "big.npz")
    assert len(loaded.frames) == 60
    np.testing.assert_array_equal(loaded.frames[59].depth_m, depth)


def test_a_depth_image_of_another_size_is_refused_naming_the_frame(tmp_path):
    frames = make_frames(3)
    frames[2] = dataclasses.replace(frames[2], depth_m=np.ones((6, 7), dtype=np.float32))
    with pytest.raises(RecordingError, match=r"frame 2: depth_m has shape \(6, 7\), the intrin"):
        save_recording(tmp_path / "r.npz", frames)
    assert not list(tmp_path.iterdir())
