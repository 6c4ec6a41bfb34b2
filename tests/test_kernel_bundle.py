"""The kernels' shipped build (`fogsim.run.kernel_bundle`): current, installed only where it
applies, and mapping bit for bit as kernels compiled on the machine."""

import io
import json
import os
import pickle
import subprocess
import sys
import tarfile
from pathlib import Path

import numpy as np
import pytest
from test_pipeline import make_frames, provider_removed_at

import mapper.averaging
import mapper.floor_map
import mapper.floor_sides
import mapper.fog
import mapper.heading
import mapper.heading_planes
import mapper.occupancy
import mapper.scanline.fused
import mapper.zmatch
from fogsim.config import RunParams
from fogsim.data.recording import load_recording, save_recording
from fogsim.errors import KernelBundleError
from fogsim.robot import self_filter
from fogsim.run import kernel_bundle, warmup
from fogsim.run.kernel_bundle import MANIFEST, BundleTarget, rekeyed_index
from fogsim.run.runner import run_scenario

ROOT = Path(__file__).resolve().parent.parent

KERNELS = [kernel for group in warmup.GROUPS for kernel in group.kernels]

RUN_KERNELS = (
    mapper.scanline.fused.plane_labels,  # segmentation
    mapper.scanline.fused.level_regions,  # floor regions
    mapper.floor_sides.side_strips,  # stereo head
    mapper.occupancy.insert_frame_columns,  # mapper
    mapper.floor_map.update_floor,
    mapper.fog._fog_rules,
    mapper.zmatch._gated_shift,  # z-match
    mapper.averaging._accumulate,  # baseline
    mapper.heading.heading_scores,  # heading
    mapper.heading_planes.refine_heading,
    self_filter._mask_kernel,  # self-filter
)
"""A kernel of each warm-up group, called by a run of the stage (the groups also list kernels
only other parameters call, e.g. `mapper.occupancy.insert_frame`)."""


def _shipped() -> list[Path]:
    return sorted(kernel_bundle.BUNDLE_DIR.glob("*.tar.xz"))


def _manifest(path: Path) -> dict:
    with tarfile.open(path, "r:xz") as tar:
        return json.load(tar.extractfile(MANIFEST))


def _skip_unless_the_build_applies() -> None:
    bundle = kernel_bundle.bundle_path()
    if not bundle.is_file():
        pytest.skip(f"no shipped build for {BundleTarget.here()}")
    if not kernel_bundle.runs_here(_manifest(bundle)["cpu"]):
        pytest.skip("this CPU cannot run the shipped build's code")


def test_the_shipped_build_is_of_these_sources():
    # One bundle, compiled from the kernel modules as they are: after an edit of a kernel
    # module (any .py of mapper/ or fogsim/robot/ mentioning numba) the bundle no longer
    # applies and a first run compiles again. Rebuild it: python -m fogsim.run.kernel_bundle
    bundles = _shipped()
    assert len(bundles) == 1, bundles
    stamps = {
        folder: kernel_bundle._jsonable(stamp)
        for folder, (_, stamp) in kernel_bundle.cache_folders(KERNELS).items()
    }
    assert set(stamps) == {"mapper", "mapper/scanline", "fogsim/robot"}
    manifest = _manifest(bundles[0])
    assert manifest["stamps"] == stamps, "stale: run python -m fogsim.run.kernel_bundle"
    # code for LLVM's x86-64-v2, no feature added; the features it uses listed for the check
    assert manifest["magic_tuple"][1:] == [kernel_bundle.BUILD_CPU, ""]
    assert manifest["cpu"] == {
        "name": "x86-64-v2",
        "features": ["cx16", "popcnt", "sahf", "sse3", "sse4.1", "sse4.2", "ssse3"],
    }
    assert bundles[0].name == BundleTarget(**manifest["target"]).file_name
    with tarfile.open(bundles[0], "r:xz") as tar:
        names = set(tar.getnames())
    # the kernels of every warm-up group a stage run calls, in depth and stereo mode
    for kernel in RUN_KERNELS:
        folder = kernel_bundle._folder_key(kernel.py_func.__code__.co_filename)
        index = Path(kernel._cache._cache_file._index_path).name
        assert f"{folder}/{index}" in names, index


def _index(magic: tuple) -> bytes:
    sig = ("float64", "int64")
    overloads = {(sig, magic, ("code hash", "")): "f-1.py311.1.nbc"}
    return pickle.dumps("0.68.1", protocol=-1) + pickle.dumps(("stamp", overloads), protocol=-1)


def test_an_index_is_rekeyed_to_this_machine_and_nothing_else_changes():
    generic = ("x86_64-unknown-linux-gnu", "generic", "")
    data = rekeyed_index(_index(generic), ("t", "znver4", "+avx"))
    version, stamp, overloads = kernel_bundle._read_index(data)
    assert version == "0.68.1" and stamp == "stamp"
    assert overloads == {
        (
            ("float64", "int64"),
            ("t", "znver4", "+avx"),
            ("code hash", ""),
        ): "f-1.py311.1.shipped.nbc"
    }


