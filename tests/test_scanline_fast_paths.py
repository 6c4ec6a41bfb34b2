"""The scan-line kernels' fast paths against plain definitions (session 26 speed work).

`region_interior` without branches, the noise box means counted once and summed by rows,
`plane_moments` taking rays and depths, `foreign_rim` in one pass: each equals the obvious
numpy computation of what its docstring says.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapper import scanline


def _blocky_labels(rng: np.random.Generator) -> np.ndarray:
    labels = rng.integers(-2, 3, size=(rng.integers(1, 12), rng.integers(1, 12)))
    return np.ascontiguousarray(np.repeat(np.repeat(labels, 3, axis=0), 3, axis=1))


def _interior_reference(labels: np.ndarray, margin: int) -> np.ndarray:
    height, width = labels.shape
    out = labels >= 0
    for k in range(1, margin + 1):
        padded = np.pad(labels, k, constant_values=-3)  # beyond the border: another region
        for dr, dc in ((-k, 0), (k, 0), (0, -k), (0, k)):
            out &= padded[k + dr : k + dr + height, k + dc : k + dc + width] == labels
    return out


@pytest.mark.parametrize("margin", [0, 1, 2, 3])
def test_region_interior_is_the_plain_definition(margin):
    rng = np.random.default_rng(margin)
    for _ in range(40):
        labels = _blocky_labels(rng)
        np.testing.assert_array_equal(
            scanline.region_interior(labels, margin), _interior_reference(labels, margin)
        )


def test_box_mean_is_the_clipped_mean_of_a_3_row_box():
    rng = np.random.default_rng(7)
    values = rng.uniform(0.0, 1.0, size=(9, 13))
    values[rng.random(values.shape) < 0.3] = np.nan
    clip = rng.uniform(0.1, 0.5, size=values.shape)
    half_cols = 2
    counts, work, row_sum, out = (np.empty(values.shape) for _ in range(4))
    scanline._box_counts(values, half_cols, counts, row_sum)
    scanline._box_mean(values, 2.5, clip, half_cols, counts, work, row_sum, out)
    clipped = np.minimum(values, 2.5 * clip)
    for r in range(values.shape[0]):
        for c in range(values.shape[1]):
            box = clipped[max(r - 1, 0) : r + 2, max(c - half_cols, 0) : c + half_cols + 1]
            present = box[np.isfinite(box)]
            assert counts[r, c] == present.size
            if present.size >= 3:
                assert out[r, c] == pytest.approx(present.mean(), rel=1e-12)
            else:
                assert np.isnan(out[r, c])


def test_plane_moments_of_rays_and_depths_are_those_of_the_points():
    rng = np.random.default_rng(3)
    height, width = 6, 8
    u, v = np.meshgrid(np.linspace(-0.4, 0.4, width), np.linspace(-0.3, 0.3, height))
    rays = np.stack([u, v, np.ones_like(u)], axis=-1).reshape(-1, 3)
    depth = rng.uniform(1.0, 2.0, size=(height, width))
    pixel_index = np.flatnonzero(rng.random(height * width) < 0.8)
    ids = rng.integers(-1, 2, size=pixel_index.size)
    normals = np.array([[0.0, 0.0, 1.0], [0.0, -0.6, 0.8]])
    centroids, eigen, areas = scanline.plane_moments(
        rays, depth, pixel_index, ids, normals, 2, 100.0, 100.0
    )
    points = rays[pixel_index] * depth.ravel()[pixel_index][:, None]
    for p in range(2):
        mine = points[ids == p]
        np.testing.assert_allclose(centroids[p], mine.mean(axis=0), rtol=1e-12)
        covariance = np.cov(mine.T, bias=True)
        np.testing.assert_allclose(eigen[p], np.linalg.eigvalsh(covariance), atol=1e-12)
        assert areas[p] > 0.0


def test_foreign_rim_is_the_ring_off_its_level():
    labels = np.array([[0, 0, 0], [0, 0, -1], [-2, 1, 1]])
    height_interior = np.array([[False, False, False], [False, True, False], [False, False, True]])
    z = np.array([[0.0, 0.05, 0.01], [0.2, 0.2, 0.0], [0.0, 0.5, 0.9]])
    sigma_z = np.full((3, 3), 0.01)
    rim = scanline.foreign_rim(labels, height_interior, z, sigma_z, np.array([0.0, 0.5]), 3.0)
    expected = np.array([[False, True, False], [True, False, False], [False, False, False]])
    np.testing.assert_array_equal(rim, expected)
