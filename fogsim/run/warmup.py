"""Compile the mapper's numba kernels before a run, and say so when numba's cache is cold.

The kernels (``cache=True``) are compiled on a machine's first run and loaded from numba's cache
afterwards. Compiling them inside the first frame takes seconds the user is not told about and
makes a progress bar's first estimate absurd; :func:`warm_up_kernels` compiles them up front on
three tiny synthetic frames of a flat floor, group by group, printing which group and how long
it took on standard error when the cache holds no compiled version of a group's kernels.

On a cold cache the groups are compiled in two processes at once: a helper process, forked
from this one (``multiprocessing``'s ``fork``), compiles :data:`HELPER_GROUPS` into the
cache while this process compiles the others, then this process loads the helper's kernels from
the cache. Compiling holds numba's compiler lock (and mostly the GIL), so a second thread would
not help; a second process halves the wait on two cores. The run begins the warm-up
(:class:`KernelWarmUp`) before it starts its threads (a forked child has only the thread that
forked, and forking a process whose threads hold locks is unsafe) and finishes it once the
simulation's thread is setting the scene up. Forked, the helper has this process's modules and
numba's registries (loaded once, before the fork: numba imports its numpy, linear-algebra and
typed-container implementations, and SciPy's BLAS modules with them, on a process's first
compile);
started as ``python -m`` it spent 2.4 s of CPU time on its interpreter, imports and registries
before its first compile (Intel Xeon, 3 repeats, load 12; 0.05 s of it the bare interpreter),
on the path of a cold run that both processes' groups bound. Each
group's step calls only its own kernels (the mapper's are driven through the ``mapper`` API, not
through a :class:`Pipeline`, which would segment and so compile the segmentation a second time
beside the helper); a last step runs a :class:`Pipeline` on the synthetic frames, which loads
every kernel from the cache and compiles whatever a group missed. A helper that fails is
reported on the stream (the last line of its exception) and its groups compiled here instead.
Where there is no ``fork`` (Windows) every group is compiled here.

The segmentation's kernels took two thirds of the compile time, so they are split: this
process first compiles its last stage (:data:`FLOOR_REGIONS`, called on a synthetic image
whose every row is one segment, with the argument types ``segment_depth`` passes), then
z-matching and the baseline map, then the FOG map's update; the helper runs the whole
segmentation, loading that stage from the cache when it gets there (it compiles it itself, once
more, only if it gets there first), then the heading scores. z-matching comes before the FOG
map's update because its numpy-exact sum (`mapper.pairwise`, about 1 s of compile CPU time) is
the tilt filter's too: the helper compiles the tilt filter last in the segmentation, and now
finds the sum in the cache; after the FOG map's update this process reached z-matching about
when the helper reached the tilt filter (both about 40 s in), and each could compile the sum.
The split is measured by ``bench/bench_cold.py``: both processes then take about as long
(:data:`HELPER_GROUPS`).

Every kernel a run compiles carries the same flags (``nogil=True, error_model="numpy",
no_cfunc_wrapper=True``; ``test_warmup`` checks it): numba compiles its own overloads that the
kernels call (``np.empty``, ``np.zeros``, ``np.unique``, the sorts) once per flag set of their
callers, so a kernel with the python error model or holding the GIL compiled them all a second
time in its process (counted with ``numba:compile`` events on a cold cache: the main process
compiled 99 functions, 88 with one flag set; the helper 114, 102). The numpy error model drops
the zero-divisor checks: a division by zero gives inf or NaN instead of raising; the kernels'
divisors are parameters validated positive or guarded counts.

Kernels compiled ahead of time: before compiling anything, a warm-up that finds a group cold
installs the kernels' shipped build (`fogsim.run.kernel_bundle`: ``x86-64-v2`` code of this
package's sources for this numba and CPython) into numba's cache, and compiles only what that
leaves cold (nothing, where the build applies: the stage's first run 31.7 → 7.0 s).

Where the cache is: numba keeps it beside the sources (``__pycache__/*.nbi`` index files and
``*.nbc`` code) and, when that folder is not writable (a wheel in a read-only site-packages),
in its user-wide cache folder (``~/.cache/numba``, numba's ``UserWideCacheLocator``), or in
``NUMBA_CACHE_DIR`` when that is set; :func:`is_cold` asks numba's own cache objects where
each kernel's index file is, so it follows the same choice.
"""