def _bundle(path: Path, manifest: dict, files: dict[str, bytes]) -> Path:
    with tarfile.open(path, "w:xz") as tar:
        for name, data in {MANIFEST: json.dumps(manifest).encode(), **files}.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return path


def _fake_manifest(**target) -> dict:
    here = BundleTarget.here()
    stamps = {
        folder: kernel_bundle._jsonable(stamp)
        for folder, (_, stamp) in kernel_bundle.cache_folders(KERNELS).items()
    }
    return {
        "target": {"triple": here.triple, "python": here.python, "numba": here.numba, **target},
        "magic_tuple": [here.triple, "x86-64-v2", ""],
        "cpu": {"name": "x86-64-v2", "features": ["sse4.1", "popcnt"]},
        "stamps": stamps,
    }


@pytest.mark.parametrize(
    "change",
    [{"numba": "0.1.0"}, {"python": "py27"}, {"triple": "aarch64-unknown-linux-gnu"}, "stamps"],
)
def test_a_build_for_another_machine_or_other_sources_installs_nothing(tmp_path, change):
    manifest = _fake_manifest(**(change if isinstance(change, dict) else {}))
    if change == "stamps":
        manifest["stamps"] = dict.fromkeys(manifest["stamps"], "other sources")
    kernel = warmup.MATCHING.kernels[0]
    folder = kernel_bundle._folder_key(kernel.py_func.__code__.co_filename)
    index = Path(kernel._cache._cache_file._index_path).name
    bundle = _bundle(tmp_path / "b.tar.xz", manifest, {f"{folder}/{index}": b"not an index"})
    # returns before writing a byte (it would fail on the file above if it tried)
    assert kernel_bundle.install(KERNELS, bundle) is None


@pytest.mark.parametrize(
    ("host", "config"),
    [
        ({"popcnt", "sse2", "sse3"}, {}),  # a CPU without SSE4.1 would die on roundsd
        (set(), {}),  # LLVM cannot tell this CPU's features
        ({"popcnt", "sse4.1", "avx2"}, {"CPU_NAME": "generic"}),  # the user chose the CPU
        ({"popcnt", "sse4.1", "avx2"}, {"CPU_FEATURES": "+sse2"}),
    ],
)
def test_a_build_this_cpu_cannot_run_or_was_not_asked_for_installs_nothing(
    tmp_path, monkeypatch, host, config
):
    kernel = warmup.MATCHING.kernels[0]
    folder = kernel_bundle._folder_key(kernel.py_func.__code__.co_filename)
    index = Path(kernel._cache._cache_file._index_path).name
    bundle = _bundle(tmp_path / "b.tar.xz", _fake_manifest(), {f"{folder}/{index}": b"no index"})
    monkeypatch.setattr(kernel_bundle, "host_cpu_features", lambda: frozenset(host))
    for name, value in config.items():
        monkeypatch.setattr(kernel_bundle.numba.config, name, value)
    # returns before writing a byte (it would fail on the file above if it tried)
    assert kernel_bundle.install(KERNELS, bundle) is None


def test_this_cpu_runs_a_build_of_the_features_it_has(monkeypatch):
    cpu = {"name": "x86-64-v2", "features": ["sse4.1", "popcnt"]}
    monkeypatch.setattr(kernel_bundle, "host_cpu_features", lambda: frozenset({"popcnt", "sse4.1"}))
    assert kernel_bundle.runs_here(cpu)
    monkeypatch.setattr(kernel_bundle, "host_cpu_features", lambda: frozenset({"popcnt"}))
    assert not kernel_bundle.runs_here(cpu)


def test_the_machines_cpu_features_are_llvms_names():
    features = kernel_bundle.host_cpu_features()
    if features:  # x86-64 always has SSE2; another architecture has its own names
        assert "sse2" in features or BundleTarget.here().triple.split("-")[0] != "x86_64"


def test_no_build_for_this_machine_or_left_out_installs_nothing(tmp_path, monkeypatch):
    assert kernel_bundle.install(KERNELS, tmp_path / "absent.tar.xz") is None
    bundle = _bundle(tmp_path / "b.tar.xz", _fake_manifest(), {})
    monkeypatch.setenv(kernel_bundle.ENV_SWITCH, "0")
    assert not kernel_bundle.enabled()
    assert kernel_bundle.install(KERNELS, bundle) is None


def _python(code: str, cache_dir: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "NUMBA_CACHE_DIR": str(cache_dir), "PYTHONPATH": str(ROOT), **env},
        capture_output=True,
        text=True,
        check=True,
    )


INSTALL = (
    "from fogsim.run import kernel_bundle, warmup\n"
    "kernels = [k for g in warmup.GROUPS for k in g.kernels]\n"
    "first = kernel_bundle.install(kernels)\n"
    "print(first.indexes if first else 0, kernel_bundle.install(kernels))\n"
    "print(sum(warmup.is_cold(g) for g in warmup.GROUPS))\n"
)


