"""The scenario schema: frozen dataclasses of the TOML contract of DESIGN.md "Scenario files".

A scenario names the robot, its camera, the encoder errors, the boxes of the scene, the route
the robot walks and the events that change the world. Lengths are metres, angles degrees,
times seconds. Each field declares what a file may give it — its type, range
(``Annotated[float, Meta(ge=..., le=...)]``) or choices (``Literal``) — and
:func:`scenario_from_dict` decodes a parsed file with msgspec (see :mod:`fogsim.config.decode`);
rules across fields are checked in ``__post_init__``. Every mistake raises
:class:`~fogsim.errors.ScenarioError` naming the file, the key (dotted, e.g.
``objects[2].size``), the value and what is allowed.

Our extensions to DESIGN.md's table (all optional, with defaults):
    ``[camera]``: ``baseline_m``, ``disparity_noise_px``, ``disparity_step_px``,
        ``dropout``, ``range_m``, ``disparity_noise_correlation_px``, ``edge_fattening_px``,
        ``occlusion`` — the stereo error model of the ``depth`` mode.
    ``[encoders]``: ``head_bias_deg``, ``head_noise_deg`` — the neck joints' error levels.
    ``[[objects]]``: ``roughness_m`` — bump height of a rough top; ``heightfield``,
        ``cell_m``, ``max_height_m`` — a terrain whose top is an 8-bit elevation image.
    ``[segmentation]``: parameter overrides of the plane segmentation.
    ``[heading]``, ``[pipeline]``, ``[reference]``, ``[elevation]``: parameter overrides of the
        heading correction, the pipeline's switches, the height reference and the robot
        elevation filter (the groups of `fogsim.config.params.RunParams`).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Literal, get_args

import cv2
import numpy as np
from msgspec import Meta
from numpy.typing import NDArray

from fogsim.config.decode import NOT_IN_FILE, FieldRuleError, decode, shown
from fogsim.config.limits import (
    MAX_CAMERA_SIDE_PX,
    MAX_EVENTS,
    MAX_FRAME_RATE_HZ,
    MAX_OBJECT_EXTENT_M,
    MAX_OBJECTS,
    MIN_CAMERA_SIDE_PX,
    MIN_STEREO_WIDTH_PX,
    SCENARIO_NAME,
    SCENARIO_NAME_PATTERN,
    WORLD_BOUND_M,
)
from fogsim.config.overrides import assign_overrides
from fogsim.config.params import OVERRIDE_PREFIXES, RunParams, replace_params
from fogsim.config.write import TomlValue, to_table, toml_text
from fogsim.errors import ParameterError, ScenarioError
from fogsim.paths import ASSETS_DIR, ROBOT_NAMES

# The robots are the description files in assets/robots/ (one list for config and robot).
RobotModel = Literal[ROBOT_NAMES]  # type: ignore[valid-type]
CameraMode = Literal["ideal", "depth", "stereo"]
Surface = Literal["flat", "rough"]
Texture = Literal["noise", "none"]
ROBOT_MODELS: tuple[str, ...] = get_args(RobotModel)
CAMERA_MODES: tuple[str, ...] = get_args(CameraMode)
SURFACES: tuple[str, ...] = get_args(Surface)
ROUTE_KINDS = ("walk_to", "turn_to", "look", "wait")
EVENT_KINDS = ("remove", "move")

# The ranges a file may give (generous sanity bounds, resource limits from fogsim.config.limits;
# the defaults are justified per field).
Coordinate = Annotated[float, Meta(ge=-WORLD_BOUND_M, le=WORLD_BOUND_M)]
"""A world x or y [m] (and the start yaw [deg]): within a kilometre of the origin."""
FovDeg = Annotated[float, Meta(ge=1.0, le=170.0)]
DepthM = Annotated[float, Meta(ge=0.01, le=100.0)]
Pixels = Annotated[int, Meta(ge=MIN_CAMERA_SIDE_PX, le=MAX_CAMERA_SIDE_PX)]
JointErrorDeg = Annotated[float, Meta(ge=0.0, le=10.0)]
ExtentM = Annotated[float, Meta(ge=0.005, le=MAX_OBJECT_EXTENT_M)]
HeadDeg = Annotated[float, Meta(ge=-90.0, le=90.0)]
# \Z, not $: "$" also matches before a final newline
ObjectName = Annotated[str, Meta(pattern=r"^[\w-]+\Z", description="letters, digits, '_' or '-'")]
ParameterTable = Mapping[str, bool | int | float]
"""``[mapper]`` / ``[segmentation]``: field name → value as written (an int stays an int)."""
HEIGHTFIELD_SIDE_PX = (3, 512)
"""(min, max) side of a heightfield image [px]: 3 samples make one interior cell; 512 × 512
samples (a 20 m square at 0.04 m) keep the MuJoCo model and the truth's arrays small."""
UNSET_SIZE = (0.0, 0.0, 0.0)
"""The ``size`` of an object whose file gives none (a heightfield's comes from its image)."""