from __future__ import annotations

import math
import multiprocessing
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from types import ModuleType, TracebackType
from typing import TextIO

import numpy as np
from numba.core.dispatcher import Dispatcher
from numba.core.registry import cpu_target
from numpy.typing import NDArray

import mapper.above_top
import mapper.averaging
import mapper.floor_borders
import mapper.floor_cover
import mapper.floor_edges
import mapper.floor_map
import mapper.floor_sides
import mapper.fog
import mapper.grid
import mapper.heading
import mapper.heading_planes
import mapper.occupancy
import mapper.scanline
import mapper.scanline.floors
import mapper.scanline.fused
import mapper.scanline.levels
import mapper.scanline.noise
import mapper.scanline.plane_pixels
import mapper.scanline.planes
import mapper.scanline.points
import mapper.scanline.regions
import mapper.scanline.rows
import mapper.scanline.steps
import mapper.tilt_kernels
import mapper.zmatch
from fogsim.config import RunParams
from fogsim.data.frame import Frame
from fogsim.errors import KernelBundleError
from fogsim.mapping.pipeline import Pipeline
from fogsim.mapping.segmenter import pipeline_segmentation_params
from fogsim.robot import self_filter
from fogsim.run import kernel_bundle
from fogsim.run.scipy_blas import blas_modules_alone
from mapper import AveragingMap, FloorObstacleMapper, SegmentationParams
from mapper.heading import heading_scores, weighted_heading_scores
from mapper.intrinsics import PinholeIntrinsics
from mapper.pose_correction import stepped_planes
from mapper.segmentation import floor_regions, segment_depth
from mapper.tilt_filter import apply_tilt, measured_tilt
from mapper.transforms import apply_transform

MESSAGE = "compiling kernels (first run only)"
"""What standard error says before the first kernel group is compiled."""

_INTRINSICS = PinholeIntrinsics.from_fov(32, 24, 47.0, 39.0)
"""A camera with the stage camera's field of view [deg] on 32 × 24 pixels: big enough for the
segmentation to find the floor plane, small enough that running it costs nothing."""

_CAMERA_HEIGHT_M = 0.9
"""Warm-up camera's height above the floor [m] (the stage robot's head height)."""

_PITCH_DOWN_DEG = 35.0
"""Warm-up camera's pitch below the horizon [deg]: every pixel sees the floor."""

_FRAMES = 3
"""Warm-up frames: the third is the first that z-matching compares with a floor map."""


@dataclass(frozen=True)
class KernelGroup:
    """Kernels compiled together, named in the progress message.

    Attributes:
        name: What the message calls them.
        kernels: The group's cached, not inlined numba kernels.
    """

    name: str
    kernels: tuple[Dispatcher, ...]


def _kernels(*modules: ModuleType) -> tuple[Dispatcher, ...]:
    """The cached, not inlined numba kernels defined in ``modules``."""
    return tuple(
        value
        for module in modules
        for value in vars(module).values()
        if isinstance(value, Dispatcher)
        and value.py_func.__module__ == module.__name__
        and value.targetoptions.get("inline", "never") == "never"
    )


SCANLINE_MODULES = (
    mapper.scanline.noise,
    mapper.scanline.rows,
    mapper.scanline.regions,
    mapper.scanline.planes,
    mapper.scanline.plane_pixels,
    mapper.scanline.levels,
    mapper.scanline.floors,
    mapper.scanline.points,
    mapper.scanline.steps,
    mapper.scanline.fused,
)
"""The modules of `mapper.scanline` (its kernels are defined there, not in the package)."""

_FLOOR_KERNELS = (
    mapper.scanline.level_geometry,
    mapper.scanline.level_regions,
    mapper.scanline.split_level,
    mapper.scanline.horizontal_sums,
    mapper.scanline.grow_floors,
    mapper.scanline.region_interior,
    mapper.scanline.region_depth,
    mapper.scanline.floor_statistics,
    mapper.scanline.floor_segment_fit,
    mapper.scanline.level_heights,
    mapper.scanline.floor_verdict,
    mapper.scanline.floor_points,
    *_kernels(mapper.scanline.steps),  # level_regions calls them (compiled whether used or not)
)
"""The segmentation's last stage (level regions and the floor points) and what it calls."""

