"""Bad input to the mapper library: named errors, bounded resources, the map left as it was.

Every parameter field is type-checked (strings, bools where numbers belong, NaN/inf), cell sizes
and grid sizes are bounded by `mapper.limits`, coordinates too (``recenter(1e300)`` used to
scroll every cell out of the map), intrinsics with NaN/inf are refused, a reflection is no rigid
transform, and complex arrays are refused instead of losing their imaginary part.
"""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from synthetic_depth import look_down_camera

from mapper import (
    AveragingMap,
    ElevationFilterParams,
    FloorObstacleMapper,
    InvalidInputError,
    InvalidParameterError,
    MapperParams,
    PinholeIntrinsics,
    RobotElevationFilter,
    SegmentationParams,
    apply_z_shift,
    segment_depth,
)
from mapper.limits import (
    MAX_CELL_M,
    MAX_CELLS,
    MAX_COLUMNS,
    MAX_COORDINATE_M,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_SIDE_PX,
    MAX_SEGMENTATION_PASSES,
    MAX_WINDOW_PX,
    MIN_CELL_M,
    RIGID_TOLERANCE,
)
from mapper.synthetic import Box, camera_rays_world, cast_frame
from mapper.transforms import apply_transform, planar_pose_to_matrix, rotation_angle_deg

PARAM_CLASSES = (MapperParams, SegmentationParams, ElevationFilterParams)
INTR = PinholeIntrinsics.from_fov(88, 72, 47.0, 39.0)
CAMERA = look_down_camera((0.0, 0.0, 0.9), pitch_down_deg=30.0)
RAYS = camera_rays_world(INTR, yaw_deg=0.0, pitch_down_deg=30.0)
SENSOR = np.array([0.0, 0.0, 0.55])


def all_fields():
    return [(cls, f.name, f.default) for cls in PARAM_CLASSES for f in dataclasses.fields(cls)]


def field_id(case):
    return f"{case[0].__name__}.{case[1]}" if isinstance(case, tuple) else str(case)


BOX = Box((1.2, 0.0), (0.3, 0.3, 0.07))


def a_frame(seed=1):
    return cast_frame(SENSOR, RAYS, [BOX], noise_z_m=0.005, rng=np.random.default_rng(seed))


def maps(m):
    return (m.occupancy_levels(), m.floor(), *m.fog())


def same_maps(a, b):
    return all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b, strict=True))


# ----------------------------------------------------------------------------- parameter types


@pytest.mark.parametrize("case", all_fields(), ids=field_id)
def test_a_string_for_any_field_names_the_field_the_value_and_what_is_allowed(case):
    cls, name, _ = case
    with pytest.raises(InvalidParameterError) as info:
        cls(**{name: "0.04"})
    message = str(info.value)
    assert f"{cls.__name__}.{name} must be" in message
    assert "'0.04'" in message and "of type str" in message and "allowed:" in message


@pytest.mark.parametrize(
    "case", [c for c in all_fields() if not isinstance(c[2], bool)], ids=field_id
)
def test_a_bool_where_a_number_belongs_is_refused(case):
    cls, name, _ = case
    with pytest.raises(InvalidParameterError, match=rf"{cls.__name__}\.{name} must be .*bool"):
        cls(**{name: True})


@pytest.mark.parametrize("case", [c for c in all_fields() if type(c[2]) is float], ids=field_id)
def test_nan_and_inf_in_float_fields_are_refused(case):
    cls, name, _ = case
    with pytest.raises(InvalidParameterError, match=rf"{cls.__name__}\.{name} must be"):
        cls(**{name: math.nan})
    if name == "max_range_m":  # inf means "no limit", documented
        assert cls(**{name: math.inf}).max_range_m == math.inf
    else:
        with pytest.raises(InvalidParameterError, match=rf"{cls.__name__}\.{name} must be"):
            cls(**{name: math.inf})


def test_integer_fields_take_numpy_integers_and_float_fields_integers():
    p = MapperParams(nx=np.int64(50), cell_m=1, p_occ=np.float32(0.7))
    assert (p.nx, p.cell_m) == (50, 1)
    assert SegmentationParams(fill_passes=np.int32(3)).fill_passes == 3
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.nx must be an integer"):
        MapperParams(nx=50.0)  # with_overrides / from_mapping convert integral floats
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.clear_outside must be a bool"):
        MapperParams(clear_outside=np.True_)