def read_heightfield(relative_path: str) -> NDArray[np.uint8]:
    """The 8-bit elevation image ``assets/<relative_path>`` as (rows, columns) values 0-255.

    Colour images must be grey (R = G = B, as the ETH elevation maps are); their first channel
    is read. Row 0 is the image's top, the object's +y edge; column 0 its -x edge. Each file is
    read once per process.

    Raises:
        FieldRuleError: (key ``heightfield``) a path outside ``assets/``, a missing or unreadable
            file, an image that is not 8-bit grey, or a side outside ``HEIGHTFIELD_SIDE_PX``.
    """
    root = ASSETS_DIR.resolve()
    path = (root / relative_path).resolve()
    if not path.is_relative_to(root) or not path.is_file():
        raise FieldRuleError(
            "heightfield",
            f"must be an image file inside {root} (a path relative to it), "
            f"got {shown(relative_path)}",
        )
    return _read_elevation_image(path, relative_path)


@functools.cache
def _read_elevation_image(path: Path, relative_path: str) -> NDArray[np.uint8]:
    """The checked, read-only image of :func:`read_heightfield` (``relative_path`` for errors)."""
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None or image.dtype != np.uint8:
        kind = "unreadable" if image is None else f"{image.dtype} values"
        raise FieldRuleError(
            "heightfield", f"must be an 8-bit image, got {shown(relative_path)} ({kind})"
        )
    if image.ndim == 3:
        grey = image[..., : min(3, image.shape[2])]
        if np.any(grey != grey[..., :1]):
            raise FieldRuleError(
                "heightfield", f"must be grey (R = G = B), got colours in {shown(relative_path)}"
            )
        image = grey[..., 0]
    low, high = HEIGHTFIELD_SIDE_PX
    if not (low <= min(image.shape) and max(image.shape) <= high):
        raise FieldRuleError(
            "heightfield",
            f"must have {low} to {high} pixels a side, got {image.shape[1]} × {image.shape[0]} "
            f"in {shown(relative_path)}",
        )
    image = np.ascontiguousarray(image)
    image.flags.writeable = False
    return image


@dataclass(frozen=True)
class RobotSpec:
    """Which robot walks and where it starts (the scenario's ``[robot]``).

    Attributes:
        model: Robot name, one of ``ROBOT_MODELS``.
        start: (x [m], y [m], yaw [deg]) of the robot frame in the world.
    """

    model: RobotModel = "icub"
    start: tuple[Coordinate, Coordinate, Coordinate] = (0.3, 0.5, 0.0)


@dataclass(frozen=True)
class CameraConfig:
    """The head camera and the stereo error model of the ``depth`` mode.

    Attributes:
        mode: ``ideal`` (exact depth), ``depth`` (exact depth + stereo error model) or
            ``stereo`` (left/right images matched with OpenCV).
        width: Image width [px].
        height: Image height [px].
        fov_deg: (horizontal, vertical) full field of view [deg].
        baseline_m: Stereo baseline of the error model [m].
        disparity_noise_px: Std of the Gaussian disparity noise [px].
        disparity_step_px: Disparity quantisation step [px] (OpenCV's SGBM: 1/16).
        dropout: Fraction of pixels randomly without a measurement.
        range_m: (min, max) measurable depth along the optical axis [m].
        disparity_noise_correlation_px: ``depth`` mode: std [px] of the Gaussian kernel that
            smooths the disparity noise, as a matching window does (0 = white noise).
        edge_fattening_px: ``depth`` mode: how far [px] the nearer side of a depth edge spreads
            over the farther, as a stereo matching window does (0 = none).
        occlusion: ``depth`` mode: True drops the pixels a right camera ``baseline_m`` away
            cannot see, as a stereo matcher's left-right check does.
    """

    mode: CameraMode = "depth"
    width: Pixels = 88
    height: Pixels = 72
    fov_deg: tuple[FovDeg, FovDeg] = (47.0, 39.0)
    baseline_m: Annotated[float, Meta(ge=0.005, le=1.0)] = 0.07
    disparity_noise_px: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.05
    disparity_step_px: Annotated[float, Meta(ge=0.0, le=4.0)] = 0.0625
    dropout: Annotated[float, Meta(ge=0.0, le=0.9)] = 0.01
    range_m: tuple[DepthM, DepthM] = (0.15, 4.0)
    disparity_noise_correlation_px: Annotated[float, Meta(ge=0.0, le=5.0)] = 0.0
    edge_fattening_px: Annotated[int, Meta(ge=0, le=8)] = 0
    occlusion: bool = False

    def __post_init__(self) -> None:
        if self.range_m[0] >= self.range_m[1]:
            raise FieldRuleError(
                "range_m", f"must be [min, max] with min < max, got {list(self.range_m)}"
            )
        if self.mode == "stereo" and self.width < MIN_STEREO_WIDTH_PX:
            raise FieldRuleError(
                "width",
                f"must be at least {MIN_STEREO_WIDTH_PX} px in the stereo mode (its matcher "
                f"searches 32 px of disparity at twice the resolution), got {self.width}",
            )