FLOOR_REGIONS = KernelGroup("floor regions", _FLOOR_KERNELS)
"""The segmentation's last stage: level geometry, level regions grown and measured, floor
points (the scan-line kernels it shares with the planes stage are the helper's)."""

_STEREO_HEAD_KERNELS = (
    *_kernels(mapper.floor_sides),
    *_kernels(mapper.floor_borders),
    mapper.tilt_kernels.stepped_plane_flags,
    mapper.tilt_kernels.believed_points,  # the step test's points, made for it alone
    # called by stepped_plane_flags only:
    mapper.tilt_kernels._points_by_plane,
    mapper.tilt_kernels._bucket_values,
    mapper.tilt_kernels._bucket_of,
    mapper.tilt_kernels._rank_value,
    mapper.tilt_kernels._bucketed_quantile,
)
"""The kernels only the stereo head's segmentation parameters call (`uses_stereo_head`)."""

SEGMENTATION = KernelGroup(
    "segmentation",
    tuple(
        k
        for k in _kernels(*SCANLINE_MODULES, mapper.tilt_kernels)
        if k not in _FLOOR_KERNELS and k not in _STEREO_HEAD_KERNELS
    ),
)
"""The rest of the depth-image segmentation's scan-line kernels: noise, row segments, planes;
the tilt correction's (the planes' normals, the tilt filter's measurement and turn)."""

STEREO_HEAD = KernelGroup("stereo head", _STEREO_HEAD_KERNELS)
"""What only the stereo head's segmentation calls: the floors' side bands (`mapper.floor_sides`,
``floor_side_strip_px``), their occluding borders (`mapper.floor_borders`,
``structure_border_px``, ``floor_occluding_border_px``) and the stepped tilt candidates' test
(``tilt_max_step_t``). A run
whose parameters call neither leaves them out (:func:`run_groups`): until session 40 every run
compiled them, the stage's depth-mode first run too (4.7 s of its 48 s of compile CPU, AMD
EPYC, `bench/bench_cold.py kernels`: `side_strips` 2.3 s, `stepped_plane_flags` 2.1 s,
`_strip_sums` 0.3 s inclusive)."""

MAPPER = KernelGroup(
    "mapper",
    _kernels(
        mapper.grid,
        mapper.occupancy,
        mapper.floor_map,
        mapper.floor_cover,
        mapper.floor_edges,
        mapper.fog,
        mapper.above_top,
    ),
)
"""The FOG map's update kernels: frame checks, occupancy, floor map, floor cover, split
columns, FOG types, the columns above the grid's top."""

MATCHING = KernelGroup("z-match, baseline", _kernels(mapper.zmatch, mapper.averaging))
"""z-matching and the averaging baseline map (no FOG map update)."""

HEADING = KernelGroup("heading", _kernels(mapper.heading, mapper.heading_planes))
"""The heading scores (structure points and edge points)."""

SELF_FILTER = KernelGroup("self-filter", _kernels(self_filter))
"""The kernel removing the robot's body from simulated depth images."""


GROUPS = (FLOOR_REGIONS, MATCHING, MAPPER, HEADING, SEGMENTATION, STEREO_HEAD, SELF_FILTER)
"""Every group, in the order this process compiles them (without a helper)."""