def test_with_overrides_converts_numbers_only():
    assert MapperParams().with_overrides(nx=50.0).nx == 50
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.nx .*'50'"):
        MapperParams().with_overrides(nx="50")  # float("50") would have made it 50
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.clear_outside"):
        MapperParams().with_overrides(clear_outside="1")


ODD_VALUES = st.one_of(
    st.text(max_size=5),
    st.booleans(),
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.complex_numbers(),
    st.lists(st.floats(-1, 1), max_size=2),
)


@settings(derandomize=True, max_examples=300, deadline=None)
@given(case=st.sampled_from(all_fields()), value=ODD_VALUES)
def test_any_value_for_any_field_is_accepted_or_refused_by_name(case, value):
    cls, name, _ = case
    try:
        params = cls(**{name: value})
    except InvalidParameterError as exc:
        assert f"{cls.__name__}.{name}" in str(exc) or f"{cls.__name__}." in str(exc)
    else:
        assert getattr(params, name) == value


# ----------------------------------------------------------------------------- resource bounds


@pytest.mark.parametrize("cell_m", [1e-9, MIN_CELL_M * 0.999, MAX_CELL_M * 1.001, 1e9])
def test_absurd_cell_sizes_are_refused_with_the_limits(cell_m):
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.cell_m .*\[0\.001, 1\.0\]"):
        MapperParams(cell_m=cell_m)
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.layer_m"):
        MapperParams(layer_m=cell_m)


def test_cell_size_limits_themselves_are_allowed():
    assert MapperParams(cell_m=MIN_CELL_M, layer_m=MAX_CELL_M).cell_m == MIN_CELL_M


def test_grid_size_is_bounded_by_columns_and_cells():
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.nx\*ny must be at most"):
        MapperParams(nx=20000, ny=20000)
    side = math.isqrt(MAX_COLUMNS)
    assert MapperParams(nx=side, ny=side).nx == side  # parameters only: nothing allocated
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.nx\*ny\*nz must be"):
        MapperParams(nx=side, ny=side, nz=MAX_CELLS // MAX_COLUMNS + 1)
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.nx\*ny must be .*got 10"):
        MapperParams(nx=10**400)  # the message stays short


@pytest.mark.parametrize("name", ["fill_passes", "break_passes", "reassign_passes"])
def test_segmentation_passes_are_bounded(name):
    assert getattr(SegmentationParams(**{name: MAX_SEGMENTATION_PASSES}), name) == 64
    with pytest.raises(InvalidParameterError, match=rf"{name} must be an integer in \[0, 64\]"):
        SegmentationParams(**{name: MAX_SEGMENTATION_PASSES + 1})


@pytest.mark.parametrize("name", ["noise_window_px", "edge_window_px", "break_reach_px"])
def test_segmentation_windows_are_bounded(name):
    assert getattr(SegmentationParams(**{name: MAX_WINDOW_PX}), name) == MAX_WINDOW_PX
    with pytest.raises(InvalidParameterError, match=rf"SegmentationParams\.{name}"):
        SegmentationParams(**{name: MAX_WINDOW_PX + 1})


def test_coordinate_fields_are_bounded():
    with pytest.raises(InvalidParameterError, match=r"MapperParams\.z_min_m .*finite"):
        MapperParams(z_min_m=2 * MAX_COORDINATE_M)
    with pytest.raises(InvalidParameterError, match=r"SegmentationParams\.expected_ground_z_m"):
        SegmentationParams(expected_ground_z_m=1e300)


# ----------------------------------------------------------------------------- coordinates


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e300, -1e300, 1 + 2j, "1"])
@pytest.mark.parametrize("map_class", [FloorObstacleMapper, AveragingMap])
def test_recenter_refuses_bad_coordinates_and_keeps_the_map(map_class, bad):
    m = map_class(MapperParams())
    m.update(*a_frame(), SENSOR)
    before = (m.geometry, m.fog())
    with pytest.raises(InvalidInputError, match=r"x_m must"):
        m.recenter(bad, 0.0)
    with pytest.raises(InvalidInputError, match=r"y_m must"):
        m.recenter(0.0, bad)
    assert m.geometry == before[0]
    assert same_maps(m.fog(), before[1])