@dataclass(frozen=True)
class EncoderConfig:
    """Joint-encoder error injection.

    Attributes:
        bias_deg: Std of the per-joint bias drawn once per run [deg] (legs, torso, arms).
        noise_deg: Std of the per-frame reading noise [deg] (legs, torso, arms).
        head_bias_deg: Std of the bias of the neck joints [deg]. In a file: optional; if the
            file gives ``bias_deg`` but not this key it equals ``bias_deg`` (one level for all
            joints, as before the key existed), else the paper-matched default.
        head_noise_deg: Std of the noise of the neck joints [deg] (same rule with
            ``noise_deg``).

    The defaults follow the paper's "up to 7° and 10 mm" camera-pose error (precise legs and
    torso, a sloppy neck); on the stage run with iCub they give about 5° and 12 mm at most
    (see ``fogsim.robot.encoders.EncoderModel`` for why not 7° and 10 mm together).
    """

    bias_deg: JointErrorDeg = 0.05
    noise_deg: JointErrorDeg = 0.02
    head_bias_deg: JointErrorDeg = 4.0
    head_noise_deg: JointErrorDeg = 0.3


_HEIGHTFIELD_DEFAULTS = {"cell_m": 0.04, "max_height_m": 1.0}
"""A heightfield's keys → their defaults (see :class:`SceneObject`); boxes leave them out."""

_HEAD_DEFAULTS = {"head_bias_deg": "bias_deg", "head_noise_deg": "noise_deg"}
"""Head key → the body key whose value it takes when a file gives only the body key."""


