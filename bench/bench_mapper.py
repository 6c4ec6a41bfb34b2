"""Mapper update speed with host and generic code generation, peers interleaved in one process.

What is timed: one ``update`` per frame (the grid recentred before it, untimed, as the pipeline
does) of

- ``FloorObstacleMapper`` (the column kernel, the default for ``nz <= 64``),
- ``FloorObstacleMapper (cell marks)`` (the per-cell kernel, the same map),
- ``FloorObstacleMapper (discretized)`` (`MapperParams.discretize_rays`: one ray per lattice
  cell holding points, to its centre),
- ``AveragingMap`` (the Kagami baseline),
- ``octomap.OcTree.insertPointCloud`` on the same finite points from the same sensor origin
  (which also updates each voxel once per cloud, occupied winning), and with ``discretize``.

Times are CPU time of the calling thread (``time.thread_time``), not wall time: on a loaded
machine a frame's wall time counts the time the process waits for a core. The children run
with ``OMP_NUM_THREADS=1``: OctoMap's insertion would otherwise use OpenMP threads (whose CPU
time the calling thread's clock misses, and whose spinning after a call slows the next peer);
every peer runs on one core.

Frame sets:

- ``stage``: the stage scenario's own frames — its recording (``fogsim record stage``, made
  once into ``--recordings``, named with the recording format version so that a recording of
  an older format is made again, not loaded) replayed through the pipeline (segmentation, z
  matching), and the points, floor heights and sensor origin it hands
  ``FloorObstacleMapper.update`` captured; at the scenario's 88 × 72 and at 176 × 144
  (``--set camera.width=176 ...``). ``--stage-files`` takes existing recordings instead (e.g.
  ``fogsim record stage --seed N``), one frame set per file at its own resolution.
- ``edge`` / ``centre`` (`mapper.synthetic`): a ground plane, two boxes and a wall 3.2 m
  ahead, seen from 0.70 m (above the grid's 0.58 m top) pitched down 22°, 47° × 39° field of
  view; from the grid's -x edge (every ray ends inside the 4 m grid at 1–3.5 m) or from its
  centre; ±5 mm z noise, the camera swaying by a few millimetres per frame.

Peers run interleaved in blocks of ``--block`` frames (each runs frames i … i+9, then the
next one does), so load from other processes hits them alike; the figure is the median per
frame. Code generation: numba compiles for the host CPU unless ``NUMBA_CPU_NAME`` names
another; the bench runs itself once per codegen in a child process with a numba cache of its
own, the kernels' shipped build left out, and prints them all, with ``os.getloadavg()`` before
and after each frame set: ``host``, ``x86-64-v2`` (the shipped build's CPU,
`fogsim.run.kernel_bundle.BUILD_CPU`: the code a fresh machine runs) and LLVM's ``generic``
x86-64 (``--codegen all``; ``both``, the default, is host and generic).

Per-stage breakdown (``--stages``): after the interleaved peers, ``FloorObstacleMapper.update``
once more over the same frames with each stage it calls timed on its own (the frame checks, the
insert, the columns above the grid's top (`mapper.above_top`, missing from the rows until
session 42: 0.053 ms of the stage's 0.81 ms, ``x86-64-v2``), eq. 8's floor check, the floor
votes, eq. 9, the floor cover, and the FOG, which ``update`` leaves to the next read of the map
and the pass reads after every update; thread CPU
time around each call, the wrapping adding a few microseconds a call): rows ``update: STAGE``
and ``update (stages summed)``, medians per frame, so that a speed-up of the update can be told
apart by where it comes from. The peer ``FloorObstacleMapper + fog() a frame`` is the update
with the FOG read after every frame (what it cost when ``update`` computed it).

Run: ``.venv/bin/python bench/bench_mapper.py [--frames 200] [--sets stage edge centre]
[--codegen all|both|host|x86-64-v2|generic] [--stage-files REC.npz ...] [--stages]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import octomap
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from machine import cpu_model  # bench/machine.py, beside this script

import mapper.mapper as mapper_module
from fogsim.config.params import resolve_params
from fogsim.data.recording import FORMAT_VERSION, load_recording
from fogsim.mapping.pipeline import Pipeline
from fogsim.run.kernel_bundle import BUILD_CPU
from fogsim.run.runner import sensor_fields
from mapper import AveragingMap, FloorObstacleMapper, MapperParams, PinholeIntrinsics
from mapper.synthetic import Box, camera_rays_world, cast_frame

ROOT = Path(__file__).resolve().parents[1]
RESOLUTIONS = ((88, 72), (176, 144))
BOXES = (
    Box((-0.6, 0.3), (0.4, 0.4, 0.07)),
    Box((0.0, -0.5), (0.3, 0.3, 0.25), walkable=False),
    Box((1.35, 0.0), (0.1, 4.0, 1.0), walkable=False),
)
# synthetic scene name -> (camera position [m], pitch down [deg]); see the module docstring
SCENES = {
    "edge": (np.array([-1.9, 0.0, 0.70]), 22.0),
    "centre": (np.array([0.0, 0.0, 0.70]), 22.0),
}
PEERS = (
    "FloorObstacleMapper",
    "FloorObstacleMapper + fog() a frame",
    "FloorObstacleMapper (cell marks)",
    "FloorObstacleMapper (discretized)",
    "AveragingMap",
    "octomap insertPointCloud",
    "octomap insertPointCloud (discretize)",
)


@dataclass(frozen=True)
class MapperInput:
    """What one ``update`` gets, and where the grid is centred before it.

    Attributes:
        points: (N, 3) world points [m].
        floor_heights: (N,) floor height of each point [m], NaN = not floor.
        sensor_origin: (3,) world camera position [m].
        center_xy_m: World (x, y) the grid is recentred on before the update [m].
    """

    points: NDArray[np.float64]
    floor_heights: NDArray[np.float64]
    sensor_origin: NDArray[np.float64]
    center_xy_m: tuple[float, float]


@dataclass(frozen=True)
class FrameSet:
    """Frames of one source at one resolution, with the mapper parameters they were made for."""

    name: str
    resolution: str
    params: MapperParams
    frames: list[MapperInput]


@dataclass(frozen=True)
class Row:
    """One peer's times on one frame set in one process (milliseconds per frame)."""

    frame_set: str
    resolution: str
    peer: str
    codegen: str
    median_ms: float
    p90_ms: float
    points: int
    load_before: tuple[float, float, float]
    load_after: tuple[float, float, float]