HELPER_GROUPS = (SELF_FILTER, SEGMENTATION, STEREO_HEAD, HEADING)
"""The groups a helper process compiles on a cold cache, in this order; this process compiles
the others. Stop 30: this process ended last, by about 8 s (``bench/bench_cold.py run``, the
stage: its floor regions 28.2 s + mapper 18.3 s + z-matching, baseline and heading 6.1 s, wall,
beside the scene's set-up; the helper's groups 45.2 s), so the heading scores (2-3 s CPU of
those 6) went back to the helper, after the segmentation. Measured with ``bench/bench_cold.py
kernels --group ...`` (each process's groups alone on an empty cache, CPU time, Intel Xeon 2
cores, load 7-10, stop 29): this process's
floor regions 24.7 s + mapper 17.7 s; the helper's self-filter 1.2 s + segmentation 62.9 s, of
which 14.2 s its floor stage, loaded from the cache this process filled by then (the
segmentation reaches it about 45 s in) + z-matching, baseline and heading 6.7 s: the helper
ended last, by about 14 s, so z-matching, baseline and heading moved here (both about 50 s).
Stop 26 had the segmentation whole in the helper: 16.6 s, this process 10 s; split, 12.8 s and
12.8 s (before the segmentation's fused kernels grew it).

The self-filter comes first: a simulation's thread calls its kernel on its first frame, once
the scene is set up (seconds into the warm-up); compiled last, the kernel was not in the cache
yet and that thread compiled it a second time, in this process, beside its groups (1 s)."""


def uses_stereo_head(params: RunParams) -> bool:
    """Whether a run of ``params`` calls the :data:`STEREO_HEAD` kernels.

    It does when its segmentation tests floor side bands, marks or drops the floors'
    occluding borders, or tests stepped tilt candidates (the stereo head's parameters).
    """
    segmentation = pipeline_segmentation_params(params)
    return (
        segmentation.floor_side_strip_px > 0
        or segmentation.structure_border_px > 0
        or segmentation.floor_occluding_border_px > 0
        or (segmentation.tilt_max_step_t > 0.0 and segmentation.correct_tilt)
    )


def run_groups(params: RunParams, *, simulated: bool = True) -> tuple[KernelGroup, ...]:
    """The groups of :data:`GROUPS` a run of ``params`` calls, in their order.

    Left out: :data:`SELF_FILTER` when the run simulates no frames (a replay, real data), and
    :data:`STEREO_HEAD` when its parameters call neither of its stages (`uses_stereo_head`).
    """
    stereo = uses_stereo_head(params)
    return tuple(
        group
        for group in GROUPS
        if (simulated or group is not SELF_FILTER) and (stereo or group is not STEREO_HEAD)
    )


def warm_up_kernels(
    params: RunParams, stream: TextIO | None = sys.stderr, *, simulated: bool = True
) -> float:
    """Compile (or load from numba's cache) the kernels a run of ``params`` uses.

    :class:`KernelWarmUp` begun and finished at once (for callers without threads of their own
    to start in between).

    Args:
        params: The run's parameters (the kernels are compiled for their types).
        stream: Where to report progress when a group's cache is cold; None = say nothing.
        simulated: The run simulates its frames; False (a replay, real data): the
            :data:`SELF_FILTER` group, which only a simulation calls, is left out.

    Returns:
        The warm-up's wall time [s].
    """
    with KernelWarmUp(params, stream, simulated=simulated) as warm_up:
        return warm_up.finish()