@dataclass(frozen=True)
class SceneObject:
    """A box of the scene, or a terrain whose top is an elevation image.

    Attributes:
        name: Unique name (the MuJoCo body is called ``obj_<name>``).
        center: (x, y) of the footprint centre in the world [m].
        size: (x, y, z) extent [m]. Required for a box; a heightfield's is its image's extent
            ((columns - 1) × ``cell_m``, (rows - 1) × ``cell_m``, its highest value's height),
            filled in when the file omits it and checked when the file gives it.
        yaw_deg: Rotation about the world z axis [deg].
        base: z of the bottom face [m]; > 0 hangs in the air (a table top, a curtain).
        walkable: Its top is a floor (a row of Table I).
        surface: ``flat`` or ``rough`` (a bumpy top that is no plane; never walkable).
        roughness_m: Bump height of a rough top [m] (the top is at ``base + size z``).
        heightfield: Path inside ``assets/`` of an 8-bit elevation image (see
            :func:`read_heightfield`); None for a box. Each pixel is a height sample, ``cell_m``
            apart: height = value / 255 × ``max_height_m`` above the ground (the ETH elevation
            maps' convention). A heightfield rests on the ground (``base`` 0), its ``surface``
            is ``flat`` and it is never ``walkable`` (no Table I row: its floors are many).
        cell_m: Spacing of a heightfield's samples [m] (heightfield only). Default: 0.04 m, the
            ETH maps' cell.
        max_height_m: Height of the value 255 [m] (heightfield only). Default: 1.0 m, the ETH
            demo's default.
        texture: ``noise`` (the 1/f grey noise of ``assets/mjcf/textures.toml``, as on every
            shipped surface) or ``none``: one flat colour, nothing for a stereo matcher to match
            (the known failure mode of stereo; ``depth`` and ``ideal`` modes do not see it).
    """

    name: ObjectName
    center: tuple[Coordinate, Coordinate]
    size: tuple[ExtentM, ExtentM, ExtentM] = UNSET_SIZE
    yaw_deg: Annotated[float, Meta(ge=-360.0, le=360.0)] = 0.0
    base: Annotated[float, Meta(ge=0.0, le=10.0)] = 0.0
    walkable: bool = False
    surface: Surface = "flat"
    roughness_m: Annotated[float, Meta(ge=0.002, le=1.0)] = 0.02
    heightfield: str | None = None
    cell_m: Annotated[float, Meta(ge=0.005, le=1.0)] | None = None
    max_height_m: Annotated[float, Meta(ge=0.01, le=10.0)] | None = None
    texture: Texture = "noise"

    def __post_init__(self) -> None:
        if self.heightfield is not None:
            self._check_heightfield()
        else:
            for key in _HEIGHTFIELD_DEFAULTS:
                if getattr(self, key) is not None:
                    raise FieldRuleError(key, "is only allowed with heightfield")
            if self.size == UNSET_SIZE:
                raise FieldRuleError("size", "is required (an [x, y, z] extent [m]) but missing")
        if self.surface != "rough":
            return
        if self.walkable:
            raise FieldRuleError(
                "walkable", "a rough top is no plane: rough objects must be walkable = false"
            )
        if self.roughness_m >= self.size[2]:
            raise FieldRuleError(
                "roughness_m",
                f"must be smaller than the object's height {self.size[2]} m, "
                f"got {self.roughness_m}",
            )

    def _check_heightfield(self) -> None:
        """Heightfield rules; fills ``size`` from the image when the file gives none."""
        for key, allowed in (("base", 0.0), ("walkable", False), ("surface", "flat")):
            if getattr(self, key) != allowed:
                raise FieldRuleError(
                    key,
                    f"must be {shown(allowed)} for a heightfield (it rests on the ground and "
                    f"is no single surface), got {shown(getattr(self, key))}",
                )
        for key, default in _HEIGHTFIELD_DEFAULTS.items():
            if getattr(self, key) is None:
                object.__setattr__(self, key, default)
        derived = self.heightfield_size_m()
        if self.size == UNSET_SIZE:
            object.__setattr__(self, "size", derived)
        elif self.size != derived:
            raise FieldRuleError(
                "size",
                f"of a heightfield comes from its image: omit it or give {list(derived)}, "
                f"got {list(self.size)}",
            )

    def heightfield_m(self) -> NDArray[np.float64]:
        """A heightfield's sample heights (rows, columns) above the ground [m].

        Row 0 is the object's +y edge, column 0 its -x edge (the image as seen from above).
        """
        if self.heightfield is None or self.max_height_m is None:
            raise FieldRuleError("heightfield", f"object {self.name!r} is a box, not a heightfield")
        return read_heightfield(self.heightfield) * (self.max_height_m / 255.0)

    def heightfield_size_m(self) -> tuple[float, float, float]:
        """A heightfield's (x, y, z) extent [m]: samples at its corners, z its highest sample."""
        heights = self.heightfield_m()
        rows, columns = heights.shape
        top = max(float(heights.max()), 0.005)  # an all-zero image still has an extent
        cell_m = float(self.cell_m or 0.0)
        return ((columns - 1) * cell_m, (rows - 1) * cell_m, top)

    @property
    def top_m(self) -> float:
        """Height of the highest point of the object above z = 0 [m]."""
        return self.base + self.size[2]


@dataclass(frozen=True)
class RouteStep:
    """One route command; exactly one attribute is set (the others are None).

    Attributes:
        walk_to: (x, y) target in the world [m].
        turn_to: Body yaw in the world [deg].
        look: (head yaw, head pitch) relative to the body [deg].
        wait: Standing time [s].
    """

    walk_to: tuple[Coordinate, Coordinate] | None = None
    turn_to: Annotated[float, Meta(ge=-720.0, le=720.0)] | None = None
    look: tuple[HeadDeg, HeadDeg] | None = None
    wait: Annotated[float, Meta(ge=0.001, le=3600.0)] | None = None

    def __post_init__(self) -> None:
        present = [k for k in ROUTE_KINDS if getattr(self, k) is not None]
        if len(present) != 1:
            raise FieldRuleError(
                "", f"must have exactly one of {', '.join(ROUTE_KINDS)}; got {present or 'none'}"
            )

    @property
    def kind(self) -> str:
        """Which command this is: one of ``ROUTE_KINDS``."""
        return next(k for k in ROUTE_KINDS if getattr(self, k) is not None)


