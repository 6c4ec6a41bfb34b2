"""Error statistics of the stereo head on the stage: what the ``depth`` mode must reproduce.

Run: MUJOCO_GL=egl .venv/bin/python bench/stereo_stats.py [--seeds 1-3] [--every 8]

Walks the stage (robot, seeds given) in ``stereo`` mode and compares each sampled frame's depth
with the exact depth of the same (left) camera, ``HeadCamera.exact_depth``, pixel for pixel over
the measurable range. With the same statistics it measures the ``depth`` mode's error model
(``--set`` style values below, default: the scenario's) on the same exact depth, so the two
columns can be compared. Reported, in output pixels of disparity ``d = f·b/z``:

  bias, noise     median and robust std (1.4826·MAD) of d_measured − d_true on surfaces
                  (pixels at least 2 px from a depth edge), overall and per range bin
  noise_p99       99th percentile of |d_measured − d_true − bias| / 2.576: the std of a Gaussian
                  with the same tail, what k-sigma tolerance tests need
  gross           fraction of surface pixels off by more than 1 px
  correlation     of the surface pixels' errors with their neighbours' at a few lags (rows,
                  columns): stereo errors are smooth over the matching window, white noise not
  mean variance   n·var(mean of n row neighbours)/var(pixel) for runs of 4, 8, 16 px: how much
                  the correlation inflates a row segment's mean (1 for white noise)
  dropout         fraction of surface pixels without a measurement, per range bin
  floor, raised   noise (robust std) on the floor (world z within 3 mm of 0) and on raised level
                  surfaces (box tops, sill, treads: z above 10 mm with level neighbours) in the
                  1-2 m band: a matcher that errs more on objects than on the floor (e.g. a
                  streaked texture) shows here, not in the pooled figure
  edge            near depth edges (1–2 px, background side): dropout, and how often the
                  measurement is nearer the foreground's depth (nearest within 2 px) than the
                  true one (edge fattening)
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")

import cv2
import numpy as np
from scipy.ndimage import grey_erosion

from fogsim.config import load_scenario
from fogsim.run.seed_spec import parse_seeds
from fogsim.sim.camera import StereoErrorModel, camera_intrinsics
from fogsim.sim.simulation import Simulation

RANGE_BINS_M = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0)
"""Edges of the depth bins [m] the range dependence is reported in."""
CORRELATION_LAGS_PX = ((0, 1), (0, 2), (0, 4), (0, 8), (1, 0), (2, 0), (4, 0))
"""(rows, columns) lags at which the disparity errors' correlation is reported."""
SURFACE_KINDS = {"floor": 1, "raised": 2}
"""Codes of :func:`surface_kind`: the floor, raised level surfaces (tops of boxes, sill, treads)."""
MEAN_RUNS_PX = (4, 8, 16)
"""Row run lengths [px] whose means' variance inflation by correlated errors is reported."""
ROBOT_BASELINE_M = 0.068
"""The stage robot's (iCub's) stereo baseline [m], ``assets/robots/icub.toml``: disparities are
in its output pixels."""


