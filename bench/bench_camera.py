"""Per-frame cost of the head camera on the stage (88 × 72), peers side by side.

Run: MUJOCO_GL=egl .venv/bin/python bench/bench_camera.py [--frames 60] [--repeats 5]
One core: taskset -c 0 ... (OpenGL's llvmpipe and OpenCV then share it). The load average of
the machine is printed at the start and the end. ``--cpu`` times with the process's CPU time
(every thread) instead of the wall clock: on a loaded machine that is the cost on one core,
without the waiting for the core (its resolution is about a millisecond's tick, so take the
median over many frames).

Reports the median over repeats of the per-frame median [ms] of (one pass per component, so
OpenGL contexts are not switched between timed calls):
  kinematics     scene.set_time + set_robot_qpos + mj_kinematics/comPos/camlight
  render_gl      mujoco.Renderer depth (EGL)           -- the default depth backend
  render_ray     mujoco.mj_multiRay depth (no OpenGL)  -- the other backend
  render_dmc     dm_control Physics.render(depth=True) -- peer; also its depth error vs ours
  noise          stereo error model (depth mode)
  stereo         stereo mode capture: two grey renders at 240 × 144 (176 × 144 widened by the
                 disparity range), SGBM, sub-pixel refinement, reduction to 88 × 72
  stereo_render  its two renders alone (with the sensor noise)
  stereo_match   its matching alone: SGBM, refinement, reduction, depth
  frame_depth    whole Simulation.frames() step in depth mode (render, noise, encoders,
                 believed FK, odometry, self-filter)
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")

import numpy as np

from fogsim.config import load_scenario
from fogsim.sim.camera import HeadCamera, RaycastDepth, RendererDepth
from fogsim.sim.simulation import Simulation

CLOCK = time.perf_counter
"""The clock :func:`timed` reads (``--cpu``: ``time.process_time``)."""


def timed(fn, *args, **kwargs):
    """(elapsed [ms], result) of one call."""
    start = CLOCK()
    result = fn(*args, **kwargs)
    return (CLOCK() - start) * 1e3, result


def kinematics(scene, robot, trajectory, i: int) -> None:
    """Set the world and the robot for frame i and compute positions."""
    scene.set_time(float(trajectory.times_s[i]))
    scene.set_robot_qpos(robot.qpos_mujoco(trajectory.q[i]))
    scene.forward()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--scenario", default="stage")
    parser.add_argument("--cpu", action="store_true", help="process CPU time, not wall time")
    args = parser.parse_args()
    global CLOCK
    CLOCK = time.process_time if args.cpu else time.perf_counter

    scenario = load_scenario(args.scenario)
    load_start = os.getloadavg()[0]
    start = time.perf_counter()
    sim = Simulation(scenario)
    setup_s = time.perf_counter() - start
    scene, robot, trajectory = sim.scene, sim.robot, sim.trajectory
    cam_id = scene.camera_ids["head_camera"]
    renderer = RendererDepth(scene.model, sim.intrinsics, scene.render_geomgroups)
    raycast = RaycastDepth(scene.model, sim.intrinsics, scene.render_geomgroups)
    stereo_config = dataclasses.replace(scenario.camera, mode="stereo")
    stereo = HeadCamera(
        scene.model, dict(scene.camera_ids), stereo_config, baseline_m=robot.stereo_baseline_m
    )
    matcher = stereo._stereo
    left_id, right_id = scene.camera_ids["head_camera_left"], scene.camera_ids["head_camera_right"]
    pair: list = []

    def render_pair() -> None:
        pair[:] = [matcher.grey_image(scene.data, i, rng) for i in (left_id, right_id)]

    def match_pair() -> None:
        matcher.reduce(matcher.disparity_render(*pair))

    # The stereo camera wrote its render intrinsics into the left/right cameras only.
    h, w = sim.intrinsics.shape
    # Spread the sampled frames over the whole walk.
    indices = np.linspace(0, trajectory.frame_count - 1, args.frames).astype(int)
    rng = np.random.default_rng(0)
    results: dict[str, list[float]] = {}
    dmc_error_mm: list[float] = []
    for _ in range(args.repeats):
        per: dict[str, list[float]] = {}
        # One pass per component, so OpenGL contexts are not switched between calls (a
        # context switch in Mesa costs milliseconds and is no part of a real run).
        components = {
            "render_gl": lambda: renderer.render(scene.data, cam_id),
            "render_ray": lambda: raycast.render(scene.data, cam_id),
            "render_dmc": lambda: scene.physics.render(h, w, camera_id=cam_id, depth=True),
            "stereo": lambda: stereo.capture(scene.data, rng),
            "stereo_render": render_pair,
        }
        for name, component in components.items():
            for i in indices:
                ms, _ = timed(kinematics, scene, robot, trajectory, i)
                per.setdefault("kinematics", []).append(ms)
                ms, depth = timed(component)
                per.setdefault(name, []).append(ms)
                if name == "render_gl":
                    ms, _ = timed(sim.camera.noise.apply, depth, rng)
                    per.setdefault("noise", []).append(ms)
                if name == "stereo_render":
                    ms, _ = timed(match_pair)
                    per.setdefault("stereo_match", []).append(ms)
        for i in indices[:10]:
            kinematics(scene, robot, trajectory, i)
            depth_gl = renderer.render(scene.data, cam_id)
            depth_dmc = scene.physics.render(h, w, camera_id=cam_id, depth=True)
            both = np.isfinite(depth_gl) & (depth_dmc < 15.0)
            dmc_error_mm.extend((1e3 * (depth_dmc[both] - depth_gl[both])).tolist())
        frame_iterator = sim.frames()
        next(frame_iterator)
        per["frame_depth"] = [timed(next, frame_iterator)[0] for _ in range(args.frames)]
        for key, values in per.items():
            results.setdefault(key, []).append(float(np.median(values)))
    print(
        f"scenario {scenario.name}, {w}x{h}, setup {setup_s:.2f} s, "
        f"{args.frames} frames x {args.repeats} repeats, load average at start "
        f"{load_start:.2f}, at end {os.getloadavg()[0]:.2f}, cores {len(os.sched_getaffinity(0))}, "
        f"{'CPU' if args.cpu else 'wall'} time"
    )
    for key, medians in results.items():
        print(
            f"  {key:12s} {np.median(medians):7.3f} ms  (repeat medians "
            f"{min(medians):.3f}..{max(medians):.3f})"
        )
    errors = np.asarray(dmc_error_mm)
    print(
        f"  dm_control depth minus mujoco.Renderer depth: median {np.median(errors):.2f} mm, "
        f"p5 {np.percentile(errors, 5):.2f} mm, p95 {np.percentile(errors, 95):.2f} mm"
    )
    for part in (renderer, stereo):
        part.close()
    sim.close()


if __name__ == "__main__":
    main()