@dataclass(frozen=True)
class Event:
    """A change of the world during the run; exactly one of ``remove`` and ``move`` is set.

    Attributes:
        at: Start time [s].
        remove: Name of the object that leaves at ``at``.
        move: Name of the object that slides to ``to`` from ``at`` on.
        to: (x, y) destination of the footprint centre [m] (move only).
        speed: Sliding speed [m/s] (move only).
    """

    at: Annotated[float, Meta(ge=0.0, le=1e5)]
    remove: str | None = None
    move: str | None = None
    to: tuple[Coordinate, Coordinate] | None = None
    speed: Annotated[float, Meta(ge=1e-4, le=10.0)] | None = None

    def __post_init__(self) -> None:
        present = [k for k in EVENT_KINDS if getattr(self, k) is not None]
        if len(present) != 1:
            raise FieldRuleError(
                "", f"must have exactly one of {', '.join(EVENT_KINDS)}; got {present or 'none'}"
            )
        for key in ("to", "speed"):
            if self.remove is not None and getattr(self, key) is not None:
                raise FieldRuleError(key, "only allowed with move, not with remove")
            if self.move is not None and getattr(self, key) is None:
                raise FieldRuleError(key, "is required with move but missing")

    @property
    def kind(self) -> str:
        """``remove`` or ``move``: one of ``EVENT_KINDS``."""
        return "remove" if self.remove is not None else "move"

    @property
    def target(self) -> str:
        """Name of the object the event changes."""
        return self.remove if self.remove is not None else str(self.move)


@dataclass(frozen=True)
class Scenario:
    """A validated scenario (see the module docstring and DESIGN.md "Scenario files").

    Attributes:
        name: The scenario's name (the file stem of the shipped ones); a safe file name
            (:data:`~fogsim.config.limits.SCENARIO_NAME_PATTERN`), as runs and caches are
            stored under it.
        description: One line for listings.
        seed: Seed of every random stream of the run.
        frame_rate_hz: Camera frames per second (the paper's 12.5).
        robot: The ``[robot]`` table.
        camera: The ``[camera]`` table.
        encoders: The ``[encoders]`` table.
        objects: The ``[[objects]]``, names unique.
        route: The ``[[route]]`` steps, in order.
        events: The ``[[events]]``; each names an object.
        mapper: ``[mapper]``: MapperParams fields → values (checked at load).
        segmentation: ``[segmentation]``: SegmentationParams fields → values (checked at load).
        heading: ``[heading]``: HeadingParams fields → values (checked at load).
        pipeline: ``[pipeline]``: PipelineParams fields → values (checked at load).
        reference: ``[reference]``: HeightReferenceParams fields → values (checked at load;
            above the robot description's neck pivot, `fogsim.run.runner.sensor_fields`).
        elevation: ``[elevation]``: ElevationFilterParams fields → values (checked at load).
        source_path: The file it was read from (not part of the file; ignored by ``==``).
    """

    name: str
    description: str = ""
    seed: Annotated[int, Meta(ge=0, le=2**32 - 1)] = 0
    frame_rate_hz: Annotated[float, Meta(ge=0.1, le=MAX_FRAME_RATE_HZ)] = 12.5
    robot: RobotSpec = field(default_factory=RobotSpec)
    camera: CameraConfig = field(default_factory=CameraConfig)
    encoders: EncoderConfig = field(default_factory=EncoderConfig)
    objects: Annotated[
        tuple[SceneObject, ...],
        Meta(max_length=MAX_OBJECTS, description=f"an array of at most {MAX_OBJECTS} tables"),
    ] = ()
    route: tuple[RouteStep, ...] = ()
    events: Annotated[
        tuple[Event, ...],
        Meta(max_length=MAX_EVENTS, description=f"an array of at most {MAX_EVENTS} tables"),
    ] = ()
    mapper: ParameterTable = field(default_factory=dict)
    segmentation: ParameterTable = field(default_factory=dict)
    heading: ParameterTable = field(default_factory=dict)
    pipeline: ParameterTable = field(default_factory=dict)
    reference: ParameterTable = field(default_factory=dict)
    elevation: ParameterTable = field(default_factory=dict)
    source_path: Path | None = field(default=None, compare=False, metadata=NOT_IN_FILE)

    def __post_init__(self) -> None:
        if not SCENARIO_NAME.fullmatch(self.name):
            raise FieldRuleError(
                "name",
                "must be a safe file name: 1-64 letters, digits, '_', '.' or '-', starting "
                f"with a letter or digit, no '..' (pattern {SCENARIO_NAME_PATTERN}), "
                f"got {shown(self.name)}",
            )
        names = [o.name for o in self.objects]
        for i, name in enumerate(names):
            if name in names[:i]:
                raise FieldRuleError(
                    f"objects[{i}].name", f"duplicate object name {name!r}; names must be unique"
                )
        for i, event in enumerate(self.events):
            if event.target not in names:
                raise FieldRuleError(
                    f"events[{i}].{event.kind}",
                    f"no object named {event.target!r}; objects: {', '.join(names) or '(none)'}",
                )

    def object(self, name: str) -> SceneObject:
        """The object called ``name``; ScenarioError listing the names if there is none."""
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise ScenarioError(
            f"{self.origin}: no object named {name!r}; objects: "
            f"{', '.join(o.name for o in self.objects) or '(none)'}"
        )

    @property
    def origin(self) -> str:
        """How messages name the scenario: its file, else ``scenario '<name>'``."""
        return str(self.source_path) if self.source_path else f"scenario {self.name!r}"

    def to_dict(self) -> dict[str, TomlValue]:
        """The scenario as the plain tables of its TOML file (round-trips through the loader)."""
        return to_table(self)

    def to_toml(self) -> str:
        """The scenario as TOML text that :func:`scenario_from_dict` reads back equal."""
        return toml_text(self)

    def with_overrides(self, assignments: Sequence[str]) -> Scenario:
        """A copy with ``key=value`` assignments applied, validated again.

        Keys are dotted: ``seed=3``, ``camera.mode=ideal``, ``mapper.p_occ=0.7``,
        ``encoders.bias_deg=0``, ``objects.<name>.<field>=...``. Values are TOML values
        (``[1, 2]``, ``true``, ``0.5``); a bare word is taken as a string.

        Raises:
            ScenarioError: a malformed assignment, an unknown key or an invalid value.
        """
        origin = f"{self.origin} (override)"
        tables = assign_overrides(self.to_dict(), assignments, origin)
        return scenario_from_dict(tables, source=self.source_path, where=origin)