def edge_distance_px(exact_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel: distance [px] to the nearest depth edge, and whether it is the far side.

    A depth edge is a pixel pair (4-neighbours) whose depths differ by more than 5 % (or one
    without depth); a pixel on the background side is farther than the edge's near depth.
    """
    z = np.nan_to_num(exact_m, nan=1e3)
    near = cv2.erode(z, np.ones((3, 3), np.uint8))
    edge = (z - near) > 0.05 * near
    edge |= (cv2.dilate(z, np.ones((3, 3), np.uint8)) - z) > 0.05 * z
    distance = cv2.distanceTransform((~edge).astype(np.uint8), cv2.DIST_L2, 3)
    nearest_near = cv2.erode(z, np.ones((5, 5), np.uint8))
    far_side = z > 1.05 * nearest_near
    return distance, far_side


def surface_kind(exact_m: np.ndarray, transform_camera_to_world: np.ndarray, intrinsics):
    """Per pixel: 1 on the floor, 2 on a raised level surface, 0 elsewhere (see the docstring).

    From the exact depth and the true camera pose: world z within 3 mm of 0 is floor; above
    10 mm with its 3 × 3 neighbours' z within 3 mm of its own, a raised level surface.
    """
    rays = intrinsics.ray_directions_camera()
    points = (rays * exact_m[..., None]) @ transform_camera_to_world[:3, :3].T
    z = np.nan_to_num(points[..., 2] + transform_camera_to_world[2, 3], nan=-1.0)
    spread = cv2.dilate(z, np.ones((3, 3), np.uint8)) - cv2.erode(z, np.ones((3, 3), np.uint8))
    kind = np.zeros(z.shape, dtype=np.int8)
    kind[np.abs(z) < 0.003] = 1
    kind[(z > 0.010) & (spread < 0.003)] = 2
    return kind


def frame_pairs(seed: int, every: int, overrides: dict[str, object]):
    """(exact, stereo, depth-mode, surface kind) of every ``every``-th frame of the stage walk.

    The depth mode's error model is the scenario's with ``overrides``, at the robot's baseline.
    """
    base = load_scenario("stage")
    scenario = dataclasses.replace(
        base, seed=seed, camera=dataclasses.replace(base.camera, mode="stereo")
    )
    sim = Simulation(scenario)
    noise = dataclasses.replace(
        StereoErrorModel.from_config(base.camera, sim.intrinsics.fx),
        baseline_m=sim.camera.baseline_m,
        **overrides,
    )
    scene, robot, trajectory = sim.scene, sim.robot, sim.trajectory
    try:
        for index in range(0, trajectory.frame_count, every):
            scene.set_time(float(trajectory.times_s[index]))
            scene.set_robot_qpos(robot.qpos_mujoco(trajectory.q[index]))
            scene.forward()
            rng = np.random.default_rng([seed, 7, index])
            stereo = sim.camera.capture(scene.data, rng)
            exact = sim.camera.exact_depth(scene.data)
            kind = surface_kind(
                exact, scene.camera_to_world(sim.depth_camera), sim.camera.intrinsics
            )
            yield exact, stereo, noise.apply(exact, rng), kind
    finally:
        sim.close()


def mean_variance_factor(error: np.ndarray, ok: np.ndarray, n: int) -> float:
    """n·var(mean of n row neighbours) / var(one pixel): 1 for white noise.

    Over the non-overlapping runs of ``n`` columns that are all valid surface pixels; the
    segmentation's ``noise_correlation_factor`` (how much correlated errors inflate the
    variance of a row segment's mean).
    """
    frames, height, width = error.shape
    usable = width // n * n
    runs_ok = ok[:, :, :usable].reshape(frames, height, -1, n).all(axis=-1)
    runs = error[:, :, :usable].reshape(frames, height, -1, n)[runs_ok]
    centred = runs - np.median(error[ok])
    return float(n * np.var(centred.mean(axis=-1)) / np.var(centred))


def statistics(
    exact: np.ndarray,
    measured: np.ndarray,
    distance: np.ndarray,
    far: np.ndarray,
    kind: np.ndarray,
    fb: float,
) -> dict[str, float]:
    """The figures of one mode over the pooled pixels (see the module docstring)."""
    in_range = np.isfinite(exact) & (exact >= RANGE_BINS_M[0]) & (exact <= RANGE_BINS_M[-1])
    surface = in_range & (distance >= 2)
    error = fb / measured - fb / exact
    ok = surface & np.isfinite(measured)
    result = {
        "bias_px": float(np.median(error[ok])),
        "noise_px": float(1.4826 * np.median(np.abs(error[ok] - np.median(error[ok])))),
        "noise_p99_px": float(
            np.percentile(np.abs(error[ok] - np.median(error[ok])), 99.0) / 2.576
        ),
        "gross": float(np.mean(np.abs(error[ok]) > 1.0)),
        "dropout": float(1.0 - ok.sum() / surface.sum()),
        "median_abs_mm": float(1e3 * np.median(np.abs(measured[ok] - exact[ok]))),
    }
    for low, high in itertools.pairwise(RANGE_BINS_M):
        part = surface & (exact >= low) & (exact < high)
        good = part & np.isfinite(measured)
        e = error[good]
        tag = f"{low:.1f}-{high:.1f}m"
        result[f"noise_px {tag}"] = float(1.4826 * np.median(np.abs(e - np.median(e))))
        result[f"dropout {tag}"] = float(1.0 - good.sum() / max(part.sum(), 1))
    for name, code in SURFACE_KINDS.items():
        e = error[ok & (kind == code) & (exact >= 1.0) & (exact < 2.0)]
        result[f"noise_px {name} 1-2m"] = float(1.4826 * np.median(np.abs(e - np.median(e))))
    for dy, dx in CORRELATION_LAGS_PX:
        pair = ok[:, dy:, dx:] & ok[:, : ok.shape[1] - dy, : ok.shape[2] - dx]
        a = error[:, dy:, dx:][pair]
        b = error[:, : ok.shape[1] - dy, : ok.shape[2] - dx][pair]
        result[f"correlation lag {dy},{dx} px"] = float(np.corrcoef(a, b)[0, 1])
    for n in MEAN_RUNS_PX:
        result[f"mean variance factor {n} px"] = mean_variance_factor(error, ok, n)
    edge = in_range & far & (distance < 2.5) & (distance > 0)
    edge_ok = edge & np.isfinite(measured)
    result["edge dropout"] = float(1.0 - edge_ok.sum() / max(edge.sum(), 1))
    foreground = grey_erosion(np.nan_to_num(exact, nan=1e3), size=(1, 5, 5))
    fattened = np.abs(measured - foreground) < np.abs(measured - exact)  # took the foreground's
    result["edge fattened"] = float(np.mean(fattened[edge_ok]))
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1-3")
    parser.add_argument("--every", type=int, default=8, help="sample every n-th frame")
    parser.add_argument("--noise-px", type=float, help="depth mode: disparity noise")
    parser.add_argument("--dropout", type=float, help="depth mode: random dropout")
    parser.add_argument("--correlation-px", type=float, help="depth mode: noise smoothing")
    parser.add_argument("--step-px", type=float, help="depth mode: disparity step")
    parser.add_argument("--fattening-px", type=int, help="depth mode: edge fattening")
    parser.add_argument("--occlusion", action="store_true", help="depth mode: occlusion loss")
    args = parser.parse_args()
    base = load_scenario("stage").camera
    given = {
        "disparity_noise_px": args.noise_px,
        "disparity_noise_correlation_px": args.correlation_px,
        "disparity_step_px": args.step_px,
        "dropout": args.dropout,
        "edge_fattening_px": args.fattening_px,
        "occlusion": args.occlusion or None,
    }
    overrides = {key: value for key, value in given.items() if value is not None}
    columns: dict[str, list[np.ndarray]] = {"exact": [], "stereo": [], "depth": []}
    distances, fars, kinds = [], [], []
    for seed in parse_seeds(args.seeds):
        for exact, stereo, depth, kind in frame_pairs(seed, args.every, overrides):
            kinds.append(kind)
            distance, far = edge_distance_px(exact)
            for key, image in zip(columns, (exact, stereo, depth), strict=True):
                columns[key].append(image)
            distances.append(distance)
            fars.append(far)
    exact = np.stack(columns["exact"])
    distance, far, kind = np.stack(distances), np.stack(fars), np.stack(kinds)
    intrinsics = camera_intrinsics(base)
    fb = intrinsics.fx * ROBOT_BASELINE_M  # output px · m
    print(f"stage seeds {args.seeds}, every {args.every}th frame: {exact.shape[0]} frames")
    stats = {
        key: statistics(exact, np.stack(columns[key]), distance, far, kind, fb)
        for key in ("stereo", "depth")
    }
    print(f"depth mode: the scenario's error model with {overrides or 'no changes'}")
    print(f"{'figure':24s} {'stereo':>10s} {'depth':>10s}")
    for name in stats["stereo"]:
        print(f"{name:24s} {stats['stereo'][name]:10.4f} {stats['depth'][name]:10.4f}")


if __name__ == "__main__":
    main()
