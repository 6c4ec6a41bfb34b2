"""Robot elevation filter (paper Sec. IV, DESIGN item 8): ``z_R`` filtered with the floor map.

Odometry from foot-to-foot kinematics accumulates errors in the robot's elevation ``z_R``. The
robot stands on the floor, so the floor height at its position, ``Floor(x_R, y_R)``, is a
measurement of ``z_R``. The filter keeps an offset added to odometry's ``z`` and pulls it towards
the floor height with gain ``gain`` whenever that height is valid and within ``gate_m`` of the
current estimate (a larger difference means the cell under the robot holds another level, e.g.
the next stair, and is ignored).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mapper.validation import check_field, real_scalar


@dataclass(frozen=True)
class ElevationFilterParams:
    """Gain in (0, 1] of each correction and the gate [m] on the floor–estimate difference."""

    gain: float = 0.3
    gate_m: float = 0.025

    def __post_init__(self) -> None:
        check_field(
            "ElevationFilterParams", "gain", self.gain, float, "in (0, 1]", lambda v: 0 < v <= 1
        )
        check_field(
            "ElevationFilterParams",
            "gate_m",
            self.gate_m,
            float,
            "a finite float > 0 [m]",
            lambda v: math.isfinite(v) and v > 0,
        )


class RobotElevationFilter:
    """Filters odometry's robot elevation with the floor height under the robot."""

    def __init__(self, params: ElevationFilterParams | None = None) -> None:
        self.params = params if params is not None else ElevationFilterParams()
        self.offset_m = 0.0

    def update(self, z_odometry_m: float, floor_at_robot_m: float) -> float:
        """Filtered elevation [m] for odometry's ``z`` and ``Floor(x_R, y_R)`` (NaN = none).

        Raises:
            InvalidInputError: either argument is not one real number (e.g. complex).
        """
        real_scalar(z_odometry_m, "z_odometry_m")
        real_scalar(floor_at_robot_m, "floor_at_robot_m")
        estimate = z_odometry_m + self.offset_m
        if math.isfinite(floor_at_robot_m):
            error = floor_at_robot_m - estimate
            if abs(error) <= self.params.gate_m:
                self.offset_m += self.params.gain * error
        return z_odometry_m + self.offset_m
