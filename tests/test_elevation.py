"""Robot elevation filter (DESIGN item 8)."""

import math

import pytest

from mapper import ElevationFilterParams, RobotElevationFilter


def test_drift_is_pulled_to_the_floor_geometrically():
    f = RobotElevationFilter(ElevationFilterParams(gain=0.5, gate_m=0.05))
    # odometry reads 20 mm too high, the floor under the robot is at 0.061 m
    estimates = [f.update(0.081, 0.061) for _ in range(5)]
    errors = [e - 0.061 for e in estimates]
    assert errors == pytest.approx([0.02 * 0.5**k for k in range(1, 6)])


def test_invalid_floor_or_other_level_is_ignored():
    f = RobotElevationFilter(ElevationFilterParams(gain=0.5, gate_m=0.025))
    assert f.update(0.10, math.nan) == 0.10
    assert f.update(0.10, 0.031) == 0.10  # 69 mm away: another stair step, gated out
    assert f.offset_m == 0.0


@pytest.mark.parametrize(("gain", "gate"), [(0.0, 0.02), (1.5, 0.02), (0.5, 0.0)])
def test_bad_params(gain, gate):
    with pytest.raises(ValueError, match="ElevationFilterParams"):
        ElevationFilterParams(gain=gain, gate_m=gate)