def synthetic_frames(scene: str, width: int, height: int, count: int, seed: int = 0) -> FrameSet:
    """The ``edge`` or ``centre`` scene (module docstring), grid centred at the origin."""
    rng = np.random.default_rng(seed)
    intrinsics = PinholeIntrinsics.from_fov(width, height, 47.0, 39.0)
    camera0, pitch_deg = SCENES[scene]
    rays = camera_rays_world(intrinsics, yaw_deg=0.0, pitch_down_deg=pitch_deg)
    dx = camera0[0] - SCENES["edge"][0][0]  # the same boxes, at the same place ahead
    boxes = [replace(b, center_xy=(b.center_xy[0] + dx, b.center_xy[1])) for b in BOXES]
    frames = []
    for i in range(count):
        camera = camera0 + np.array([0.002 * (i % 20), 0.001 * (i % 7), 0.003 * (i % 3)])
        points, heights = cast_frame(camera, rays, boxes, max_range_m=3.5, noise_z_m=0.005, rng=rng)
        frames.append(MapperInput(points, heights, camera, (0.0, 0.0)))
    return FrameSet(scene, f"{width}x{height}", MapperParams(), frames)


def stage_recording(directory: Path, width: int, height: int) -> Path:
    """The stage scenario recorded at ``width × height`` (made with the CLI on first use).

    The file name carries the recording format version: a recording made by an older fogsim
    does not load (``RecordingError``), so it is recorded again beside it instead.
    """
    path = directory / f"stage-{width}x{height}-v{FORMAT_VERSION}.npz"
    if not path.is_file():
        directory.mkdir(parents=True, exist_ok=True)
        command = [sys.executable, "-m", "fogsim", "record", "stage", "--out", str(path)]
        command += ["--set", f"camera.width={width}", "--set", f"camera.height={height}"]
        # Its "recorded ..." line goes to stderr: a child's stdout holds only JSON rows.
        subprocess.run([*command, "--quiet"], check=True, cwd=ROOT, stdout=sys.stderr)
    return path