def test_recenter_within_the_coordinate_limit_works_and_says_so():
    m = FloorObstacleMapper()
    shift = m.recenter(MAX_COORDINATE_M, -MAX_COORDINATE_M)
    assert shift == (round(MAX_COORDINATE_M / 0.04), -round(MAX_COORDINATE_M / 0.04))
    assert m.floor_at(MAX_COORDINATE_M, -MAX_COORDINATE_M) != 0.0  # NaN: nothing seen there
    with pytest.raises(InvalidInputError, match=r"MAX_COORDINATE_M"):
        m.recenter(MAX_COORDINATE_M * 1.01, 0.0)


@pytest.mark.parametrize("center", [(math.nan, 0.0), (0.0, 1e300), (0.0,), (1j, 0.0)])
def test_a_bad_centre_is_refused_at_construction(center):
    with pytest.raises(InvalidInputError, match="center_xy_m"):
        FloorObstacleMapper(center_xy_m=center)
    with pytest.raises(InvalidInputError, match="center_xy_m"):
        AveragingMap(center_xy_m=center)


def test_points_and_heights_beyond_the_limit_are_dropped_like_nonfinite_ones():
    points, heights = a_frame()
    far = points.copy()
    far[::7] = (1e300, 0.0, 0.0)
    heights_far = heights.copy()
    heights_far[1::7] = 1e300
    reference = points.copy()
    reference[::7] = np.nan
    heights_ref = heights.copy()
    heights_ref[1::7] = np.nan
    a, b = FloorObstacleMapper(), FloorObstacleMapper()
    ra = a.update(far, heights_far, SENSOR)
    rb = b.update(reference, heights_ref, SENSOR)
    assert ra == rb and ra.points_dropped_nonfinite >= len(points[::7])
    assert same_maps(maps(a), maps(b))
    assert far[0, 0] == 1e300 and heights_far[1] == 1e300  # the caller's arrays are untouched
    with pytest.raises(InvalidInputError, match="sensor_origin must be finite and within"):
        a.update(points, heights, (0.0, 0.0, 2 * MAX_COORDINATE_M))


# ----------------------------------------------------------------------------- intrinsics


@pytest.mark.parametrize("name", ["fx", "fy", "cx", "cy"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, "1", True])
def test_intrinsics_with_nan_inf_or_non_numbers_are_refused(name, bad):
    good = dict(width=88, height=72, fx=100.0, fy=100.0, cx=43.5, cy=35.5)
    with pytest.raises(InvalidParameterError, match=rf"PinholeIntrinsics\.{name} must be"):
        PinholeIntrinsics(**{**good, name: bad})


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"fx": 0.0}, r"fx must be a finite float > 0"),
        ({"fy": -100.0}, r"fy must be a finite float > 0"),
        ({"width": 0}, r"width must be an integer in \[1, 16384\]"),
        ({"height": 2.5}, r"height must be an integer"),
        ({"width": True}, r"width must be an integer"),
        ({"width": MAX_IMAGE_SIDE_PX + 1}, r"MAX_IMAGE_SIDE_PX"),
        ({"width": MAX_IMAGE_SIDE_PX, "height": MAX_IMAGE_SIDE_PX}, r"MAX_IMAGE_PIXELS"),
    ],
)
def test_intrinsics_sizes_and_focal_lengths_are_bounded(changes, message):
    good = dict(width=88, height=72, fx=100.0, fy=100.0, cx=43.5, cy=35.5)
    with pytest.raises(InvalidParameterError, match=message):
        PinholeIntrinsics(**{**good, **changes})


def test_largest_allowed_image_and_fov_checks():
    side = math.isqrt(MAX_IMAGE_PIXELS)
    assert PinholeIntrinsics(side, side, 1.0, 1.0, 0.0, 0.0).shape == (side, side)
    with pytest.raises(InvalidParameterError, match=r"hfov_deg must be .*in \(0, 180\) degrees"):
        PinholeIntrinsics.from_fov(88, 72, math.nan, 39.0)
    with pytest.raises(InvalidParameterError, match=r"vfov_deg must be in \(0, 180\) degrees"):
        PinholeIntrinsics.from_fov(88, 72, 47.0, 180.0)