class KernelWarmUp:
    """The warm-up of a run's kernels, begun before the run starts its threads.

    Begun (made): finds the groups whose cache is cold; with any cold, installs the shipped
    build of the kernels (`fogsim.run.kernel_bundle.install`, saying so on ``stream``) and
    looks again; says so on ``stream`` of the groups still cold and, with more than one,
    forks the helper process compiling :data:`HELPER_GROUPS` (module doc).
    :meth:`finish`: runs each group of :data:`GROUPS` on synthetic data (throwaway maps, a
    2 × 2 image for :data:`SELF_FILTER`) but the helper's, waits for the helper and loads its
    kernels from the cache, then maps the synthetic frames with a throwaway :class:`Pipeline`
    (every kernel loaded from the cache). Nothing of the run's own state is touched. Close it
    (``with``): a helper still running (the run failed before :meth:`finish`) is stopped.

    Args:
        params: The run's parameters (the kernels are compiled for their types).
        stream: Where to report progress when a group's cache is cold; None = say nothing.
        simulated: The run simulates its frames; False (a replay, real data): the
            :data:`SELF_FILTER` group, which only a simulation calls, is left out.
    """

    def __init__(
        self, params: RunParams, stream: TextIO | None = sys.stderr, *, simulated: bool = True
    ) -> None:
        self._start = time.perf_counter()
        self._params = params
        self._stream = stream
        self._groups = run_groups(params, simulated=simulated)
        self._cold = [group for group in self._groups if is_cold(group)]
        if self._cold and _install_shipped(stream):
            self._cold = [group for group in self._groups if is_cold(group)]
        away = [group for group in HELPER_GROUPS if group in self._cold]
        fork = bool(away) and len(away) < len(self._cold) and _can_fork()
        if self._cold:
            processes = " in 2 processes" if fork else ""
            self._say(f"fogsim: {MESSAGE}, {len(self._cold)} groups{processes}", flush=True)
        self._helper = _Helper(params, away) if fork else None

    def finish(self) -> float:
        """Compile or load every group, wait for the helper; the warm-up's wall time [s].

        The time counts from the warm-up's beginning (the helper's compile included).
        """
        # SciPy's BLAS and LAPACK modules without their package while every kernel is loaded and
        # called once (`fogsim.run.scipy_blas`): numba keeps the routines' addresses.
        with blas_modules_alone():
            steps = _steps(self._params)
            helper = self._helper
            away = helper.groups if helper is not None else []
            for group in self._groups:
                if group in away:
                    continue
                if group in self._cold:
                    self._say(f"  {group.name} kernels ...", end="", flush=True)
                group_start = time.perf_counter()
                steps[group]()
                if group in self._cold:
                    self._say(f" {time.perf_counter() - group_start:.1f} s", flush=True)
            if helper is not None:
                names = ", ".join(group.name for group in away)
                self._say(f"  {names} kernels ...", end="", flush=True)
                failure = helper.wait()
                for group in away:
                    steps[group]()  # from the cache the helper filled (compiled if it failed)
                self._say(f" {helper.seconds():.1f} s (second process)", flush=True)
                if failure:
                    self._say(f"  (the second process failed, compiled here: {failure})")
            _pipeline(_floor_frames(), self._params)
        elapsed_s = time.perf_counter() - self._start
        if self._cold:
            self._say(f"  compiled in {elapsed_s:.1f} s", flush=True)
        return elapsed_s

    def close(self) -> None:
        """Stop the helper if it still runs; idempotent."""
        if self._helper is not None:
            self._helper.stop()

    def __enter__(self) -> KernelWarmUp:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()

    def _say(self, text: str, *, end: str = "\n", flush: bool = False) -> None:
        """Print ``text`` on the stream (nothing without one)."""
        if self._stream is not None:
            print(text, end=end, file=self._stream, flush=flush)


def _can_fork() -> bool:
    """Whether this process can fork the helper; if not, every group is compiled here.

    It can when ``fork`` exists (not on Windows) and it is no ``multiprocessing`` daemon (a
    daemon may have no children).
    """
    return (
        "fork" in multiprocessing.get_all_start_methods()
        and not multiprocessing.current_process().daemon
    )


def _steps(params: RunParams) -> dict[KernelGroup, Callable[[], None]]:
    """What compiles each group: a run of its kernels on synthetic data."""
    frames = _floor_frames()
    return {
        FLOOR_REGIONS: lambda: _floors(frames[0], Pipeline(params).segmentation_params),
        SEGMENTATION: lambda: _segment(frames[0], params),
        STEREO_HEAD: _stereo_head,
        MAPPER: lambda: _map(frames, params),
        MATCHING: lambda: _match(frames, params),
        HEADING: lambda: _heading(frames[0], params),
        SELF_FILTER: self_filter.compile_mask_kernel,
    }