def stage_frames(path: Path, count: int) -> FrameSet:
    """The mapper's inputs when the recording is replayed: ``count`` frames evenly spaced."""
    recording = load_recording(path)
    scenario = recording.scenario
    # No heading rebuild: it would replace the mapper whose inputs are captured here.
    pipeline = Pipeline(
        resolve_params(scenario, {"pipe.heading_rebuild_frames": 0}, sensor=sensor_fields(scenario))
    )
    mapper = pipeline.mapper
    captured: list[MapperInput] = []
    center: list[tuple[float, float]] = [(0.0, 0.0)]
    recenter, update = mapper.recenter, mapper.update

    def capture_recenter(x_m: float, y_m: float) -> tuple[int, int]:
        center[0] = (float(x_m), float(y_m))
        return recenter(x_m, y_m)

    def capture_update(points, floor_heights, sensor_origin):
        captured.append(
            MapperInput(
                np.array(points, dtype=np.float64),
                np.array(floor_heights, dtype=np.float64),
                np.array(sensor_origin, dtype=np.float64),
                center[0],
            )
        )
        return update(points, floor_heights, sensor_origin)

    mapper.recenter, mapper.update = capture_recenter, capture_update
    for frame in recording.frames:
        pipeline.process(frame)
    keep = np.linspace(0, len(captured) - 1, min(count, len(captured))).round().astype(int)
    k = recording.intrinsics
    return FrameSet(
        "stage", f"{k.width}x{k.height}", pipeline.mapper_params, [captured[i] for i in keep]
    )


def make_peers(params: MapperParams) -> dict[str, Callable[[MapperInput], float]]:
    """Each peer's insertion of one frame; returns the seconds the insertion itself took."""
    column = FloorObstacleMapper(replace(params, discretize_rays=False))
    read_fog = FloorObstacleMapper(replace(params, discretize_rays=False))
    cell = FloorObstacleMapper(replace(params, discretize_rays=False), column_marks=False)
    discretized = FloorObstacleMapper(replace(params, discretize_rays=True))
    averaging = AveragingMap(params)

    def grid_map(
        m: FloorObstacleMapper | AveragingMap, fog: bool = False
    ) -> Callable[[MapperInput], float]:
        def insert(f: MapperInput) -> float:
            m.recenter(*f.center_xy_m)
            t0 = time.thread_time()
            m.update(f.points, f.floor_heights, f.sensor_origin)
            if fog:  # the FOG is computed when read (`FloorObstacleMapper._refresh_fog`)
                m.fog()  # type: ignore[union-attr]
            return time.thread_time() - t0

        return insert

    def octo(discretize: bool) -> Callable[[MapperInput], float]:
        tree = octomap.OcTree(params.cell_m)

        def insert(f: MapperInput) -> float:
            finite = np.ascontiguousarray(f.points[np.all(np.isfinite(f.points), axis=1)])
            t0 = time.thread_time()
            tree.insertPointCloud(finite, f.sensor_origin, discretize=discretize)
            return time.thread_time() - t0

        return insert

    impls = (
        grid_map(column),
        grid_map(read_fog, fog=True),
        grid_map(cell),
        grid_map(discretized),
        grid_map(averaging),
        octo(False),
        octo(True),
    )
    return dict(zip(PEERS, impls, strict=True))


def time_interleaved(frame_set: FrameSet, block: int, codegen: str) -> list[Row]:
    """Per-frame times of every peer, interleaved in blocks of frames; one row per peer."""
    # warm-up (JIT compile or cache load) on separate instances
    for insert in make_peers(frame_set.params).values():
        insert(frame_set.frames[0])
    peers = make_peers(frame_set.params)
    frames = frame_set.frames
    times = {name: np.empty(len(frames)) for name in peers}
    load_before = os.getloadavg()
    for start in range(0, len(frames), block):
        for name, insert in peers.items():
            for i in range(start, min(start + block, len(frames))):
                times[name][i] = insert(frames[i])
    return _rows(frame_set, codegen, times, load_before, os.getloadavg())