# ----------------------------------------------------------------------------- rigid transforms


def test_a_reflection_is_not_a_rigid_transform():
    mirrored = CAMERA.copy()
    mirrored[:3, 0] *= -1.0  # orthonormal, det -1
    assert np.abs(mirrored[:3, :3] @ mirrored[:3, :3].T - np.eye(3)).max() < 1e-12
    with pytest.raises(InvalidInputError, match=r"det R = -1"):
        segment_depth(np.ones(INTR.shape), INTR, mirrored)


def test_rotation_tolerance_refuses_a_scale_and_accepts_float32_rounding():
    scaled = CAMERA.copy()
    scaled[:3, :3] *= 1.0 + 10 * RIGID_TOLERANCE
    with pytest.raises(InvalidInputError, match=r"rigid transform .*within 1e-06"):
        segment_depth(np.ones(INTR.shape), INTR, scaled)
    depth = np.full(INTR.shape, 2.0)
    result = segment_depth(depth, INTR, CAMERA.astype(np.float32))  # recordings may store f32
    assert result.points.shape == (depth.size, 3)


# ----------------------------------------------------------------------------- complex arrays


def test_complex_bool_and_string_arrays_are_refused_not_truncated():
    points, heights = a_frame()
    m = FloorObstacleMapper()
    with pytest.raises(InvalidInputError, match=r"points must hold real numbers .*complex"):
        m.update(points + 1j, heights, SENSOR)
    with pytest.raises(InvalidInputError, match=r"floor_heights must hold real numbers"):
        m.update(points, heights + 0j, SENSOR)
    with pytest.raises(InvalidInputError, match=r"sensor_origin must hold real numbers"):
        m.update(points, heights, SENSOR + 1j)
    with pytest.raises(InvalidInputError, match=r"points must hold real numbers .*bool"):
        m.update(np.ones((3, 3), dtype=bool), np.zeros(3), SENSOR)
    with pytest.raises(InvalidInputError, match=r"points must hold real numbers .*object"):
        m.update([[0.0, 0.0, None]], [0.0], SENSOR)
    with pytest.raises(InvalidInputError, match=r"points_world must hold real numbers"):
        m.cell_of(np.zeros((2, 3), dtype=complex))
    with pytest.raises(InvalidInputError, match=r"points must hold real numbers"):
        m.match_z(points + 1j, heights)
    with pytest.raises(InvalidInputError, match=r"points must hold real numbers"):
        AveragingMap().update(points + 1j, heights, SENSOR)
    assert same_maps(maps(m), maps(FloorObstacleMapper()))  # nothing was inserted


def test_complex_images_transforms_and_scalars_are_refused():
    with pytest.raises(InvalidInputError, match=r"depth_m must hold real numbers"):
        segment_depth(np.ones(INTR.shape) + 0j, INTR, CAMERA)
    with pytest.raises(InvalidInputError, match=r"transform_camera_to_robot must hold real"):
        segment_depth(np.ones(INTR.shape), INTR, CAMERA + 0j)
    with pytest.raises(InvalidInputError, match=r"depth_m must hold real numbers"):
        INTR.depth_to_points_camera(np.ones(INTR.shape) + 1j)
    with pytest.raises(InvalidInputError, match=r"pose must hold real numbers"):
        planar_pose_to_matrix([0.0, 0.0, 0.0, 1j])
    with pytest.raises(InvalidInputError, match=r"points must hold real numbers"):
        apply_transform(np.eye(4), np.zeros((2, 3)) + 1j)
    with pytest.raises(InvalidInputError, match=r"rotation must hold real numbers"):
        rotation_angle_deg(np.eye(3) + 0j)
    with pytest.raises(InvalidInputError, match=r"shift_m must hold real numbers"):
        apply_z_shift(np.zeros((2, 3)), np.zeros(2), 1j)
    elevation = RobotElevationFilter()
    with pytest.raises(InvalidInputError, match=r"z_odometry_m must hold real numbers"):
        elevation.update(1j, 0.0)
    with pytest.raises(InvalidInputError, match=r"floor_at_robot_m must hold real numbers"):
        elevation.update(0.0, "0.1")
    assert elevation.offset_m == 0.0