class _Helper:
    """A helper process, forked now, compiling ``groups`` into numba's cache in their order.

    numba's registries are loaded here before the fork, so that the helper has them (module
    doc). Output of this process waiting in its buffers is written out first: the child would
    write it a second time when it ends.
    """

    def __init__(self, params: RunParams, groups: list[KernelGroup]) -> None:
        self.groups = groups
        cpu_target.target_context.refresh()  # what a process's first compile loads
        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                stream.flush()
        self._start = time.perf_counter()
        self._end: float | None = None
        context = multiprocessing.get_context("fork")
        self._connection, child_end = context.Pipe(duplex=False)
        self._process = context.Process(
            target=_helper_main, args=(params, groups, child_end), name="fogsim-kernels"
        )
        self._process.start()
        child_end.close()

    def wait(self) -> str:
        """Wait for the helper; the last line of its error if it failed, else ''."""
        try:
            answer = self._connection.recv()  # when it was done (time.time), or its error
        except EOFError:
            answer = None
        self._process.join()
        self._end = time.perf_counter()
        if isinstance(answer, float):
            self._end -= max(time.time() - answer, 0.0)  # it may have ended long before
            return ""
        return answer or f"exit status {self._process.exitcode}"

    def seconds(self) -> float:
        """The helper's wall time [s], start to end (after :meth:`wait`)."""
        return (self._end or time.perf_counter()) - self._start

    def stop(self) -> None:
        """Kill the helper if it still runs (the warm-up was interrupted), and reap it."""
        if self._process.is_alive():
            self._process.kill()
        self._process.join()
        self._connection.close()


def _helper_main(params: RunParams, groups: list[KernelGroup], connection: Connection) -> None:
    """The helper process: compile ``groups``; send the clock when done, or its error's line.

    With the error the parent compiles the groups itself.
    """
    try:
        _compile(params, groups)
    except Exception as error:  # any: told to the parent, which compiles them itself
        lines = "".join(traceback.format_exception_only(error)).strip().splitlines()
        connection.send(lines[-1] if lines else type(error).__name__)
    else:
        connection.send(time.time())
    connection.close()


def _compile(params: RunParams, groups: list[KernelGroup]) -> None:
    """The helper's work: run the steps of ``groups`` in their order (into numba's cache)."""
    steps = _steps(params)
    for group in groups:
        steps[group]()


_SHIPPED_TRIED = [False]
"""Whether this process has asked for the shipped build (:func:`install_shipped_kernels`)."""


def install_shipped_kernels(stream: TextIO | None = sys.stderr) -> bool:
    """Install the kernels' shipped build when any group is cold; once a process.

    For what maps without a :class:`KernelWarmUp` (a replay's report, ``fogsim tune``'s
    trials, ``fogsim compare``): without it, each of their processes compiled every kernel on
    a fresh machine (``fogsim compare`` of one recording: 55 s). A build that cannot be read is
    reported on ``stream`` and left out (the kernels then compile as before).

    Returns:
        Whether anything was installed.
    """
    if _SHIPPED_TRIED[0]:
        return False
    _SHIPPED_TRIED[0] = True
    if not any(is_cold(group) for group in GROUPS):
        return False
    return _install_shipped(stream)


def _install_shipped(stream: TextIO | None) -> bool:
    """`fogsim.run.kernel_bundle.install` of every group's folders, said on ``stream``."""

    def say(text: str) -> None:
        if stream is not None:
            print(text, file=stream, flush=True)

    try:
        installed = kernel_bundle.install(k for group in GROUPS for k in group.kernels)
    except KernelBundleError as exc:
        say(f"fogsim: the kernels' shipped build was not installed: {exc}")
        return False
    if installed is not None:
        say(
            f"fogsim: {installed.indexes} kernels installed from the shipped build "
            f"{installed.bundle.name} (first run only; {installed.cpu} code: "
            f"{kernel_bundle.ENV_SWITCH}=0 compiles them for this CPU instead)"
        )
    return installed is not None


def is_cold(group: KernelGroup) -> bool:
    """Whether none of the group's kernels has a fresh cache index (``*.nbi``).

    Fresh: numba would load compiled code from it, its source stamp being the current one (the
    whole `mapper` package's, `mapper.kernel_cache`, so after an edit of any kernel module every
    mapper group is cold and its compile is announced). A group counts as warm when any of its
    kernels is cached: not every kernel is used by a run (``mapper.occupancy`` keeps a second
    insertion kernel for comparison, the stereo camera's plane refit is not compiled for a
    depth camera), and kernels inlined into others (``inline="always"``) are never compiled on
    their own.
    """
    return not any(_fresh_index(kernel) for kernel in group.kernels)


