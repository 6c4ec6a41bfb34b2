"""`bench/bench_refine_ab.py`: a base commit's heading refinement against this tree's."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))
bench_refine_ab = pytest.importorskip("bench_refine_ab")
base_module = pytest.importorskip("base_module")

from mapper import heading_planes  # noqa: E402


def _fit() -> "bench_refine_ab.Fit":
    """Two keyframes 0.4 m apart seeing the same two walls, with a 1° yaw error to find."""
    rng = np.random.default_rng(3)
    walls = np.vstack(
        [
            np.column_stack([rng.uniform(0.5, 2.0, 150), np.full(150, 1.0)]),
            np.column_stack([np.full(150, 2.2), rng.uniform(-0.5, 0.9, 150)]),
        ]
    )
    z = np.tile(rng.uniform(0.0, 0.4, 300), 2)
    cameras = np.array([[0.0, 0.0], [0.4, 0.0]])
    yaw = np.array([0.0, 0.0])
    error = math.radians(1.0)
    offsets = []
    for camera in cameras:  # the points as each keyframe believes them: turned by the error
        c, s = math.cos(-error), math.sin(-error)
        relative = walls - camera
        offsets.append(np.column_stack([c * relative[:, 0] - s * relative[:, 1],
                                        s * relative[:, 0] + c * relative[:, 1]]))  # fmt: skip
    offsets_xy = np.ascontiguousarray(np.vstack(offsets))
    keyframe_of = np.repeat(np.arange(2, dtype=np.int64), 300)
    normals, weights = [], []
    for k in range(2):
        n, w = heading_planes.keyframe_normals(
            np.ascontiguousarray(offsets_xy[keyframe_of == k]),
            np.ascontiguousarray(z[keyframe_of == k]),
            heading_planes.NORMAL_RADIUS_M,
        )
        normals.append(n)
        weights.append(w)
    args = (
        offsets_xy, z, np.vstack(normals), np.concatenate(weights), keyframe_of, cameras, yaw,
        0.0, heading_planes.MATCH_M, heading_planes.HUBER_M, heading_planes.MIN_BASELINE_M,
        heading_planes.ITERATIONS, heading_planes.TOLERANCE_RAD, heading_planes.MAX_SHIFT_RAD,
    )  # fmt: skip
    result = tuple(float(v) for v in heading_planes.refine_heading(*args))
    return bench_refine_ab.Fit("synthetic", args, result)


def test_the_fit_is_a_real_refinement():
    # The fixture is worth comparing on: the fit moves toward the 1° error and is accepted.
    fit = _fit()
    correction, information, _ = fit.result
    assert fit.points == 600
    assert information > 0.0
    assert math.degrees(correction) == pytest.approx(1.0, abs=0.3)


def test_a_base_commit_s_module_is_compared_with_this_tree_s(tmp_path):
    if subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True).returncode:
        pytest.skip("not a git checkout")
    base = base_module.module_at("HEAD", "mapper/heading_planes.py", tmp_path)
    assert base.__name__ == "heading_planes_base" and base is not heading_planes
    fit = _fit()
    kernels = {"base": base.refine_heading, "tree": heading_planes.refine_heading}
    rows = bench_refine_ab.compare([fit], kernels, 3)
    assert len(rows) == 1 and rows[0][0] is fit
    assert set(rows[0][1]) == {"base", "tree"} and all(t > 0.0 for t in rows[0][1].values())


def test_a_kernel_that_returns_something_else_stops_the_comparison():
    fit = _fit()

    def off_by_a_bit(*args):
        correction, information, rms = heading_planes.refine_heading(*args)
        return math.nextafter(correction, math.inf), information, rms

    kernels = {"base": heading_planes.refine_heading, "tree": off_by_a_bit}
    with pytest.raises(SystemExit, match="tree returned"):
        bench_refine_ab.compare([fit], kernels, 1)