PARAMETER_TABLES = tuple(OVERRIDE_PREFIXES)
"""The scenario tables of parameter overrides, each a :class:`~fogsim.config.params.RunParams`
group of the same name."""


def scenario_from_dict(
    data: Mapping[str, object], source: Path | None = None, where: str | None = None
) -> Scenario:
    """Validate a parsed TOML document and build the :class:`Scenario`.

    Besides the declared types, ranges and rules: ``[encoders]`` head keys default to the body
    keys a file gives (see :class:`EncoderConfig`), and the parameter tables (``[mapper]``,
    ``[segmentation]``, ``[heading]``, ``[pipeline]``, ``[reference]``, ``[elevation]``) must be
    valid changes of their :class:`~fogsim.config.params.RunParams` group (names, types and the
    classes' own ranges).

    Args:
        data: The parsed TOML document.
        source: The file it came from (kept as ``source_path``).
        where: How errors name the origin (defaults to the file path).

    Raises:
        ScenarioError: The document breaks the contract; the message names the origin, the
            dotted key, the value and what is allowed.
    """
    origin = where or (str(source) if source else "scenario")
    defaults = RunParams()
    for table in PARAMETER_TABLES:
        values = data.get(table, {})
        if isinstance(values, Mapping):  # else decode says it must be a table
            try:
                replace_params(getattr(defaults, table), values, table)
            except ParameterError as exc:
                raise ScenarioError(f"{origin}: {exc}") from exc
    scenario = decode(_with_head_defaults(data), Scenario, origin)
    return scenario if source is None else replace(scenario, source_path=source)


def _with_head_defaults(data: Mapping[str, object]) -> Mapping[str, object]:
    """``data`` with ``[encoders]`` head keys filled from the body keys the file gives."""
    encoders = data.get("encoders")
    if not isinstance(encoders, Mapping):
        return data
    filled = {
        head: encoders[body]
        for head, body in _HEAD_DEFAULTS.items()
        if body in encoders and head not in encoders
    }
    return {**data, "encoders": {**encoders, **filled}} if filled else data
