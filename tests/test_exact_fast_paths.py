"""Fast roads of the main thread's per-frame geometry give the old numbers bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mapper.heading as _heading
from fogsim.data.frame import Frame
from fogsim.eval.archive import cells_in_view, view_points_world
from mapper import HeadingEstimator, HeadingParams
from mapper.grid import GridGeometry
from mapper.intrinsics import PinholeIntrinsics
from mapper.reference import HeightReference, HeightReferenceParams
from mapper.transforms import apply_transform


def _rigid(rng: np.random.Generator) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    transform = np.eye(4)
    transform[:3, :3] = q
    transform[:3, 3] = rng.normal(scale=3.0, size=3)
    return transform


@pytest.mark.parametrize("count", [*range(0, 40), 63, 64, 65, 127, 128, 129, 999, 6336, 25344])
def test_apply_transform_is_the_broadcast_product_bit_for_bit(count: int) -> None:
    rng = np.random.default_rng(count)
    for _ in range(5):
        transform = _rigid(rng)
        points = rng.normal(scale=2.0, size=(count, 3))
        points[rng.random(count) < 0.1] = np.nan
        expected = points @ transform[:3, :3].T + transform[:3, 3]
        got = apply_transform(transform, points)
        assert got.shape == (count, 3) and got.dtype == np.float64
        np.testing.assert_array_equal(got, expected)
        assert got.tobytes() == expected.tobytes()  # NaN rows too, bit for bit


def test_apply_transform_other_shapes_and_inputs_unchanged() -> None:
    rng = np.random.default_rng(1)
    transform = _rigid(rng)
    image = rng.normal(size=(4, 5, 3))
    np.testing.assert_array_equal(
        apply_transform(transform, image), image @ transform[:3, :3].T + transform[:3, 3]
    )
    vector = rng.normal(size=3)
    np.testing.assert_array_equal(
        apply_transform(transform, vector), vector @ transform[:3, :3].T + transform[:3, 3]
    )
    points = rng.normal(size=(10, 3))
    before = points.copy()
    apply_transform(transform, points)
    np.testing.assert_array_equal(points, before)  # the caller's points are never changed
    as_int = np.arange(12).reshape(4, 3)
    np.testing.assert_array_equal(
        apply_transform(transform, as_int), as_int @ transform[:3, :3].T + transform[:3, 3]
    )


@pytest.mark.parametrize("layout", ["every_other_row", "fortran", "column_slice"])
def test_apply_transform_strided_points_bit_for_bit(layout: str) -> None:
    rng = np.random.default_rng(7)
    for count in (2, 3, 17, 6336):
        transform = _rigid(rng)
        base = rng.normal(size=(2 * count, 5))
        points = {
            "every_other_row": base[::2, :3],
            "fortran": np.asfortranarray(base[:count, :3]),
            "column_slice": base[:count, 1:4],
        }[layout]
        expected = points @ transform[:3, :3].T + transform[:3, 3]
        assert apply_transform(transform, points).tobytes() == expected.tobytes()


# The functions as they were before their fast roads (c2da7ee): the known answers.


def _old_cell_of(geometry: GridGeometry, points_world: np.ndarray):
    p = np.asarray(points_world, dtype=np.float64)
    ox, oy = geometry.origin_xy_m
    lowest = (ox, oy, geometry.z_min_m)
    size = (geometry.cell_m, geometry.cell_m, geometry.layer_m)
    upper = (geometry.nx, geometry.ny, geometry.nz)
    valid = np.ones(p.shape[0], dtype=bool)
    axes = []
    with np.errstate(invalid="ignore"):
        for k in range(p.shape[1]):
            g = np.floor((p[:, k] - lowest[k]) / size[k])
            valid &= (g >= 0) & (g < upper[k])
            axes.append(g)
    idx = np.where(valid[:, None], np.stack(axes, axis=1), -1.0).astype(np.int64)
    return idx, valid


def _old_depth_to_points_camera(intrinsics: PinholeIntrinsics, depth_m: np.ndarray):
    depth = np.asarray(depth_m, dtype=np.float64)
    depth = np.where(depth > 0.0, depth, np.nan)
    return intrinsics.ray_directions_camera() * depth[..., None]


def _old_cells_in_view(frame: Frame, geometry: GridGeometry) -> np.ndarray:
    points_camera = _old_depth_to_points_camera(frame.intrinsics, frame.depth_m).reshape(-1, 3)
    t = np.asarray(frame.transform_camera_to_world_true, dtype=np.float64)
    points_world = points_camera @ t[:3, :3].T + t[:3, 3]
    index, inside = _old_cell_of(geometry, points_world)
    seen = np.zeros((geometry.nx, geometry.ny), dtype=bool)
    seen[index[inside, 0], index[inside, 1]] = True
    return seen


def _geometry(rng: np.random.Generator) -> GridGeometry:
    return GridGeometry(
        nx=int(rng.integers(5, 60)),
        ny=int(rng.integers(5, 60)),
        nz=int(rng.integers(2, 20)),
        cell_m=float(rng.choice([0.02, 0.04, 0.05])),
        layer_m=float(rng.choice([0.01, 0.04])),
        z_min_m=float(rng.uniform(-0.3, 0.1)),
        origin_ix=int(rng.integers(-40, 10)),
        origin_iy=int(rng.integers(-40, 10)),
    )


def _awkward_points(rng: np.random.Generator, geometry: GridGeometry, count: int) -> np.ndarray:
    """Points in and around the grid, some on cell faces, NaN, inf and far off."""
    ox, oy = geometry.origin_xy_m
    span = np.array(
        [
            geometry.nx * geometry.cell_m,
            geometry.ny * geometry.cell_m,
            geometry.nz * geometry.layer_m,
        ]
    )
    low = np.array([ox, oy, geometry.z_min_m])
    points = low + rng.uniform(-0.2, 1.2, (count, 3)) * span
    faces = rng.random(count) < 0.1  # exactly on a cell's lower face
    points[faces, 0] = ox + rng.integers(-2, geometry.nx + 2, faces.sum()) * geometry.cell_m
    points[rng.random(count) < 0.05, 1] = np.nan
    points[rng.random(count) < 0.02, 2] = np.inf
    points[rng.random(count) < 0.02, 0] = -1e300
    return points


def test_cell_of_gives_the_old_indices_bit_for_bit() -> None:
    rng = np.random.default_rng(11)
    for _ in range(40):
        geometry = _geometry(rng)
        points = _awkward_points(rng, geometry, int(rng.integers(0, 3000)))
        for columns in (3, 2):
            index, valid = geometry.cell_of(points[:, :columns])
            old_index, old_valid = _old_cell_of(geometry, points[:, :columns])
            assert index.dtype == np.int64 and valid.dtype == np.bool_
            np.testing.assert_array_equal(index, old_index)
            np.testing.assert_array_equal(valid, old_valid)


def test_columns_seen_are_the_columns_of_cell_of() -> None:
    rng = np.random.default_rng(12)
    for _ in range(40):
        geometry = _geometry(rng)
        points = _awkward_points(rng, geometry, int(rng.integers(0, 3000)))
        index, valid = _old_cell_of(geometry, points)
        expected = np.zeros((geometry.nx, geometry.ny), dtype=bool)
        expected[index[valid, 0], index[valid, 1]] = True
        np.testing.assert_array_equal(geometry.columns_seen(points), expected)


def _old_columns_seen(geometry: GridGeometry, p: np.ndarray) -> np.ndarray:
    """``GridGeometry.columns_seen`` at 30a3fc2 (numpy)."""
    ox, oy = geometry.origin_xy_m
    vx = (p[:, 0] - ox) / geometry.cell_m
    vy = (p[:, 1] - oy) / geometry.cell_m
    vz = (p[:, 2] - geometry.z_min_m) / geometry.layer_m
    with np.errstate(invalid="ignore"):
        inside = (vx >= 0.0) & (vx < geometry.nx) & (vy >= 0.0) & (vy < geometry.ny)
        inside &= (vz >= 0.0) & (vz < geometry.nz)
    seen = np.zeros(geometry.nx * geometry.ny, dtype=bool)
    seen[vx[inside].astype(np.int64) * geometry.ny + vy[inside].astype(np.int64)] = True
    return seen.reshape(geometry.nx, geometry.ny)


def test_columns_seen_compiled_are_the_old_numpy_columns_bit_for_bit() -> None:
    rng = np.random.default_rng(15)
    for trial in range(40):
        geometry = _geometry(rng)
        points = _awkward_points(rng, geometry, int(rng.integers(0, 3000)))
        if trial % 3 == 1:  # strided rows, as a caller's view may be
            points = np.repeat(points, 2, axis=0)[::2]
        if trial % 3 == 2:  # float32 points (-1e300 becomes -inf)
            with np.errstate(over="ignore"):
                points = points.astype(np.float32)
        got = geometry.columns_seen(points)
        expected = _old_columns_seen(geometry, np.asarray(points, dtype=np.float64))
        assert got.dtype == expected.dtype and got.shape == expected.shape
        assert got.tobytes() == expected.tobytes()


def test_depth_to_points_camera_is_the_old_broadcast_bit_for_bit() -> None:
    rng = np.random.default_rng(13)
    for width, height in ((88, 72), (176, 144), (1, 1), (5, 3)):
        intrinsics = PinholeIntrinsics.from_fov(width, height, 47.0, 39.0)
        depth = rng.uniform(0.05, 6.0, (height, width)).astype(np.float32)
        depth[rng.random(depth.shape) < 0.1] = np.nan
        depth[rng.random(depth.shape) < 0.05] = 0.0
        depth[rng.random(depth.shape) < 0.02] = -1.0
        for image in (depth, depth.astype(np.float64)):
            got = intrinsics.depth_to_points_camera(image)
            expected = _old_depth_to_points_camera(intrinsics, image)
            assert got.shape == (height, width, 3) and got.flags.c_contiguous
            assert got.tobytes() == expected.tobytes()


def test_cells_in_view_are_the_old_cells_on_random_poses() -> None:
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(14)
    intrinsics = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    geometry = GridGeometry(
        nx=100, ny=100, nz=40, cell_m=0.04, layer_m=0.04, z_min_m=-0.2, origin_ix=-50, origin_iy=-50
    )
    seeing = 0
    for trial in range(30):
        pose = np.eye(4)
        pose[:3, :3] = Rotation.random(random_state=trial).as_matrix()
        pose[:3, 3] = rng.uniform([-2.0, -2.0, 0.2], [2.0, 2.0, 1.2])
        depth = rng.uniform(0.1, 5.0, intrinsics.shape).astype(np.float32)
        depth[rng.random(depth.shape) < 0.1] = np.nan
        frame = Frame(
            index=trial,
            time_s=0.08 * trial,
            depth_m=depth,
            intrinsics=intrinsics,
            transform_camera_to_robot_believed=pose,
            robot_pose_believed=np.zeros(4),
            transform_camera_to_world_true=pose,
            robot_pose_true=np.zeros(4),
        )
        expected = _old_cells_in_view(frame, geometry)
        seeing += bool(expected.any())
        np.testing.assert_array_equal(cells_in_view(frame, geometry), expected)
    assert seeing >= 15  # most random poses see part of the grid


def _old_frame_errors(frame: Frame, corrected: np.ndarray | None):
    """The accumulator's per-frame computation before it was batched (c2da7ee)."""
    from fogsim.eval.pose_error import heading_error_deg
    from fogsim.geometry import pose_error
    from mapper.transforms import planar_pose_to_matrix

    world_true = np.asarray(frame.transform_camera_to_world_true, dtype=np.float64)
    robot_true = np.asarray(frame.robot_pose_true, dtype=np.float64)
    if not (np.all(np.isfinite(world_true)) and np.all(np.isfinite(robot_true))):
        return None, None
    camera_true = np.linalg.inv(planar_pose_to_matrix(robot_true)) @ world_true
    in_robot = pose_error(frame.transform_camera_to_robot_believed, camera_true)
    in_world = pose_error(frame.transform_camera_to_world_believed, world_true)
    residual = None
    if corrected is not None:
        residual = abs(heading_error_deg(np.asarray(corrected)[:3, :3], camera_true[:3, :3]))
    row = (in_robot.rotation_deg, in_robot.translation_mm)
    return (*row, in_world.rotation_deg, in_world.translation_mm), residual