def _rows(
    frame_set: FrameSet,
    codegen: str,
    times_s: dict[str, np.ndarray],
    load_before: tuple[float, float, float],
    load_after: tuple[float, float, float],
) -> list[Row]:
    """One row per timed name: median and 90th percentile of its per-frame times [ms]."""
    points = int(np.median([len(f.points) for f in frame_set.frames]))
    return [
        Row(
            frame_set.name,
            frame_set.resolution,
            name,
            codegen,
            float(np.median(t) * 1e3),
            float(np.percentile(t, 90) * 1e3),
            points,
            load_before,
            load_after,
        )
        for name, t in times_s.items()
    ]


#: The stages of ``FloorObstacleMapper.update`` (names in `mapper.mapper`) timed by ``--stages``.
STAGES = (
    "validate_frame",
    "insert_frame_columns",
    "update_above_top",
    "verify_floor",
    "frame_verdicts",
    "update_floor",
    "frame_floor_heights",
    "accumulate_cover",
    "update_fog_area",
)


def stage_breakdown(frame_set: FrameSet, codegen: str) -> list[Row]:
    """Per-stage CPU times of ``FloorObstacleMapper.update`` over the frames (``--stages``).

    Each stage's function is replaced in `mapper.mapper` by a timing wrapper for the pass (and
    put back after it); a frame's stage time is the sum over its calls (0 when it is not called,
    e.g. an empty frame). The FOG (`update_fog_area`) is computed when read, not in ``update``:
    the pass reads it after every update, so the stages sum to the update plus that read. A
    first pass on a throwaway mapper warms the kernels.
    """
    originals = {name: getattr(mapper_module, name) for name in STAGES}
    spent = dict.fromkeys(STAGES, 0.0)

    def timed(name: str) -> Callable:
        function = originals[name]

        def call(*args, **kwargs):
            t0 = time.thread_time()
            result = function(*args, **kwargs)
            spent[name] += time.thread_time() - t0
            return result

        return call

    make_peers(frame_set.params)["FloorObstacleMapper"](frame_set.frames[0])
    mapper = FloorObstacleMapper(replace(frame_set.params, discretize_rays=False))
    times = {name: np.empty(len(frame_set.frames)) for name in STAGES}
    load_before = os.getloadavg()
    try:
        for name in STAGES:
            setattr(mapper_module, name, timed(name))
        for i, f in enumerate(frame_set.frames):
            mapper.recenter(*f.center_xy_m)
            for name in STAGES:
                spent[name] = 0.0
            mapper.update(f.points, f.floor_heights, f.sensor_origin)
            mapper.fog()  # the FOG stage runs when the FOG is read (`update` marks its area)
            for name in STAGES:
                times[name][i] = spent[name]
    finally:
        for name, function in originals.items():
            setattr(mapper_module, name, function)
    load_after = os.getloadavg()
    times["(stages summed)"] = np.sum([times[name] for name in STAGES], axis=0)
    named = {f"update: {name}": t for name, t in times.items()}
    return _rows(frame_set, codegen, named, load_before, load_after)


def measure(args: argparse.Namespace, codegen: str) -> list[Row]:
    """All requested frame sets in this process."""
    rows = []
    for name in args.sets:
        if name == "stage" and args.stage_files:
            for path in args.stage_files:
                frame_set = stage_frames(Path(path), args.frames)
                rows += time_interleaved(frame_set, args.block, codegen)
                rows += stage_breakdown(frame_set, codegen) if args.stages else []
            continue
        for width, height in RESOLUTIONS:
            if name == "stage":
                path = stage_recording(Path(args.recordings), width, height)
                frame_set = stage_frames(path, args.frames)
            else:
                frame_set = synthetic_frames(name, width, height, args.frames)
            rows += time_interleaved(frame_set, args.block, codegen)
            rows += stage_breakdown(frame_set, codegen) if args.stages else []
    return rows


CODEGENS = ("host", BUILD_CPU, "generic")
"""The code generators a child can compile for: the host CPU, the kernels' shipped build's
(`fogsim.run.kernel_bundle.BUILD_CPU`, what a fresh machine runs), LLVM's generic x86-64."""