def test_the_build_installs_into_an_empty_cache_once(tmp_path):
    _skip_unless_the_build_applies()
    bundle = kernel_bundle.bundle_path()
    with tarfile.open(bundle, "r:xz") as tar:
        indexes = sum(name.endswith(".nbi") for name in tar.getnames())
    lines = _python(INSTALL, tmp_path).stdout.split("\n")
    # every index installed, then nothing more (fresh indexes are never overwritten), and
    # no group of the warm-up is cold
    assert lines[0] == f"{indexes} None"
    assert lines[1] == "0"
    assert len(list(tmp_path.rglob("*.nbi"))) == indexes
    # left out: nothing installed, every group cold
    lines = _python(INSTALL, tmp_path / "off", FOGSIM_KERNEL_BUNDLE="0").stdout.split("\n")
    assert lines[0] == "0 None" and lines[1] == str(len(warmup.GROUPS))


@pytest.mark.slow
def test_a_first_run_on_the_build_compiles_nothing_and_maps_as_this_process(tmp_path):
    _skip_unless_the_build_applies()
    frames = make_frames(6, box_until_frame=3, noise=0.005, seed=3)
    truths = [provider_removed_at(0.2)(f.time_s) for f in frames]
    recording = tmp_path / "rec.npz"
    save_recording(recording, frames, truths=truths)
    command = [sys.executable, "-m", "fogsim", "run", "--replay", str(recording)]
    first = subprocess.run(
        [*command, "--out", str(tmp_path / "first"), "--no-pictures"],
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        check=True,
    )
    assert "kernels installed from the shipped build" in first.stderr
    assert warmup.MESSAGE not in first.stderr  # nothing left to compile
    # This process's kernels (compiled for this CPU, unless a run installed the build into
    # the cache beside the sources first) map the same frames to the same bytes.
    run_scenario(None, tmp_path / "here", replay=load_recording(recording), pictures=False)
    ours = np.load(tmp_path / "here" / "maps.npz")
    theirs = np.load(tmp_path / "first" / "maps.npz")
    assert sorted(ours.files) == sorted(theirs.files) and len(ours.files) > 10
    for name in ours.files:
        assert ours[name].tobytes() == theirs[name].tobytes(), name


def test_a_corrupt_build_is_an_error_naming_the_file(tmp_path):
    broken = tmp_path / "x.tar.xz"
    broken.write_bytes(b"\xfd7zXZ\x00 cut short")
    with pytest.raises(KernelBundleError, match=r"cannot read kernel bundle .*x\.tar\.xz"):
        kernel_bundle.install(KERNELS, broken)


def test_a_warm_up_says_the_build_failed_and_compiles_instead(tmp_path, monkeypatch):
    broken = tmp_path / "x.tar.xz"
    broken.write_bytes(b"not xz at all")
    monkeypatch.setattr(kernel_bundle, "bundle_path", lambda target=None: broken)
    monkeypatch.setattr(warmup, "is_cold", lambda group: group is warmup.SELF_FILTER)
    stream = io.StringIO()
    warmup.warm_up_kernels(RunParams(), stream=stream)
    said = stream.getvalue()
    assert "the kernels' shipped build was not installed: cannot read kernel bundle" in said
    assert str(broken) in said
    assert f"{warmup.MESSAGE}, 1 groups" in said and "self-filter kernels ..." in said


ONCE = (
    "import io\n"
    "from fogsim.run import warmup\n"
    "said = io.StringIO()\n"
    "print(warmup.install_shipped_kernels(said), warmup.install_shipped_kernels(said))\n"
    "print(sum(warmup.is_cold(g) for g in warmup.GROUPS), said.getvalue().count('installed'))\n"
)


def test_what_maps_without_a_warm_up_installs_the_build_once_a_process(tmp_path):
    # A replay's report (fogsim tune's trials) and fogsim compare map without a warm-up: on a
    # cold cache they install the build (said once), then never look again in that process;
    # a process on a warm cache installs nothing.
    _skip_unless_the_build_applies()
    lines = _python(ONCE, tmp_path).stdout.split("\n")
    assert lines[:2] == ["True False", "0 1"]
    lines = _python(ONCE, tmp_path).stdout.split("\n")
    assert lines[:2] == ["False False", "0 0"]


RECORD = (
    "from fogsim.config import load_scenario\n"
    "from fogsim.run.record import record_scenario\n"
    "import sys\n"
    "record_scenario(load_scenario('flat_floor'), sys.argv[1], max_frames=2)\n"
)


def test_a_first_recording_installs_the_self_filter_s_kernel_from_the_build(tmp_path):
    # `fogsim record` simulates only: its one kernel (the self-filter's) comes from the build
    # on a fresh machine, not compiled in its first frame.
    _skip_unless_the_build_applies()
    subprocess.run(
        [sys.executable, "-c", RECORD, str(tmp_path / "rec.npz")],
        env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        check=True,
    )
    folder = kernel_bundle._folder_key(self_filter._mask_kernel.py_func.__code__.co_filename)
    code = [p.name for p in (tmp_path / "numba").rglob("*.nbc") if folder.split("/")[-1] in str(p)]
    assert code and all(name.endswith(".shipped.nbc") for name in code), code