def _random_pose_frame(rng: np.random.Generator, index: int) -> Frame:
    from scipy.spatial.transform import Rotation

    def rigid(scale: float) -> np.ndarray:
        transform = np.eye(4)
        transform[:3, :3] = Rotation.from_rotvec(rng.normal(scale=scale, size=3)).as_matrix()
        transform[:3, 3] = rng.normal(scale=0.5, size=3)
        return transform

    robot_true = np.array([*rng.uniform(-5, 5, 2), rng.uniform(0, 0.3), rng.uniform(-7, 7)])
    robot_believed = robot_true + rng.normal(scale=[0.02, 0.02, 0.005, 0.03])
    camera_true = rigid(0.5)
    world_true = np.eye(4)
    c, s = np.cos(robot_true[3]), np.sin(robot_true[3])
    world_true[:2, :2] = [[c, -s], [s, c]]
    world_true[:3, 3] = robot_true[:3]
    world_true = world_true @ camera_true
    if rng.random() < 0.1:  # no true pose (real data): skipped
        world_true = np.full((4, 4), np.nan)
    elif rng.random() < 0.05:
        robot_true = robot_true.copy()
        robot_true[1] = np.inf
    return Frame(
        index=index,
        time_s=index / 12.5,
        depth_m=np.ones((2, 2), np.float32),
        intrinsics=PinholeIntrinsics.from_fov(2, 2, 47.0, 39.0),
        transform_camera_to_robot_believed=camera_true @ rigid(0.05),
        robot_pose_believed=robot_believed,
        transform_camera_to_world_true=world_true,
        robot_pose_true=robot_true,
    )


