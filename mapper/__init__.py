"""Floor and obstacle height map (Gutmann, Fukuchi, Fujita) as a library; no MuJoCo dependency."""

# First: the kernels' cache locator is chosen when a kernel is decorated (`mapper.kernel_cache`).
from mapper import kernel_cache  # noqa: F401  (installs the package-wide cache stamp)
from mapper.averaging import AveragingMap
from mapper.backends import HeightMapBackend, StepRuleParams, label_by_step
from mapper.elevation import ElevationFilterParams, RobotElevationFilter
from mapper.elevation_map import ElevationMap, ElevationMapParams
from mapper.errors import InvalidInputError, InvalidParameterError, MapperError
from mapper.grid import AffectedArea, CellType, GridGeometry, UpdateResult
from mapper.heading import HeadingEstimator, HeadingParams
from mapper.intrinsics import PinholeIntrinsics
from mapper.last_map import LastMeasurementMap
from mapper.mapper import FloorObstacleMapper
from mapper.params import MapperParams
from mapper.segmentation import (
    PoseCorrection,
    SegmentationParams,
    SegmentationResult,
    segment_depth,
)
from mapper.tilt_filter import TiltFilter, TiltFilterParams
from mapper.zmatch import ZDecision, ZMatch, apply_z_shift, frame_decision

__all__ = [
    "AffectedArea",
    "AveragingMap",
    "CellType",
    "ElevationFilterParams",
    "ElevationMap",
    "ElevationMapParams",
    "FloorObstacleMapper",
    "GridGeometry",
    "HeadingEstimator",
    "HeadingParams",
    "HeightMapBackend",
    "InvalidInputError",
    "InvalidParameterError",
    "LastMeasurementMap",
    "MapperError",
    "MapperParams",
    "PinholeIntrinsics",
    "PoseCorrection",
    "RobotElevationFilter",
    "SegmentationParams",
    "SegmentationResult",
    "StepRuleParams",
    "TiltFilter",
    "TiltFilterParams",
    "UpdateResult",
    "ZDecision",
    "ZMatch",
    "apply_z_shift",
    "frame_decision",
    "label_by_step",
    "segment_depth",
]