def _fresh_index(kernel: Dispatcher) -> bool:
    """Whether numba's cache holds compiled code of ``kernel`` it would load (a fresh index).

    numba has no public call for this; its cache file object reads the index and returns no
    entries when the file is missing, of another numba version or stamped by other sources.
    """
    return bool(kernel._cache._cache_file._load_index())


def _floor_frames() -> tuple[Frame, ...]:
    """:data:`_FRAMES` frames of a standing robot's camera looking at a flat floor."""
    pitch = math.radians(_PITCH_DOWN_DEG)
    forward = np.array([math.cos(pitch), 0.0, -math.sin(pitch)])
    right = np.array([0.0, -1.0, 0.0])
    transform_camera_to_robot = np.eye(4)
    transform_camera_to_robot[:3, :3] = np.stack([right, np.cross(forward, right), forward], 1)
    transform_camera_to_robot[:3, 3] = (0.0, 0.0, _CAMERA_HEIGHT_M)
    depth_m = _floor_depth_m(transform_camera_to_robot)
    pose = np.zeros(4)
    return tuple(
        Frame(
            index=i,
            time_s=0.1 * i,
            depth_m=depth_m,
            intrinsics=_INTRINSICS,
            transform_camera_to_robot_believed=transform_camera_to_robot,
            robot_pose_believed=pose,
            transform_camera_to_world_true=transform_camera_to_robot,
            robot_pose_true=pose,
        )
        for i in range(_FRAMES)
    )


def _floor_depth_m(transform_camera_to_world: NDArray[np.float64]) -> NDArray[np.float32]:
    """Depth [m] along the optical axis of the floor z = 0 (rays have unit camera z)."""
    rays_world = _INTRINSICS.ray_directions_camera() @ transform_camera_to_world[:3, :3].T
    return (-transform_camera_to_world[2, 3] / rays_world[..., 2]).astype(np.float32)


def _segment(frame: Frame, params: RunParams) -> None:
    """Segment ``frame`` as the run's pipeline does, and measure and apply its tilt.

    The tilt as the tilt filter measures and applies it (`mapper.tilt_filter`).
    """
    segmentation_params = Pipeline(params).segmentation_params
    result = segment_depth(
        frame.depth_m,
        frame.intrinsics,
        frame.transform_camera_to_robot_believed,
        segmentation_params,
    )
    measured, _ = measured_tilt(result, segmentation_params)
    apply_tilt(result, np.zeros(2) if measured is None else measured)


def _stereo_head() -> None:
    """Call the :data:`STEREO_HEAD` kernels with the argument types `segment_depth` passes.

    A type that differed would compile a second version, and the run would load neither.
    """
    labels = np.zeros((2, 5), dtype=np.int64)
    z = np.zeros((2, 5))
    mapper.floor_sides.peel_side_strips(labels, z, z + 0.01, np.zeros(1), 1, 3.0, 1.0, 0.0, 1.0)
    mapper.floor_borders.occluding_border(labels, z + 1.0, np.zeros(1), 1, 0.01)
    stepped_planes(
        np.zeros((8, 3)),
        np.zeros(8, dtype=np.int64),
        np.array([[0.0, 0.0, 1.0]]),
        np.array([8]),
        1,
        0.9,
        1.0,
        1.0,
        0.01,
    )


def _floors(frame: Frame, params: SegmentationParams) -> None:
    """The segmentation's floor stage on ``frame``'s floor, every image row one segment.

    The calls and argument types are ``segment_depth``'s (a type that differed would compile a
    second version of a kernel, and the run would load neither): float64 images, the camera's
    read-only ray table, int64 segment tables.
    """
    depth = np.asarray(frame.depth_m, dtype=np.float64)
    height, width = depth.shape
    rays_camera = frame.intrinsics.ray_directions_camera().reshape(-1, 3)
    origin = frame.transform_camera_to_robot_believed[:3, 3].copy()
    rotation = frame.transform_camera_to_robot_believed[:3, :3].copy()
    typical_sigma = np.full((height, width), params.min_noise_m)
    rays, points, sigma_z = mapper.scanline.level_geometry(
        depth, rays_camera, rotation, origin, typical_sigma, params.min_noise_m
    )
    segments = (
        np.arange(height, dtype=np.int64),
        np.zeros(height, dtype=np.int64),
        np.full(height, width, dtype=np.int64),
    )
    labels, floors = floor_regions(
        origin, rays, points, sigma_z, depth, segments, frame.intrinsics, params
    )
    mapper.scanline.floor_points(
        np.flatnonzero(np.isfinite(depth)),
        labels,
        np.where(floors.is_floor, floors.heights_m, np.nan),
        np.nan,
        rays,
        depth,
        typical_sigma,
        origin,
        params.ground_relabel_sigma_factor,
        params.floor_snap_sigma_factor,
    )


