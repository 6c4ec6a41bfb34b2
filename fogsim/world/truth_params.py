"""Parameters of the ground truth: the robot's foot and the mapper grid's height.

The paper's definitions (DESIGN.md "Ground truth") need two numbers that do not come from the
scene: how big a foot is ("a surface with room for a foot") and how high the mapper's grid
reaches ("nothing above it within the grid's height"). The runner passes the robot's foot and the
mapper's grid top; the defaults are iCub's foot and the default grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fogsim.errors import ParameterError
from mapper.params import MapperParams

ICUB_FOOT_LENGTH_M = 0.156
"""iCub's footprint length [m]: ``assets/robots/icub.toml`` ``[feet] length_m = [-0.028, 0.128]``
(heel to toe along the sole's x) spans 0.156 m."""
ICUB_FOOT_WIDTH_M = 0.06
"""iCub's footprint width [m]: ``assets/robots/icub.toml`` ``[feet] half_width_m = 0.03``."""


@dataclass(frozen=True)
class TruthParams:
    """What the ground truth needs beyond the scene's geometry.

    Attributes:
        foot_length_m: Footprint length, heel to toe [m]. Default: iCub's, 0.156 m (the shipped
            scenarios' default robot; ``assets/robots/icub.toml`` ``[feet]``). A flat top has
            room for a foot when a ``foot_length_m`` × ``foot_width_m`` rectangle fits on it
            with its sides along the top's sides, either way round. A foot turned at an angle
            fits a rectangle only when it nearly fits straight (iCub's needs a 0.153 m square
            at 45°, a 0.156 m one straight: 3 mm, a tenth of a grid cell), so the straight test
            is the geometry to within a cell. A disc of the foot's width instead would call a
            0.07 m post a floor, which no foot stands on.
        foot_width_m: Footprint width [m], at most ``foot_length_m``. Default: iCub's, 0.06 m.
            A top narrower than this in its narrow direction never has room for a foot.
        grid_top_m: World z up to which things count [m]: a flat top above it is no floor (the
            mapper cannot hold it), an object whose bottom is at or above it is not there for
            the truth (the mapper never sees into that height). Default: the top face of the
            default mapper grid, ``MapperParams().z_max_m`` = -0.06 + 16 × 0.04 = 0.58 m.

    Raises:
        ParameterError: A foot size not in (0, 2] m, a width above the length, or a grid top
            that is not finite.
    """

    foot_length_m: float = ICUB_FOOT_LENGTH_M
    foot_width_m: float = ICUB_FOOT_WIDTH_M
    grid_top_m: float = MapperParams().z_max_m

    def __post_init__(self) -> None:
        for name in ("foot_length_m", "foot_width_m"):
            value = getattr(self, name)
            if not 0.0 < value <= 2.0:
                raise ParameterError(f"TruthParams.{name} must be in (0, 2] m, got {value!r}")
        if self.foot_width_m > self.foot_length_m:
            raise ParameterError(
                f"TruthParams.foot_width_m must be at most foot_length_m = {self.foot_length_m} m, "
                f"got {self.foot_width_m!r}"
            )
        if not math.isfinite(self.grid_top_m):
            raise ParameterError(f"TruthParams.grid_top_m must be finite, got {self.grid_top_m!r}")

    def has_room_for_foot(self, size_x_m: float, size_y_m: float) -> bool:
        """Whether a ``size_x_m`` × ``size_y_m`` top holds the foot, straight, either way round."""
        long_m, short_m = max(size_x_m, size_y_m), min(size_x_m, size_y_m)
        return long_m >= self.foot_length_m and short_m >= self.foot_width_m