@pytest.mark.parametrize("count", [0, 1, 2, 5, 300])
def test_pose_error_accumulator_gives_the_per_frame_errors_bit_for_bit(count: int) -> None:
    from fogsim.eval.pose_error import PoseErrorAccumulator, heading_error_deg
    from mapper.transforms import planar_pose_to_matrix

    rng = np.random.default_rng(100 + count)
    accumulator = PoseErrorAccumulator()
    rows, residuals, world = [], [], []
    for index in range(count):
        frame = _random_pose_frame(rng, index)
        corrected = None
        if rng.random() < 0.7:
            corrected = frame.transform_camera_to_robot_believed @ _yaw(rng.normal(scale=0.05))
        accumulator.add(frame, corrected)
        row, residual = _old_frame_errors(frame, corrected)
        if row is not None:
            rows.append(row)
            if residual is not None:
                residuals.append(residual)
                in_world = planar_pose_to_matrix(frame.robot_pose_believed) @ corrected
                world.append(
                    abs(
                        heading_error_deg(
                            in_world[:3, :3], frame.transform_camera_to_world_true[:3, :3]
                        )
                    )
                )
    errors = accumulator.per_frame()
    known = np.isfinite(errors.camera_rotation_deg)
    got_rows = np.column_stack(
        [
            errors.camera_rotation_deg[known],
            errors.camera_translation_mm[known],
            errors.world_rotation_deg[known],
            errors.world_translation_mm[known],
        ]
    )
    processed = np.isfinite(errors.residual_heading_deg)
    got_residuals = np.abs(errors.residual_heading_deg[processed])
    got_mapped = np.abs(errors.map_heading_deg[processed])
    got_world = np.abs(errors.world_heading_deg[processed])
    np.testing.assert_allclose(got_world, np.array(world).reshape(-1), rtol=0, atol=1e-12)
    expected_rows = np.array(rows).reshape(-1, 4)
    assert got_rows.tobytes() == expected_rows.tobytes()
    assert got_residuals.tobytes() == np.array(residuals, dtype=np.float64).tobytes()
    assert got_mapped.tobytes() == got_residuals.tobytes()  # no frame mapped again