def _floor_points_world(
    frame: Frame,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``frame``'s world points, their floor heights (all floor, height 0), the camera's place."""
    points_camera = frame.depth_m[..., None] * frame.intrinsics.ray_directions_camera()
    transform = frame.transform_camera_to_world_true
    points_world = apply_transform(transform, points_camera.reshape(-1, 3))
    return points_world, np.zeros(len(points_world)), np.ascontiguousarray(transform[:3, 3])


def _map(frames: tuple[Frame, ...], params: RunParams) -> None:
    """The FOG map's update and layers on the frames' floor points.

    No segmentation and no z-matching: those are other groups' (:data:`SEGMENTATION`, the
    helper's; :data:`MATCHING`).
    """
    fog = FloorObstacleMapper(params.mapper)
    for points_world, floor_world, origin in map(_floor_points_world, frames):
        fog.recenter(float(origin[0]), float(origin[1]))
        fog.update(points_world, floor_world, origin)
        fog.geometry.columns_seen(points_world)  # a run's cells in view
    fog.fog(), fog.floor(), fog.obstacle(), fog.ceiling(), fog.floor_at(0.0, 0.0)


def _match(frames: tuple[Frame, ...], params: RunParams) -> None:
    """z-matching and the averaging map's update on the frames' points.

    z-matching is against an empty FOG map: its update is :data:`MAPPER`'s (this process's).
    """
    fog = FloorObstacleMapper(params.mapper)
    baseline = AveragingMap(params.mapper)
    for points_world, floor_world, origin in map(_floor_points_world, frames):
        baseline.recenter(float(origin[0]), float(origin[1]))
        baseline.update(points_world, floor_world, origin)
        fog.match_z(points_world, floor_world)
    baseline.heights()


def _heading(frame: Frame, params: RunParams) -> None:
    """Both heading scores on four of the frame's floor points.

    With `HeadingParams.plane_refine_estimates`, its point-to-plane refinement too.
    """
    points_world = _floor_points_world(frame)[0]
    offsets_xy = np.ascontiguousarray(points_world[:4, :2])
    heights = points_world[:4, 2].copy()
    keys = np.array([0, 2, 4], dtype=np.int64)
    poses = (offsets_xy[:2].copy(), np.zeros(2), np.zeros(3))  # camera xy, yaw, angles
    voxel = (params.heading.cell_m, params.heading.layer_m)
    heading_scores(offsets_xy, heights, keys, *poses, *voxel)
    # the edge score (`mapper.heading`, on scenes like a staircase)
    weighted_heading_scores(offsets_xy, heights, np.ones(4), keys, *poses, *voxel)
    if params.heading.plane_refine_estimates:  # the point-to-plane refinement, its types
        normals, weights = mapper.heading_planes.keyframe_normals(
            offsets_xy, heights, mapper.heading_planes.NORMAL_RADIUS_M
        )
        mapper.heading_planes.refined_heading(
            offsets_xy,
            heights,
            normals,
            weights,
            np.array([0, 0, 1, 1], dtype=np.int64),
            offsets_xy[:2],
            np.zeros(2),
            0.0,
        )


def _pipeline(frames: tuple[Frame, ...], params: RunParams) -> None:
    """A throwaway :class:`Pipeline` on the frames: what a run calls, from the cache now."""
    pipeline = Pipeline(params)
    for frame in frames:
        pipeline.process(frame)
    pipeline.finish()  # frames waiting for the height reference are mapped now
    pipeline.maps()
