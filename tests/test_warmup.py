"""Kernel warm-up before a run: the compile message only with a cold numba cache, same results.

The kernels that replace numba's slow-to-compile functions give numpy's answers.
"""

import dataclasses
import json
import os
import pkgutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_pipeline import INTR, make_frames, provider_removed_at

import mapper.floor_borders
import mapper.floor_sides
import mapper.scanline
import mapper.tilt_kernels
from fogsim.config import RunParams, resolve_params
from fogsim.data.recording import Recording
from fogsim.run import warmup
from fogsim.run.runner import run_scenario
from fogsim.run.warmup import GROUPS, MESSAGE, KernelGroup, is_cold
from mapper.scanline.regions import _stable_order
from mapper.zmatch import _median

ROOT = Path(__file__).resolve().parent.parent

WARM_UP = (
    "import json, sys\n"
    "from numba.core import event\n"
    "from fogsim.config import RunParams, resolve_params\n"
    "from fogsim.run.warmup import warm_up_kernels\n"
    "compiled = set()\n"
    "class Compiled(event.Listener):\n"
    "    def on_start(self, ev):\n"
    "        f = ev.data['dispatcher'].py_func\n"
    "        compiled.add(f.__module__ + '.' + f.__name__)\n"
    "    def on_end(self, ev): pass\n"
    "event.register('numba:compile', Compiled())\n"
    "overrides = json.loads(sys.argv[1]) if len(sys.argv) > 1 else None\n"
    "warm_up_kernels(resolve_params(None, overrides) if overrides else RunParams())\n"
    "print(' '.join(sorted(compiled)))\n"
)
"""A warm-up that prints the kernels this process compiled (numba's events); its argument, if
any, the run's parameter overrides as JSON."""

STEREO_HEAD_OVERRIDES = {
    "seg.floor_side_strip_px": 3,
    "seg.tilt_max_step_t": 3.0,
    "seg.structure_border_px": 1,
}
"""The stereo head's segmentation stages on (`warmup.uses_stereo_head`)."""

FLOOR_STAGE = {
    "level_geometry",
    "split_level",
    "horizontal_sums",
    "grow_floors",
    "region_interior",
    "region_depth",
    "floor_statistics",
    "floor_segment_fit",
    "floor_points",
}
"""The segmentation's last stage, compiled by the main process beside the helper."""