def _yaw(angle_rad: float) -> np.ndarray:
    transform = np.eye(4)
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    transform[:2, :2] = [[c, -s], [s, c]]
    return transform


class _OldKeyframes(HeadingEstimator):
    """The estimator with ``_add_keyframe`` as it was at c2da7ee (``observe`` as at 30a3fc2)."""

    def observe(
        self, points_robot, floor_heights_m, transform_camera_to_robot, robot_pose, z_shift_m=0.0
    ):
        """The method at 30a3fc2 (each keyframe set tested and its band made on its own)."""
        transform = np.asarray(transform_camera_to_robot, dtype=np.float64)
        if not self.params.correct_heading:
            return
        frame = (points_robot, floor_heights_m, transform, robot_pose, z_shift_m)
        for edges in (False, True) if self.params.edge_score else (False,):
            if (
                self._add_keyframe(*frame, edges=edges)
                and self._added[edges] % self.params.estimate_every == 0
            ):
                self._estimate(edges)

    def _add_keyframe(self, points_robot, floor_heights_m, transform, pose, z_shift_m, edges):
        """The method at c2da7ee (before its fast road): the known answer."""
        p = self.params
        c, s = math.cos(pose[3]), math.sin(pose[3])
        rotation = np.array([[c, -s], [s, c]])
        camera_xy = rotation @ transform[:2, 3] + pose[:2]
        axis = rotation @ transform[:2, 2]  # optical axis, horizontal part
        sector = math.floor(math.degrees(math.atan2(axis[1], axis[0])) / p.keyframe_sector_deg)
        cell = np.floor(camera_xy / p.keyframe_spacing_m).astype(np.int64)
        key = (int(cell[0]), int(cell[1]), sector)
        keyframes = self._edge_keyframes if edges else self._keyframes
        if any(k.key == key for k in keyframes):
            return False
        offsets = points_robot[:, :2] - transform[:2, 3]
        z_robot = points_robot[:, 2] + z_shift_m
        range_m = np.hypot(offsets[:, 0], offsets[:, 1])
        # A floor point's height is its floor's (a plane's: depth noise leaves no ground
        # point above `min_height_m` to draw an edge where the noise reaches it).
        height_m = np.where(np.isnan(floor_heights_m), points_robot[:, 2], floor_heights_m)
        height_m = height_m + z_shift_m
        band = (height_m >= p.min_height_m) & (height_m <= p.max_height_m)
        structure = band & (range_m <= p.max_range_m)
        gradients = None
        if edges:
            # The occupancy reaches two cells beyond the range: the range's end is no edge.
            candidates = np.flatnonzero(band & (range_m <= p.max_range_m + 2.0 * p.cell_m))
            gradients = _old_edge_gradients(points_robot[candidates], p.cell_m)
            edge = (
                np.any(gradients != 0.0, axis=1)
                & structure[candidates]
                & _heading.inside_image(points_robot, transform, p.edge_margin_m)[candidates]
            )
            index, gradients = candidates[edge], gradients[edge]
        else:
            index = np.flatnonzero(structure & np.isnan(floor_heights_m))
        if index.size < p.min_points:
            return False
        step = -(-index.size // p.max_points_per_keyframe)
        index = index[::step]
        if gradients is not None:
            gradients = np.ascontiguousarray(gradients[::step])
        keyframes.append(
            _heading._Keyframe(
                key=key,
                offsets_xy=np.ascontiguousarray(offsets[index]),
                z_world=z_robot[index] + pose[2],
                camera_xy=camera_xy,
                yaw_rad=float(pose[3]),
                gradients_xy=gradients,
            )
        )
        del keyframes[: -p.max_keyframes]
        self._added[edges] += 1
        return True


def _old_edge_gradients(points_robot: np.ndarray, cell_m: float, reach: int = 2) -> np.ndarray:
    """``edge_gradients`` at 30a3fc2 (every side looked up among the sorted occupied keys)."""
    if points_robot.shape[0] == 0:
        return np.zeros((0, 2))
    ij = np.floor(points_robot[:, :2] / cell_m).astype(np.int64)
    ij -= ij.min(axis=0) - reach  # every neighbour index >= 0
    width = int(ij[:, 1].max()) + reach + 1
    occupied = np.unique(ij[:, 0] * width + ij[:, 1])

    def has(di: int, dj: int) -> np.ndarray:
        keys = (ij[:, 0] + di) * width + ij[:, 1] + dj
        at = np.minimum(np.searchsorted(occupied, keys), occupied.size - 1)
        return occupied[at] == keys

    def side(di: int, dj: int) -> np.ndarray:
        return (has(di, dj) | has(reach * di, reach * dj)).astype(np.float64)

    return np.column_stack([side(1, 0) - side(-1, 0), side(0, 1) - side(0, -1)])


@pytest.mark.parametrize("spread_m", [0.05, 1.0, 4.0, 200.0])
@pytest.mark.parametrize("reach", [1, 2, 3])
def test_edge_gradients_are_the_old_sorted_search_bit_for_bit(spread_m: float, reach: int) -> None:
    # 200 m in 3 cm squares spans more than the dense table holds: the sorted search's road.
    rng = np.random.default_rng(round(spread_m * 10) + reach)
    for count in (1, 2, 50, 3000):
        points = rng.uniform(-spread_m, spread_m, (count, 3)) + rng.uniform(-50, 50, 3)
        points[: count // 3, 1] = points[0, 1]  # a line: ends and sides
        for cell_m in (0.03, 0.1):
            got = _heading.edge_gradients(points, cell_m, reach)
            expected = _old_edge_gradients(points, cell_m, reach)
            assert got.shape == expected.shape and got.dtype == expected.dtype
            assert got.tobytes() == expected.tobytes()
    empty = np.zeros((0, 3))
    assert (
        _heading.edge_gradients(empty, 0.03).tobytes() == _old_edge_gradients(empty, 0.03).tobytes()
    )


def test_edge_gradients_of_points_not_finite_are_the_old_answer() -> None:
    # NaN and infinite points wrap the square indices around: the sorted search's road, as old.
    rng = np.random.default_rng(5)
    points = rng.uniform(-1.0, 1.0, (200, 3))
    for bad in (np.nan, np.inf, -np.inf):
        with np.errstate(invalid="ignore"):
            for rows in (slice(0, 1), slice(0, 200, 7), slice(None)):
                spoiled = points.copy()
                spoiled[rows, 0] = bad
                got = _heading.edge_gradients(spoiled, 0.03)
                expected = _old_edge_gradients(spoiled, 0.03)
                assert got.tobytes() == expected.tobytes()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_keyframes_are_the_old_keyframes_bit_for_bit(seed: int) -> None:
    from test_heading import WALK, box_points_world, floor_points_world
    from test_heading import frame as heading_frame

    rng = np.random.default_rng(seed)
    boxes = box_points_world(rng)
    # No estimate refined point to plane: the old keyframes have no normals, and what is
    # compared is the keyframes (and the estimates the score makes of them).
    for params in (
        HeadingParams(estimate_every=1, plane_refine_estimates=0),
        HeadingParams(
            estimate_every=2, min_points=300, max_points_per_keyframe=300, plane_refine_estimates=0
        ),
        HeadingParams(
            edge_score=False, max_keyframes=2, keyframe_sector_deg=10.0, plane_refine_estimates=0
        ),
    ):
        new, old = HeadingEstimator(params), _OldKeyframes(params)
        for step in range(12):
            x, y, yaw = WALK[step % len(WALK)]
            yaw += rng.normal(scale=0.4)  # new sectors, and back to old ones
            points, heights, camera, pose = heading_frame(
                boxes, floor_points_world(x), (x, y + rng.normal(scale=0.1), yaw), 3.0
            )
            points = points + rng.normal(scale=0.004, size=points.shape)
            if step % 4 == 3:  # NaN points (none inside the view's border then: no edges)
                points[rng.random(len(points)) < 0.02] = np.nan
            shift = float(rng.normal(scale=0.03)) if step % 3 else 0.0
            for estimator in (new, old):
                estimator.observe(points, heights, camera, pose, z_shift_m=shift)
        assert new.keyframes > 0 and (new._added[1] > 0 or not params.edge_score)
        assert new._added == old._added
        assert (new.estimates, new.edge_estimates) == (old.estimates, old.edge_estimates)
        assert new.correction_rad == old.correction_rad
        pairs = zip(
            new._keyframes + new._edge_keyframes, old._keyframes + old._edge_keyframes, strict=True
        )
        for a, b in pairs:
            assert a.key == b.key and a.yaw_rad == b.yaw_rad
            for name in ("offsets_xy", "z_world", "camera_xy", "gradients_xy"):
                got, expected = getattr(a, name), getattr(b, name)
                if expected is None:
                    assert got is None
                    continue
                assert got.shape == expected.shape and got.dtype == expected.dtype
                assert got.flags.c_contiguous == expected.flags.c_contiguous
                assert got.tobytes() == expected.tobytes(), name


def _checks_find_nothing(pose, camera, previous) -> bool:
    from fogsim.data.checks import pose_problem, step_problem, transform_problem
    from fogsim.data.limits import MAX_CAMERA_OFFSET_M

    poses = pose[None] if previous is None else np.stack([previous, pose])
    return (
        pose_problem(pose[None]) is None
        and transform_problem(camera[None], max_translation_m=MAX_CAMERA_OFFSET_M) is None
        and step_problem(poses) is None
    )


def test_surely_plausible_frames_pass_every_check_and_real_ones_are_sure() -> None:
    from scipy.spatial.transform import Rotation

    from fogsim.data.checks import surely_plausible
    from fogsim.data.limits import MAX_CAMERA_OFFSET_M

    rng = np.random.default_rng(21)
    sure = 0
    for trial in range(3000):
        pose = np.array([*rng.normal(scale=3.0, size=3), rng.normal(scale=3.0)])
        camera = np.eye(4)
        camera[:3, :3] = Rotation.random(random_state=trial).as_matrix()
        camera[:3, 3] = rng.normal(scale=0.5, size=3)
        previous = None if trial % 5 == 0 else pose + np.append(rng.normal(scale=0.03, size=3), 0)
        kind = trial % 12
        scale = 10.0 ** rng.uniform(-2, 1)
        if kind == 1:  # far off, around each limit
            pose[rng.integers(0, 4)] = rng.choice([1, -1]) * 1e4 * (1 + rng.normal(scale=0.1))
        elif kind == 2:  # a long step
            previous = pose - np.append(rng.normal(size=3) * 5.0 * scale, 0.0)
        elif kind == 3:  # a rotation block off orthonormality
            camera[:3, :3] += rng.normal(scale=1e-6 * scale, size=(3, 3))
        elif kind == 4:  # a reflection
            camera[:3, 0] = -camera[:3, 0]
        elif kind == 5:  # a far camera
            camera[:3, 3] = rng.normal(size=3) * MAX_CAMERA_OFFSET_M * scale / 2
        elif kind == 6:  # a last row off
            camera[3, rng.integers(0, 4)] += rng.choice([1e-13, 1e-11, 1e-3])
        elif kind == 7:  # not finite
            where = rng.integers(0, 4)
            (pose if trial % 2 else camera[where])[where] = rng.choice([np.nan, np.inf, -np.inf])
        elif kind == 8 and previous is not None:
            previous[rng.integers(0, 3)] = np.nan
        fast = surely_plausible(pose, camera, previous, max_translation_m=MAX_CAMERA_OFFSET_M)
        if fast:
            assert _checks_find_nothing(pose, camera, previous), trial
        sure += fast
        if kind in (0, 9, 10, 11):  # an ordinary frame is always sure
            assert fast, trial
    assert 1000 < sure < 2800


def test_raised_points_are_the_broadcast_sum_bit_for_bit() -> None:
    from fogsim.mapping.pipeline import _raised

    rng = np.random.default_rng(31)
    for count in (0, 1, 2, 3, 6336):
        points = rng.normal(size=(count, 3))
        points[rng.random(count) < 0.1] = np.nan
        if count:
            points[0] = [-0.0, -0.0, -0.0]
        for shift in (0.0, -0.0, 0.0123, -1e-3):
            expected = points + np.array([0.0, 0.0, shift])
            assert _raised(points, shift).tobytes() == expected.tobytes()


def test_floor_at_reads_the_cell_of_cell_of() -> None:
    from mapper import FloorObstacleMapper, MapperParams

    rng = np.random.default_rng(41)
    mapper = FloorObstacleMapper(MapperParams())
    mapper.recenter(1.37, -0.52)
    mapper._floor[...] = rng.normal(size=mapper._floor.shape)
    mapper._floor[rng.random(mapper._floor.shape) < 0.2] = np.nan
    g = mapper.geometry
    ox, oy = g.origin_xy_m
    xs = ox + rng.uniform(-0.2, 1.2, 3000) * g.nx * g.cell_m
    ys = oy + rng.uniform(-0.2, 1.2, 3000) * g.ny * g.cell_m
    xs[::7] = ox + rng.integers(-2, g.nx + 2, xs[::7].size) * g.cell_m  # on cell faces
    ys[::11] = oy + g.ny * g.cell_m  # the far face: off the grid
    xs[::13], ys[::17], xs[::19] = np.nan, np.inf, -1e300
    for x, y in zip(xs.tolist(), ys.tolist(), strict=True):
        index, valid = _old_cell_of(g, np.array([[x, y]]))
        expected = float(mapper._floor[index[0, 0], index[0, 1]]) if valid[0] else np.nan
        got = mapper.floor_at(x, y)
        assert np.array_equal(got, expected, equal_nan=True), (x, y)
        assert mapper.floor_at(np.float64(x), np.float64(y)) is not None


def test_floor_at_refuses_what_is_not_a_real_number() -> None:
    from mapper import FloorObstacleMapper, MapperParams
    from mapper.errors import InvalidInputError

    mapper = FloorObstacleMapper(MapperParams())
    with pytest.raises(InvalidInputError, match="x_m must hold real numbers"):
        mapper.floor_at(1j, 0.0)
    with pytest.raises(InvalidInputError, match="y_m must hold real numbers"):
        mapper.floor_at(0.0, "0.5")


def test_cells_in_view_of_points_made_ahead_are_the_cells_made_in_line() -> None:
    # A run makes a frame's world points on its segmentation thread (`view_points_world`).
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(11)
    intrinsics = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
    geometry = GridGeometry(
        nx=100, ny=100, nz=40, cell_m=0.04, layer_m=0.04, z_min_m=-0.2, origin_ix=-50, origin_iy=-50
    )
    seeing = 0
    for trial in range(10):
        pose = np.eye(4)
        pose[:3, :3] = Rotation.random(random_state=100 + trial).as_matrix()
        pose[:3, 3] = rng.uniform([-2.0, -2.0, 0.2], [2.0, 2.0, 1.2])
        depth = rng.uniform(0.1, 5.0, intrinsics.shape).astype(np.float32)
        depth[rng.random(depth.shape) < 0.1] = np.nan
        frame = Frame(trial, 0.0, depth, intrinsics, pose, np.zeros(4), pose, np.zeros(4))
        got = cells_in_view(frame, geometry, view_points_world(frame))
        assert got.tobytes() == cells_in_view(frame, geometry).tobytes()
        assert got.tobytes() == _old_cells_in_view(frame, geometry).tobytes()
        seeing += bool(got.any())
    assert seeing >= 5


class _OldReference(HeightReference):
    """``HeightReference.update`` as it was at 30a3fc2 (the lowest level re-made every frame).

    With today's `_settle` (the precision asked before the waiting frames are mapped) on its
    lowest level: what is compared is the incremental median, not that rule.
    """

    old_lowest_m = np.empty(0)

    def update(self, heights_m, areas_m2, is_floor, rise_m):
        self.frames += 1
        params = self.params
        expected = self.shift_m if self.converged else 0.0
        offset = np.abs(-heights_m - expected)
        candidate = is_floor & (areas_m2 >= params.min_area_m2) & (offset <= params.gate_m)
        if not self.converged and abs(rise_m) <= params.start_level_m:
            candidate |= (
                is_floor & (areas_m2 >= params.start_min_area_m2) & (offset <= params.start_gate_m)
            )
        if not candidate.any():
            return None
        largest = int(np.argmax(np.where(candidate, areas_m2, -np.inf)))
        measured = -float(heights_m[largest])
        self.measurements_m.append(measured)
        self.rises_m.append(rise_m)
        rises = np.asarray(self.rises_m)
        self.old_lowest_m = np.asarray(self.measurements_m)[
            rises <= rises.min() + params.start_level_m
        ]
        self._shift_m = float(np.median(self.old_lowest_m))
        self._lowest_rise_m = float(rises.min())
        self._lowest_sorted_m = sorted(self.old_lowest_m.tolist())
        self._settle()
        return measured

    @property
    def converged(self) -> bool:
        return self.old_lowest_m.size >= self.params.min_frames


@pytest.mark.filterwarnings("ignore:Mean of empty slice", "ignore:invalid value encountered")
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_height_reference_is_the_old_one_frame_by_frame(seed: int) -> None:
    # Walks up, down (new lowest levels), level; odd rises (NaN, inf) in the last seed (a NaN
    # rise leaves no lowest level: the median of nothing, NaN, with numpy's warnings, as old).
    rng = np.random.default_rng(seed)
    # The tread rule (session 44) and the start rule (session 45) are not the old reference's,
    # and not what this compares: the medians kept in order against numpy's over the history
    # (tests/test_reference.py has them).
    params = HeightReferenceParams(tread_min_area_m2=0.0, start_known_error_m=math.inf)
    new, old = HeightReference(params), _OldReference(params)
    rise = 0.0
    zeros = 0
    for frame in range(400):
        if seed != 5:  # seed 5: on level ground, the lowest level all the way
            rise += float(rng.choice([0.0] * 12 + [0.004, -0.004, 0.03, -0.03]))
        if seed == 4 and frame in (150, 250):
            rise_m = [np.inf, np.nan][frame == 250]
        else:
            rise_m = rise + float(rng.normal(scale=0.001))
        count = int(rng.integers(0, 5))
        heights = rng.normal(scale=0.01, size=count) - rng.choice([0.0, 0.03], size=count)
        if seed == 3 and frame >= 200:  # ties, and zeros of both signs
            heights = np.round(heights, 3) * rng.choice([1.0, 1.0, 0.0, -0.0], size=count)
        areas = rng.uniform(0.0, 3.0, count)
        floor = rng.random(count) < 0.8
        got = new.update(heights, areas, floor, rise_m)
        expected = old.update(heights, areas, floor, rise_m)
        assert got == expected or (got != got and expected != expected)
        assert np.float64(new.shift_m).tobytes() == np.float64(old.shift_m).tobytes()
        assert new._lowest_sorted_m == sorted(old.old_lowest_m.tolist())
        zeros += new.shift_m == 0.0
        assert (new.converged, new.known) == (old.converged, old.known)
    assert len(new.measurements_m) > 100
    assert zeros > 0 or seed != 3