def run_child(args: argparse.Namespace, codegen: str, cache_dir: Path) -> list[Row]:
    """``measure`` in a child process compiled for ``codegen`` (one of :data:`CODEGENS`)."""
    # Each codegen compiles into a cache of its own, the kernels' shipped build left out: numba
    # would load the build's x86-64-v2 code for any codegen from a shared cache.
    env = dict(os.environ, OMP_NUM_THREADS="1", FOGSIM_KERNEL_BUNDLE="0")
    env["NUMBA_CACHE_DIR"] = str(cache_dir / f"numba-{codegen}")
    env.pop("NUMBA_CPU_NAME", None)
    env.pop("NUMBA_CPU_FEATURES", None)
    if codegen != "host":  # LLVM's CPU of that name, no feature added
        env["NUMBA_CPU_NAME"] = codegen
        env["NUMBA_CPU_FEATURES"] = ""
    command = [sys.executable, __file__, "--child", codegen, "--frames", str(args.frames)]
    command += ["--block", str(args.block), "--recordings", args.recordings, "--sets", *args.sets]
    if args.stage_files:
        command += ["--stage-files", *args.stage_files]
    if args.stages:
        command += ["--stages"]
    out = subprocess.run(command, env=env, check=True, capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines():
        fields = json.loads(line)
        fields["load_before"] = tuple(fields["load_before"])
        fields["load_after"] = tuple(fields["load_after"])
        rows.append(Row(**fields))
    return rows


def machine() -> str:
    """CPU model (`machine.cpu_model`), core count and OS."""
    return f"{cpu_model()}, {os.cpu_count()} cores, {platform.platform()}"


def print_table(rows: list[Row]) -> None:
    """The rows, then per frame set and codegen the speed-ups that matter."""
    print(
        f"{'set':7s} {'frame':>8s} {'codegen':9s} {'peer':33s} {'points':>7s} "
        f"{'CPU ms med':>10s} {'p90':>8s}  load (1, 5, 15 min) before / after"
    )
    for r in rows:
        load = f"{'/'.join(f'{v:.1f}' for v in r.load_before)} / "
        load += "/".join(f"{v:.1f}" for v in r.load_after)
        print(
            f"{r.frame_set:7s} {r.resolution:>8s} {r.codegen:9s} {r.peer:33s} {r.points:7d} "
            f"{r.median_ms:10.3f} {r.p90_ms:8.3f}  {load}"
        )
    by = {(r.frame_set, r.resolution, r.codegen, r.peer): r.median_ms for r in rows}
    print()
    for key in sorted({(r.frame_set, r.resolution, r.codegen) for r in rows}):
        ours, read, cell, discretized, _, octo, octo_discretized = (by[(*key, p)] for p in PEERS)
        print(
            f"{' '.join(key)}: update {ours:.3f} ms, column vs cell marks {cell / ours:.2f}x, "
            f"vs OctoMap {octo / ours:.1f}x; with fog() a frame {read:.3f} ms, vs OctoMap "
            f"{octo / read:.1f}x; discretized {discretized:.3f} ms, vs OctoMap "
            f"{octo / discretized:.1f}x, vs OctoMap discretized "
            f"{octo_discretized / discretized:.1f}x"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=200, help="frames per set")
    parser.add_argument("--sets", nargs="+", choices=["stage", *SCENES], default=["stage", "edge"])
    parser.add_argument("--block", type=int, default=10, help="frames per interleaved block")
    parser.add_argument("--codegen", choices=["all", "both", *CODEGENS], default="both")
    parser.add_argument(
        "--recordings",
        default=str(Path(tempfile.gettempdir()) / "fogsim-bench"),
        help="where the stage recordings are kept (made on first use)",
    )
    parser.add_argument(
        "--stage-files",
        nargs="+",
        default=[],
        help="existing stage recordings to take the stage frames from (instead of recording)",
    )
    parser.add_argument(
        "--stages",
        action="store_true",
        help="also time each stage of FloorObstacleMapper.update (module docstring)",
    )
    parser.add_argument("--child", choices=CODEGENS, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        for row in measure(args, args.child):
            print(json.dumps(row.__dict__))
        return
    codegens = {"all": CODEGENS, "both": ("host", "generic")}.get(args.codegen, (args.codegen,))
    with tempfile.TemporaryDirectory() as cache_dir:
        rows = [row for c in codegens for row in run_child(args, c, Path(cache_dir))]
    print(f"{machine()}; {args.frames} frames per set, blocks of {args.block}")
    print_table(rows)


if __name__ == "__main__":
    main()
