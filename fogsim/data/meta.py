"""The recording's ``meta_json``: its schema as msgspec structs, decoding and encoding.

msgspec (the project's schema library, see :mod:`fogsim.config.decode`) decodes the JSON text
strictly into the frozen structs below: a string is never a number, an unknown key is an error,
every number lies in the range its field declares (JSON has no NaN or infinity), and errors
carry the key path (``$.intrinsics.cx``). Only the structs' shapes and ranges live here; what a
file must hold besides is checked by :func:`fogsim.data.recording.load_recording`.
"""

from __future__ import annotations

import re
from typing import Annotated

import msgspec
from msgspec import Meta

from fogsim.config.schema import Surface
from fogsim.data.limits import (
    MAX_ABS_YAW_RAD,
    MAX_FOCAL_PX,
    MAX_IMAGE_PIXELS,
    MAX_IMAGE_SIDE_PX,
    MAX_POSITION_M,
    MIN_FOCAL_PX,
)
from fogsim.errors import FogsimError, RecordingError
from fogsim.world import SceneTruth
from fogsim.world.timeline import ObjectState
from mapper.intrinsics import PinholeIntrinsics

FORMAT_NAME = "fogsim-recording"
FORMAT_VERSION = 2
"""2: ground-truth states name every scenario object (``object_names``, for per-object truth)."""
SUPPORTED_VERSIONS = (1, 2)
"""Version 1 files load when they hold no ground truth (real data); their truths are refused."""

ImageSidePx = Annotated[int, Meta(ge=1, le=MAX_IMAGE_SIDE_PX)]
FocalPx = Annotated[float, Meta(ge=MIN_FOCAL_PX, le=MAX_FOCAL_PX)]
PositionM = Annotated[float, Meta(ge=-MAX_POSITION_M, le=MAX_POSITION_M)]
ExtentM = Annotated[float, Meta(gt=0.0, le=MAX_POSITION_M)]
YawRad = Annotated[float, Meta(ge=-MAX_ABS_YAW_RAD, le=MAX_ABS_YAW_RAD)]

_AT = re.compile(r"^(?P<what>.*?)(?: - at `\$\.?(?P<where>[^`]*)`)?$", re.DOTALL)