def _warm_up(cache_dir: Path, overrides: dict | None = None) -> tuple[str, set[str]]:
    """A warm-up in a fresh interpreter whose numba cache is ``cache_dir``: its standard error
    and the kernels (``module.name``) it compiled itself (not in its helper process)."""
    # The shipped build left out: these tests are about the compile it saves.
    env = dict(
        os.environ, NUMBA_CACHE_DIR=str(cache_dir), PYTHONPATH=str(ROOT), FOGSIM_KERNEL_BUNDLE="0"
    )
    arguments = [json.dumps(overrides)] if overrides else []
    process = subprocess.run(
        [sys.executable, "-c", WARM_UP, *arguments],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return process.stderr, set(process.stdout.split())


@pytest.mark.slow
def test_message_with_a_cold_cache_only(tmp_path):
    cold, compiled_here = _warm_up(tmp_path)
    # The helper compiled the segmentation but its floor stage, and the heading scores; this
    # process the floor stage, the FOG map's update, z-matching and the baseline, and no other
    # scan-line kernel (a Pipeline in the mapper step segments: it compiled every scan-line
    # kernel twice) nor the tilt's nor the heading's.
    modules = {name.rsplit(".", 1)[0] for name in compiled_here}
    assert {"mapper.occupancy", "mapper.floor_map", "mapper.fog"} <= modules
    assert {"mapper.zmatch", "mapper.averaging"} <= modules
    assert "mapper.tilt_kernels" not in modules and "mapper.heading" not in modules
    scanline = {name.split(".")[-1] for name in compiled_here if name.startswith("mapper.scanl")}
    assert scanline >= FLOOR_STAGE
    assert not scanline & {"local_noise_depth_m", "split_rows", "grow_planes", "plane_moments"}
    groups = warmup.run_groups(RunParams())
    assert warmup.STEREO_HEAD not in groups  # the stage's depth-mode parameters do not call it
    assert MESSAGE in cold and f"{len(groups)} groups in 2 processes" in cold
    assert "floor regions kernels ..." in cold
    assert "mapper kernels ..." in cold
    assert "z-match, baseline kernels ..." in cold
    assert "self-filter, segmentation, heading kernels ..." in cold
    assert "(second process)" in cold and "failed" not in cold  # compiled beside the others
    assert "compiled in" in cold
    assert list(tmp_path.rglob("*.nbi")), "the warm-up filled the cache"
    # Each signature is a compile of its own: a literal argument (0, True) or a type that
    # differs between two callers compiles a kernel twice, which is time wasted.
    several = {kernel for kernel, n in _signature_counts(tmp_path).items() if n > 1}
    assert not several, several
    assert _warm_up(tmp_path) == ("", set())  # everything loaded from the cache
    # The stereo head's parameters call two more stages: their group alone is compiled (in
    # this process: one group cold needs no helper), every other kernel loaded.
    stereo, compiled_here = _warm_up(tmp_path, STEREO_HEAD_OVERRIDES)
    assert MESSAGE in stereo and "1 groups" in stereo and "stereo head kernels ..." in stereo
    stereo_head = {
        f"{k.py_func.__module__}.{k.py_func.__name__}" for k in warmup.STEREO_HEAD.kernels
    }
    mapper_compiled = {name for name in compiled_here if name.startswith("mapper.")}
    assert "mapper.floor_sides.side_strips" in mapper_compiled
    assert "mapper.tilt_kernels.stepped_plane_flags" in mapper_compiled
    assert mapper_compiled <= stereo_head
    several = {kernel for kernel, n in _signature_counts(tmp_path).items() if n > 1}
    assert not several, several
    assert _warm_up(tmp_path, STEREO_HEAD_OVERRIDES) == ("", set())


def _signature_counts(cache_dir: Path) -> dict[str, int]:
    """Signatures compiled of every kernel of every group (``module.name``): entries in its
    numba cache index, whichever process compiled them."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache_dir), PYTHONPATH=str(ROOT))
    count = (
        "from fogsim.run.warmup import GROUPS\n"
        "for group in GROUPS:\n"
        "    for kernel in group.kernels:\n"
        "        index = kernel._cache._cache_file._load_index()\n"
        "        print(kernel.py_func.__module__, kernel.py_func.__name__, len(index))\n"
    )
    listed = subprocess.run(
        [sys.executable, "-c", count], env=env, capture_output=True, text=True, check=True
    ).stdout.split("\n")
    counts = {f"{m}.{k}": int(n) for m, k, n in (line.split() for line in listed if line)}
    assert counts["mapper.scanline.planes.grow_planes"] == 1  # the listing is not empty
    return counts


def test_a_run_with_progress_leaves_the_cache_warm():
    run_scenario(None, None, replay=_recording(), pictures=False, progress=True)
    # a replay warms up every kernel but the self-filter's, which only a simulation calls, and
    # the stereo head's, which these (default, depth-mode) parameters do not call
    left_out = (warmup.SELF_FILTER, warmup.STEREO_HEAD)
    assert not any(is_cold(group) for group in GROUPS if group not in left_out)


def test_a_cache_stamped_by_other_sources_is_cold(monkeypatch):
    # Warm (the replay above, or this one), then the sources' stamp changes (an edited kernel
    # module): numba would recompile every kernel of the group, so its compile is announced.
    group = warmup.MATCHING
    if is_cold(group):
        run_scenario(None, None, replay=_recording(), pictures=False)
    assert not is_cold(group)
    for kernel in group.kernels:
        monkeypatch.setattr(kernel._cache._cache_file, "_source_stamp", "edited sources")
    assert is_cold(group)


@pytest.mark.parametrize("simulated", [True, False])
def test_only_a_simulated_run_warms_the_self_filter_up(monkeypatch, simulated):
    calls = []
    monkeypatch.setattr(warmup.self_filter, "compile_mask_kernel", lambda: calls.append(1))
    warmup.warm_up_kernels(RunParams(), stream=None, simulated=simulated)
    assert calls == ([1] if simulated else [])


def _recording():
    frames = make_frames(4, box_until_frame=2)
    truths = [provider_removed_at(0.1)(f.time_s) for f in frames]
    return Recording(frames=frames, scenario=None, truths=truths, intrinsics=INTR)


def test_warm_up_leaves_the_results_unchanged():
    quiet = run_scenario(None, None, replay=_recording(), pictures=False, progress=False)
    shown = run_scenario(None, None, replay=_recording(), pictures=False, progress=True)
    assert dataclasses.replace(shown, timing=quiet.timing) == quiet


def test_a_failing_helper_process_is_reported_with_its_last_error_line():
    helper = warmup._Helper(RunParams(), [KernelGroup("no such group", ())])
    failure = helper.wait()
    helper.stop()
    assert failure.startswith("KeyError: KernelGroup(name='no such group'")


def test_a_helper_process_stopped_before_its_end_is_killed(monkeypatch):
    # A run that fails before the warm-up's end stops its helper at once (not after compiling).
    group = KernelGroup("endless", ())
    monkeypatch.setattr(warmup, "_steps", lambda params: {group: lambda: time.sleep(60)})
    helper = warmup._Helper(RunParams(), [group])  # forked: the endless step is its work
    start = time.perf_counter()
    helper.stop()
    assert helper._process.exitcode == -signal.SIGKILL
    assert time.perf_counter() - start < 30


def test_the_helper_process_is_forked_with_numbas_registries_loaded(monkeypatch):
    # What a process's first compile imports is loaded once, before the fork, not in both.
    group = KernelGroup("registries", ())
    loaded = "numba.np.linalg" in sys.modules
    monkeypatch.setattr(warmup, "_steps", lambda params: {group: lambda: None})
    helper = warmup._Helper(RunParams(), [group])
    assert helper.wait() == ""
    helper.stop()
    assert helper._process.exitcode == 0
    assert loaded or "numba.np.linalg" in sys.modules


def test_stable_order_is_numpys_stable_argsort():
    # Replaces numba's argsort (0.85 s of compile): ties keep their order, NaN goes last.
    assert _stable_order(np.array([2.0, np.nan, 1.0, 2.0, -np.inf])).tolist() == [4, 2, 0, 3, 1]
    assert _stable_order(np.zeros(0)).tolist() == []
    rng = np.random.default_rng(5)
    for n in (1, 2, 3, 7, 64, 65, 1000):
        values = rng.integers(0, 4, n).astype(float)  # many ties
        values[rng.random(n) < 0.1] = np.nan
        values[rng.random(n) < 0.1] = np.inf
        assert np.array_equal(_stable_order(values), np.argsort(values, kind="stable"))


def test_median_is_numpys():
    # Replaces numba's np.median (0.9 s of compile) in z-matching's gate.
    assert _median(np.array([3.0, 1.0, 2.0, 10.0])) == 2.5
    assert _median(np.array([3.0, 1.0, 2.0])) == 2.0
    assert np.isnan(_median(np.array([np.nan, 1.0, 2.0, 3.0])))  # numba's median: 2.5
    rng = np.random.default_rng(6)
    for n in (1, 2, 3, 8, 9, 128, 1001):
        for values in (rng.normal(size=n), rng.integers(-2, 3, n).astype(float)):
            assert _median(values) == np.median(values)


def test_every_run_kernel_is_compiled_with_the_same_flags():
    """numba compiles its own overloads (``np.empty``, ``np.unique``, sorts) once per flag set
    of their callers: a kernel with other flags (another error model, holding the GIL) compiles
    them all again on a cold cache. Kernels inlined into others take their caller's flags."""
    flags = {
        f"{kernel.py_func.__module__}.{kernel.py_func.__name__}": tuple(
            sorted((k, v) for k, v in kernel.targetoptions.items() if k != "boundscheck")
        )
        for group in GROUPS
        for kernel in group.kernels
    }
    assert len(flags) > 50
    expected = (
        ("error_model", "numpy"),
        ("no_cfunc_wrapper", True),
        ("nogil", True),
        ("nopython", True),
    )
    assert {name: f for name, f in flags.items() if f != expected} == {}


def test_every_scanline_kernel_is_in_exactly_one_group():
    """The package's kernels are defined in its modules (`warmup.SCANLINE_MODULES`, every one
    of them): each is warmed up by one group, the floor stage's or the segmentation's."""
    modules = {info.name for info in pkgutil.iter_modules(mapper.scanline.__path__)}
    assert {m.__name__.rsplit(".", 1)[1] for m in warmup.SCANLINE_MODULES} == modules
    kernels = warmup._kernels(*warmup.SCANLINE_MODULES)
    # 49 as mapper/scanline.py had before its split (not inlined), 7 of steps.py (session 56),
    # the noise box's running row sums (session 58)
    assert len(kernels) == 57
    groups = {k.py_func.__name__: [g.name for g in GROUPS if k in g.kernels] for k in kernels}
    assert {name: g for name, g in groups.items() if len(g) != 1} == {}
    assert {name for name, g in groups.items() if g == ["floor regions"]} == {
        k.py_func.__name__ for k in warmup.FLOOR_REGIONS.kernels
    }


def test_a_run_warms_up_the_stereo_head_s_kernels_only_when_its_parameters_call_them():
    depth = RunParams()
    stereo = resolve_params(None, STEREO_HEAD_OVERRIDES)
    assert not warmup.uses_stereo_head(depth) and warmup.uses_stereo_head(stereo)
    for key, value in (*STEREO_HEAD_OVERRIDES.items(), ("seg.floor_occluding_border_px", 1)):
        assert warmup.uses_stereo_head(resolve_params(None, {key: value})), key
    assert warmup.run_groups(stereo) == GROUPS
    assert warmup.run_groups(depth) == tuple(g for g in GROUPS if g is not warmup.STEREO_HEAD)
    assert warmup.run_groups(depth, simulated=False) == tuple(
        g for g in GROUPS if g not in (warmup.STEREO_HEAD, warmup.SELF_FILTER)
    )
    # No tilt correction, no step test: only the side bands would call the group.
    no_tilt = {"seg.tilt_max_step_t": 3.0, "seg.correct_tilt": False}
    assert not warmup.uses_stereo_head(resolve_params(None, no_tilt))
    # The group is the whole side-band and border modules and the step test (with its points),
    # and no other group has them.
    floor_sides = warmup._kernels(mapper.floor_sides)
    borders = warmup._kernels(mapper.floor_borders)
    assert len(borders) == 1
    steps = {
        mapper.tilt_kernels.stepped_plane_flags,
        mapper.tilt_kernels.believed_points,
        mapper.tilt_kernels._points_by_plane,
        mapper.tilt_kernels._bucket_values,
        mapper.tilt_kernels._bucket_of,
        mapper.tilt_kernels._rank_value,
        mapper.tilt_kernels._bucketed_quantile,
    }
    assert set(warmup.STEREO_HEAD.kernels) == {*floor_sides, *borders, *steps}
    others = [k for g in GROUPS if g is not warmup.STEREO_HEAD for k in g.kernels]
    assert not set(warmup.STEREO_HEAD.kernels) & set(others)


def test_kernels_the_helper_shares_are_compiled_here_before_the_helper_gets_to_them():
    """The helper compiles the tilt filter last in its segmentation; the numpy-exact sum it
    calls (`mapper.pairwise`) is z-matching's too. This process compiles z-matching right after
    its floor stage, before the FOG map's update, so that the helper loads the sum from the
    cache (`fogsim.run.warmup`'s module doc)."""
    assert warmup.MATCHING not in warmup.HELPER_GROUPS
    assert warmup.SEGMENTATION in warmup.HELPER_GROUPS
    here = [group for group in GROUPS if group not in warmup.HELPER_GROUPS]
    assert here[:2] == [warmup.FLOOR_REGIONS, warmup.MATCHING]