class IntrinsicsMeta(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """``meta.intrinsics``: the depth camera's pinhole model (pixel centres at integers)."""

    width: ImageSidePx
    height: ImageSidePx
    fx: FocalPx
    fy: FocalPx
    cx: float
    cy: float

    def __post_init__(self) -> None:
        if self.width * self.height > MAX_IMAGE_PIXELS:
            raise ValueError(
                f"width × height = {self.width} × {self.height} must be at most "
                f"{MAX_IMAGE_PIXELS} pixels"
            )
        for name, value, side in (("cx", self.cx, self.width), ("cy", self.cy, self.height)):
            if not -0.5 <= value <= side - 0.5:
                raise ValueError(
                    f"{name} = {value} must lie in the image, in [-0.5, {side - 0.5}] px"
                )

    def to_intrinsics(self) -> PinholeIntrinsics:
        """The mapper's intrinsics."""
        return PinholeIntrinsics(self.width, self.height, self.fx, self.fy, self.cx, self.cy)

    @classmethod
    def from_intrinsics(cls, intrinsics: PinholeIntrinsics) -> IntrinsicsMeta:
        """The stored form of the mapper's intrinsics."""
        k = intrinsics
        return cls(int(k.width), int(k.height), k.fx, k.fy, k.cx, k.cy)


class ObjectStateMeta(msgspec.Struct, frozen=True, forbid_unknown_fields=True, omit_defaults=True):
    """One object of a stored world state (:class:`fogsim.world.timeline.ObjectState`)."""

    name: str
    center_xy: tuple[PositionM, PositionM]
    size: tuple[ExtentM, ExtentM, ExtentM]
    yaw_rad: YawRad
    base_m: PositionM
    walkable: bool
    surface: Surface = "flat"
    roughness_m: Annotated[float, Meta(ge=0.0, le=MAX_POSITION_M)] = 0.0
    heightfield: str | None = None
    cell_m: Annotated[float, Meta(ge=0.0, le=MAX_POSITION_M)] = 0.0
    max_height_m: Annotated[float, Meta(ge=0.0, le=MAX_POSITION_M)] = 0.0


class SceneTruthMeta(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """One stored world state (:class:`fogsim.world.SceneTruth`)."""

    time_s: float
    objects: tuple[ObjectStateMeta, ...]
    surface_names: tuple[str, ...]
    surface_heights_m: dict[str, PositionM] = {}
    object_names: tuple[str, ...] = ()

    def to_truth(self) -> SceneTruth:
        """The world state (raises FogsimError if an object is not among ``object_names``)."""
        objects = tuple(
            ObjectState(
                name=o.name,
                center_xy=o.center_xy,
                size=o.size,
                yaw_rad=o.yaw_rad,
                base_m=o.base_m,
                walkable=o.walkable,
                surface=o.surface,
                roughness_m=o.roughness_m,
                heightfield=o.heightfield,
                cell_m=o.cell_m,
                max_height_m=o.max_height_m,
            )
            for o in self.objects
        )
        return SceneTruth(
            time_s=self.time_s,
            objects=objects,
            surface_names=self.surface_names,
            surface_heights_m=dict(self.surface_heights_m),
            object_names=self.object_names,
        )

    @classmethod
    def from_truth(cls, truth: SceneTruth) -> SceneTruthMeta:
        """The stored form of a world state."""
        objects = tuple(
            ObjectStateMeta(
                name=o.name,
                center_xy=(float(o.center_xy[0]), float(o.center_xy[1])),
                size=(float(o.size[0]), float(o.size[1]), float(o.size[2])),
                yaw_rad=float(o.yaw_rad),
                base_m=float(o.base_m),
                walkable=bool(o.walkable),
                surface=o.surface,  # type: ignore[arg-type]  # a scenario's surface
                roughness_m=float(o.roughness_m),
                heightfield=o.heightfield,
                cell_m=float(o.cell_m),
                max_height_m=float(o.max_height_m),
            )
            for o in truth.objects
        )
        return cls(
            time_s=float(truth.time_s),
            objects=objects,
            surface_names=tuple(truth.surface_names),
            surface_heights_m={str(k): float(v) for k, v in truth.surface_heights_m.items()},
            object_names=tuple(truth.object_names),
        )


class _FormatMeta(msgspec.Struct, frozen=True):
    """What every version of ``meta_json`` holds: read first to pick the version."""

    format: str
    version: int
    truths: tuple[msgspec.Raw, ...] = ()


class RecordingMeta(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """``meta_json``: the recording's format, camera, scenario and ground truth.

    Attributes:
        format: Always :data:`FORMAT_NAME`.
        version: :data:`FORMAT_VERSION` when written; any of :data:`SUPPORTED_VERSIONS` loads.
        intrinsics: The depth camera's intrinsics.
        scenario_toml: The scenario file's text, or None (real data: not scored).
        truths: Every distinct world state (``truth_index`` points into it).
        created_by: What wrote the file (``"fogsim"``).
    """

    format: str
    version: int
    intrinsics: IntrinsicsMeta
    scenario_toml: str | None = None
    truths: tuple[SceneTruthMeta, ...] = ()
    created_by: str | None = None


def _where(exc: msgspec.MsgspecError) -> str:
    """The message of a msgspec error, "what - at `$.a.b`", as "a.b: what"."""
    match = _AT.match(str(exc))
    assert match is not None  # the pattern matches any text
    return f"{match['where']}: {match['what']}" if match["where"] else match["what"]


def decode_meta(text: str, origin: str) -> RecordingMeta:
    """Decode ``meta_json`` text.

    Args:
        text: The JSON text.
        origin: How errors name where the text came from (``"FILE: meta_json"``).

    Raises:
        RecordingError: Not JSON, not a fogsim recording, an unsupported version, a version-1
            file with ground truth, or a key missing, unknown, of the wrong type or out of
            range (the message names the key path and what is allowed).
    """
    try:
        head = msgspec.json.decode(text, type=_FormatMeta)
    except msgspec.MsgspecError as exc:
        raise RecordingError(f"{origin}: {_where(exc)}") from exc
    if head.format != FORMAT_NAME:
        raise RecordingError(f"{origin}: format must be '{FORMAT_NAME}', got {head.format!r}")
    if head.version not in SUPPORTED_VERSIONS:
        raise RecordingError(
            f"{origin}: recording version {head.version} is not supported; "
            f"supported versions: {list(SUPPORTED_VERSIONS)}"
        )
    if head.version == 1 and head.truths:
        raise RecordingError(
            f"{origin}: a version 1 recording's ground truth lacks the scenario's object names "
            "(version 2 scores per object); record the scenario again with `fogsim record`"
        )
    try:
        return msgspec.json.decode(text, type=RecordingMeta)
    except msgspec.MsgspecError as exc:
        raise RecordingError(f"{origin}: {_where(exc)}") from exc


def decode_truths(meta: RecordingMeta, origin: str) -> list[SceneTruth]:
    """The stored world states.

    Raises:
        RecordingError: A state names an object missing from its ``object_names``.
    """
    truths = []
    for index, stored in enumerate(meta.truths):
        try:
            truths.append(stored.to_truth())
        except FogsimError as exc:
            raise RecordingError(f"{origin}: truths[{index}]: {exc}") from exc
    return truths


def encode_meta(meta: RecordingMeta, origin: str) -> str:
    """The JSON text of ``meta``, checked by decoding it as :func:`decode_meta` would.

    Raises:
        RecordingError: A value the file could not hold (e.g. NaN, out of range).
    """
    text = msgspec.json.encode(meta).decode("utf-8")
    decode_meta(text, origin)
    return text
