"""Every parameter of a run, resolved once: library defaults ← scenario tables ← overrides.

:class:`RunParams` groups the mapper's, the segmentation's, the robot elevation filter's and the
pipeline's own parameters; :func:`resolve_params` builds it from a scenario and ``--set`` style
overrides. :func:`replace_params` is the one conversion of a ``{name: value}`` mapping into a
parameter dataclass (the scenario loader checks ``[mapper]`` and ``[segmentation]`` with it, the
run resolves its parameters with it); its errors name the key, the value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

from fogsim.config.decode import shown
from fogsim.errors import ParameterError
from mapper import ElevationFilterParams, HeadingParams, MapperParams
from mapper.reference import HeightReferenceParams
from mapper.segmentation import SegmentationParams

if TYPE_CHECKING:  # for the annotation only: the schema imports this module
    from fogsim.config.schema import Scenario

P = TypeVar("P")
"""A frozen parameter dataclass (``MapperParams``, ``SegmentationParams``, ...)."""


@dataclass(frozen=True)
class PipelineParams:
    """Parameters of the pipeline around the mapper (override keys ``pipe.<name>``).

    Attributes:
        use_z_match: Apply the z-shift matching (paper: optional step 2 of Fig. 2). Off, the
            held-out stereo suite (session 57, seeds 1–8) goes 394.88 → 401.88 unsafe cells
            in all with 54 Table I rows 0.5 mm or more better and 117 worse (`stairs_35_65_100`
            seed 3's ground 2.7 → 14.1 mm, `rock_field` seed 8's sill −1.7 → −21.6 mm): in
            stereo the match takes out what each frame's residual tilt moves its surfaces by.
            Weighting its pairs by 1/range² (a prototype) gave 401.88 too (rows 12 / 19).
        use_elevation_filter: Filter the robot's z with the floor map (Sec. IV).
        event_tolerance_m: Height tolerance of "floor again" in the event scores [m].
        use_height_reference: Estimate the camera height over frames (`mapper.reference`)
            instead of the segmentation's per-frame ground shift, and map no frame before it is
            known (issue 11: one frame's ground fragment froze the whole map's height).
        anchor_shift_m: The anchor rule: a frame shifted by its own measurement of the ground
            under the feet (it agrees with the height reference's estimate: its data are right
            relative to the feet) is still z-matched onto the map when the match's shift is at
            most this [m]: that much is the odometry's z drift since the map around it was
            built, and the map, anchored at the start pose, holds the ground there. A larger
            shift goes to the elevation filter only (the map may be wrong there: walking down,
            it was built by frames mapped before the reference was known). A frame whose
            measurement disagrees with the estimate (shifted by the estimate) is z-matched
            whatever the shift. 0.001: flat_floor seeds 1-8 exact (0.36 mm mean, 0.72 mm worst
            with 0: odometry drifts up to −1.6 mm in 66 frames and the map follows unshifted
            frames); 0.002 changes nothing there; with no limit stage_down's platform row goes
            from 2.45 to 3.17 mm worst.
        use_tilt_filter: Rotate each frame by the tilt filtered over frames
            (`mapper.tilt_filter`) instead of the tilt its own planes measured (issue 12: the
            stereo fit's noise, ~0.2° per frame, tilted far surfaces by several mm).
        tilt_noise_deg: The camera tilt's per-frame noise per axis [deg], the filter's
            `TiltFilterParams.noise_deg` (0.3: the default neck encoder noise; not the
            scenario's own level: the camera's tilt error is more than the neck's, and
            moving_box's 0.2 / 0.5° made the filter refuse the true tilt on seed 2, whose box
            top was then never mapped).
        tilt_bias_deg: The neck encoders' per-run bias std [deg], the filter's
            `TiltFilterParams.bias_deg` (4.0: the default neck encoder bias).
        tilt_tail_dof: The filter's `TiltFilterParams.tail_dof`: degrees of freedom of a
            Student-t measurement noise, inf (the default) Gaussian; its docstring has the
            measured trade-off of 2.
        tilt_turn_frames: The camera's turn the filter's process noise scales with is taken
            over this many frames, as the angle between the believed camera orientation now and
            that many frames ago, divided by the frames (1: since the previous frame). The
            believed turn per frame is mostly the neck encoders' reading noise (its median
            0.65° on a walk with the head held still, three joints' 0.3° noise, which moves no
            bias), and it let the bias drift after a run of wrongly tilted frames (stereo
            `down_landing_turn` seed 4: frames 651-692, the roll 1.5° off); over several frames
            the noise averages out of the turn while a real head motion keeps its rate. 1 (the
            default): 4 was measured (session 46, stereo, seeds 1-8, mean (worst), 1 → 4) and
            trades one scene for another: held-out `down_landing_turn`'s landing row 16.5
            (17.4) → 8.3 (14.8) mm, `down_slant_turn`'s step_1 7.0 (16.0) → 1.7 (4.2) mm and
            platform 4.8 (14.3) → 1.8 (4.6) mm, `stairs_35_65_100` 38 (124) → 28 (77) unsafe
            cells, the share of frames whose applied tilt is more than 1° off over 43 stereo
            recordings (`eth_stairs` among them) 2.98 → 2.46 %; but `down_shallow_steps` 58
            (116) → 235 (831) unsafe cells (seeds 5 and 7 fail at the start again: one more
            frame taken 2.2° tilted, the far ground misread, session 45's start rule no longer
            enough), `down_low_steps` 122 (217) → 140 (262), the zig-zag stage's sill 0.83
            (1.39) → 4.86 (33.9) mm, the stage 1.75 (4) → 2.75 (8) and `talos_course`'s worst
            seed 75 → 90 unsafe cells.
            The start's tilt is what fails there: the first frames' planes join small steps
            into ramps, which any process noise lets through. Session 57, the held-out stereo
            suite on today's pipeline, 1 → 4: 394.88 → 658.25 unsafe cells in all
            (`down_shallow_steps` 44.88 (61) → 217.50 (796), `down_low_steps` 81.88 (192) →
            175.38 (421)), and `down_landing_turn` no longer gains (73.25 → 72.00, its landing
            row 17.4 mm on its worst seed either way); 4 only from the 100th frame on (a
            prototype) left the start alone but moved seed 1's 16 mm from the landing to step_1.
        heading_rebuild_frames: When the heading's first estimate comes, the maps are rebuilt
            from the frames mapped before it (issue 11: they carried the neck's 2–3° yaw error,
            8–17 cm at 2 m), if there are at most this many and their data fit
            `fogsim.mapping.pipeline.MAX_REBUILD_BYTES` (256 MiB; each frame is kept until
            then: 226 KB at 88 × 72, so at most 226 MB). 1000: more than the longest shipped
            walk (stage_down, 941 frames), so a walk's first estimate rebuilds its maps however
            late it comes. 400 until session 54 (the first estimate came at frame ~115 of the
            stage, ~186 of stage_down; `room`'s structure estimates, which
            `heading_rebuild_on_structure` rebuilds with, at frames 211–330), which left the
            held-out `down_low_steps` unrebuilt: its estimates come late (seed 7 at frame 548,
            3.6° where the frames before it carried −3.6°). 400 → 1000, `fogsim suite`, seeds
            1–8, mean (worst): `down_low_steps` depth unsafe cells 41.62 (83) → 36.38 (83)
            (seed 7 50 → 8, its maps' heading 3.59 → 0.23°, obstacle recall 49 → 89 %), stereo
            99.62 (198) → 90.75 (198); held-out unsafe cells in all depth 197.12 → 191.88,
            stereo 440.50 → 431.00 (`down_slant_turn` 96.12 → 95.50, its flat box's worst
            row 54.40 → 54.93 mm); every other scene the same in every figure, shipped suites
            in both modes unchanged. 0: no rebuild.
        heading_rebuild_change_deg: After that rebuild, the maps are rebuilt again (from every
            frame mapped so far, while there are at most `heading_rebuild_frames`) when a later
            estimate moves more than this [deg] from the one they were rebuilt with: an early
            estimate from a short baseline can be off, and the maps otherwise keep it in every
            frame mapped before it (`room` seed 3: a first estimate from the edge score −1.0°,
            the structure score's +1.25° 12 keyframes later; the final maps' heading error,
            `map_heading_deg`, 1.84° on that seed). 0: only the first estimate's rebuild.
            Measured with 1.0 (twice the estimates' 0.5° grid: a settled estimate's
            one-step wobble, the stage's −2.25, −1.75, −2.25°, rebuilds nothing), seeds 1–8,
            session 34: depth (`fogsim suite`) `room`'s `map_heading_deg` 0.82 (1.84) → 0.62
            (1.05)°, its unsafe cells 1.5 (5) → 0.75 (3), the zig-zag stage 0.61 → 0.65°,
            rows unchanged, the stage's sill coverage 0.56 → 0.48 on its worst seed; but in
            stereo (replays) the zig-zag stage's later estimates are the worse ones (its
            `map_heading_deg` 0.49 (1.01) → 0.67 (1.42)°) and `room`'s sill row on seed 2 went
            from 0.3 to 3.65 mm: the latest estimate is not always the better one, so it is off.
            Again at session 53 (1.0, `fogsim suite`, depth, seeds 1–8, unsafe cells mean
            (worst)): the held-out scenes 197.12 → 198.62 in all — `down_slant_turn` seed 8's
            flat box row 49.38 mm → within 1.51 (its first estimate 2.1° off, the later ones
            0.8°), `stairs_40_75_110` seed 1 57 → 28 cells, but `rock_field` 2.88 (15) → 9.62
            (23) (worse on six seeds: its rough rocks pull the later estimates), its map
            heading 0.74 → 1.12°; the shipped suite 37.38 → 38.88 (`stage_offgrid` 6.62 (16) →
            8.0 (23)); issue 11's depth targets held-out 172 → 171 of 210, shipped 229 of 262.
            1.0 since session 54, with `heading_rebuild_refined_only`: only an estimate refined
            point to plane rebuilds again (with `head.plane_refine_estimates` 2, the run's
            second structure estimate). Unrestricted, 1.0 still took `rock_field` depth 2.88
            (15) → 8.88 (23) (seed 8: a later score estimate 1.7° off the one before, from
            frame 180 on, rebuilt the maps with) and the shipped depth suite 37.25 → 38.12.
            Refined only, `fogsim suite`, seeds 1–8, 0 → 1.0, unsafe cells mean (worst) in
            all: held-out depth 184.75 → 185.12 (`down_landing_turn` 13.75 → 14.62 its worst
            case, `down_shallow_steps` 22.00 → 22.12, `down_slant_turn` 63.75 (111) → 63.12
            (104)), but `down_slant_turn` seed 8's flat box row 49.38 mm → within 1.51 mm
            (every held-out depth row within 1.51 mm on every seed), issue 11's targets 174 →
            177 of 210; shipped depth identical in every figure; held-out stereo 428.62 →
            420.75 (`down_shallow_steps` 55.25 (111) → 47.50 (63)), targets 65 met (of 209:
            one check fewer has a value); shipped stereo identical in every figure.
        heading_rebuild_on_structure: When the maps were rebuilt with an estimate of the
            heading's edge score (its stand-in while the structure score has never stood out:
            `HeadingParams.flat_contrast`), rebuild them once more (while at most
            `heading_rebuild_frames` frames were mapped) with the structure score's first
            estimate, the better evidence where it stands out: no change threshold. Replays,
            seeds 1–8, with it and `heading_rebuild_frames` 400 (`room`'s structure estimates
            come at frames 211–330 of 343, after the first rebuild's 300 frames on some
            seeds), session 36: only `room` changes (elsewhere the first estimate is the
            structure score's, or, on `stairs`, it never stands out): depth `map_heading_deg`
            0.82 (1.84) → 0.78 (1.26)° (seed 3 1.84 → 0.32°, but seeds 5 and 6 0.79 / 0.73 →
            1.16 / 1.26°: room depth's structure estimates are themselves 0.3–1.2° off,
            `HeadingParams.voxel_estimate`), unsafe cells 1.5 (5) → 1.5 (3); stereo 0.89
            (1.55) → 0.58 (1.33)° but unsafe cells 9.0 (16) → 10.0 (20) and the sill row 1.02
            (1.87) → 1.59 (3.65) mm (seed 2: 0.26 → 3.65 mm with its heading 0.79 → 0.26°, as
            with `heading_rebuild_change_deg` 1: that seed's sill row is better with the worse
            heading). With `HeadingParams.voxel_estimate` as well, `room` is within 1° on every
            seed (depth 0.51 (0.84)°, stereo 0.49 (0.83)°; unsafe cells 1.5 (5) → 1.4 (8) and
            9.0 (16) → 8.9 (21)), at that option's costs elsewhere. So False until session
            41: with the structure score's first estimate refined point to plane after an
            edge stand-in (`HeadingParams.plane_after_edges`, whose docstring has the replays)
            `room` depth goes 0.72 (1.84) → 0.49 (0.77)°, `talos_course` stereo 45.9 → 41.1
            unsafe cells, `room` stereo 7.0 (13) → 8.5 (19) cells. So True, with
            `heading_rebuild_frames` 400.
        heading_rebuild_refined_only: With `heading_rebuild_change_deg`, only an estimate the
            heading refined point to plane (`mapper.HeadingEstimator.refined`: the run's first
            `head.plane_refine_estimates`, or a witnessed one) rebuilds the maps again; the
            score's own later estimates steer only the frames after them. The refined fit
            counts every keyframe's surface normals, where the score alone slides along a
            surface and is pulled by a rough top's views (`rock_field` seed 8, session 54: a
            later score estimate 1.7° off the one before rebuilt the maps with). True: see
            `heading_rebuild_change_deg` for the measured figures. False: any estimate.
    """

    use_z_match: bool = True
    use_elevation_filter: bool = True
    use_height_reference: bool = True
    event_tolerance_m: float = 0.01
    anchor_shift_m: float = 0.001
    use_tilt_filter: bool = True
    tilt_noise_deg: float = 0.3
    tilt_bias_deg: float = 4.0
    tilt_tail_dof: float = math.inf
    tilt_turn_frames: int = 1
    heading_rebuild_frames: int = 1000
    heading_rebuild_change_deg: float = 1.0
    heading_rebuild_on_structure: bool = True
    heading_rebuild_refined_only: bool = True

    def __post_init__(self) -> None:
        if not self.event_tolerance_m > 0.0:
            raise ParameterError(
                f"PipelineParams.event_tolerance_m must be > 0 m, got {self.event_tolerance_m!r}"
            )
        if not 0.0 <= self.anchor_shift_m < float("inf"):
            raise ParameterError(
                f"PipelineParams.anchor_shift_m must be a finite float >= 0 m, "
                f"got {self.anchor_shift_m!r}"
            )
        for name in ("tilt_noise_deg", "tilt_bias_deg", "heading_rebuild_change_deg"):
            value = getattr(self, name)
            if not 0.0 <= value < float("inf"):
                raise ParameterError(
                    f"PipelineParams.{name} must be a finite float >= 0 deg, got {value!r}"
                )
        if not self.tilt_tail_dof > 0.0:
            raise ParameterError(
                f"PipelineParams.tilt_tail_dof must be a float > 0 (inf: Gaussian), "
                f"got {self.tilt_tail_dof!r}"
            )
        if isinstance(self.tilt_turn_frames, bool) or not (
            isinstance(self.tilt_turn_frames, int) and 1 <= self.tilt_turn_frames <= 100
        ):
            raise ParameterError(
                f"PipelineParams.tilt_turn_frames must be an integer in [1, 100], "
                f"got {self.tilt_turn_frames!r}"
            )
        if isinstance(self.heading_rebuild_frames, bool) or not (
            isinstance(self.heading_rebuild_frames, int)
            and 0 <= self.heading_rebuild_frames <= 10_000
        ):
            raise ParameterError(
                f"PipelineParams.heading_rebuild_frames must be an integer in [0, 10000], "
                f"got {self.heading_rebuild_frames!r}"
            )


def replace_params(params: P, changes: Mapping[str, object], where: str) -> P:
    """A copy of the parameter dataclass ``params`` with ``changes`` applied and validated.

    Each value is typed by the field's current value: a bool field takes true/false (or 1/0),
    an int field an integer (an integral float such as ``120.0`` becomes ``120``), a float field
    any number (kept as given: an int stays an int). The dataclass's own ``__post_init__`` then
    checks ranges and relations between fields.

    Args:
        params: The parameters to start from (e.g. ``MapperParams()``).
        changes: Field name → new value.
        where: Dotted prefix naming the parameters in messages (``"mapper"``).

    Raises:
        ParameterError: An unknown name (the message lists the allowed ones), a value of the
            wrong type or one the dataclass rejects; the message starts with ``<where>.<name>``.
    """
    if not changes:
        return params
    allowed = [f.name for f in dataclasses.fields(params)]  # type: ignore[arg-type]
    unknown = sorted(set(changes) - set(allowed))
    if unknown:
        raise ParameterError(
            f"{where}.{unknown[0]}: unknown {where} parameter(s) {unknown}; allowed: {allowed}"
        )
    typed = {
        name: _typed(value, getattr(params, name), f"{where}.{name}")
        for name, value in changes.items()
    }
    try:
        return dataclasses.replace(params, **typed)  # type: ignore[type-var]
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{_rejected_key(str(exc), params, typed, where)}: {exc}") from exc


def _typed(value: object, current: object, key: str) -> bool | int | float:
    """``value`` as the type of the field whose current value is ``current``."""
    if isinstance(current, bool):
        if isinstance(value, numbers.Real) and value in (0, 1):
            return bool(value)
        raise ParameterError(f"{key}: must be true or false (or 1 / 0), got {shown(value)}")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(f"{key}: must be a number, got {shown(value)}")
    try:
        number = float(value)
    except OverflowError as exc:  # an integer beyond the float range
        raise ParameterError(f"{key}: must be a number, got {shown(value)}") from exc
    if math.isnan(number):
        raise ParameterError(f"{key}: must be a number, got {shown(value)}")
    if isinstance(current, int):
        if not number.is_integer():
            raise ParameterError(f"{key}: must be an integer, got {shown(value)}")
        return int(value)
    return value  # type: ignore[return-value]  # a Real: int or float as given


def _rejected_key(message: str, params: object, changes: Mapping[str, object], where: str) -> str:
    """``<where>.<name>`` of the changed field the dataclass's message names, else ``where``.

    The mapper's parameter classes name the field they reject as ``<Class>.<field>``.
    """
    cls = re.escape(type(params).__name__)
    named = [n for n in changes if re.search(rf"\b{cls}\.{re.escape(n)}\b", message)]
    return f"{where}.{named[0]}" if named else where


@dataclass(frozen=True)
class RunParams:
    """Every parameter of a run (the report's ``params``).

    Attributes:
        mapper: Grid and thresholds (override keys: bare field names or ``mapper.<field>``).
        segmentation: Plane segmentation (``seg.<field>``).
        elevation: Robot elevation filter (``elev.<field>``).
        pipeline: The pipeline's own switches (``pipe.<field>``).
        heading: Camera heading correction (``head.<field>``, `mapper.heading`).
        reference: The camera height reference over frames (``ref.<field>``,
            `mapper.reference`; used with ``pipeline.use_height_reference``).
    """

    mapper: MapperParams = field(default_factory=MapperParams)
    segmentation: SegmentationParams = field(default_factory=SegmentationParams)
    elevation: ElevationFilterParams = field(default_factory=ElevationFilterParams)
    pipeline: PipelineParams = field(default_factory=PipelineParams)
    heading: HeadingParams = field(default_factory=HeadingParams)
    reference: HeightReferenceParams = field(default_factory=HeightReferenceParams)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain ``{"mapper": {...}, "segmentation": {...}, ...}``."""
        return {
            f.name: {
                g.name: getattr(getattr(self, f.name), g.name)
                for g in dataclasses.fields(getattr(self, f.name))
            }
            for f in dataclasses.fields(self)
        }


OVERRIDE_PREFIXES: dict[str, str] = {
    "mapper": "",
    "segmentation": "seg.",
    "heading": "head.",
    "pipeline": "pipe.",
    "reference": "ref.",
    "elevation": "elev.",
}
"""Prefix of each :class:`RunParams` group in override keys (``mapper.`` is also accepted); its
keys, in this order, are also a scenario's parameter tables (`fogsim.config.schema`)."""


def override_key(group: str, name: str) -> str:
    """The override key of a parameter: ``("segmentation", "min_points") -> "seg.min_points"``."""
    return OVERRIDE_PREFIXES[group] + name


def split_override_key(key: str) -> tuple[str, str]:
    """The group and field an override key names (inverse of :func:`override_key`).

    ``"p_occ"`` and ``"mapper.p_occ"`` -> ``("mapper", "p_occ")``; ``"seg.min_points"`` ->
    ``("segmentation", "min_points")``.
    """
    if key.startswith("mapper."):
        return "mapper", key[len("mapper.") :]
    for group, prefix in OVERRIDE_PREFIXES.items():
        if prefix and key.startswith(prefix):
            return group, key[len(prefix) :]
    return "mapper", key


def resolve_params(
    scenario: Scenario | None,
    overrides: Mapping[str, float] | None = None,
    sensor: Mapping[str, float | int] | None = None,
) -> RunParams:
    """Parameters: defaults ← sensor ← the scenario's parameter tables ← overrides.

    Args:
        scenario: A Scenario (its ``[mapper]``, ``[segmentation]``, ``[heading]``,
            ``[pipeline]``, ``[reference]`` and ``[elevation]`` tables) or None.
        sensor: The head's parameters (:func:`fogsim.run.runner.sensor_fields`), below the
            scenario's tables: ``SegmentationParams`` fields (the camera's noise model) by
            name, other groups' with their override prefix (``"ref.<field>"``).
        overrides: Keys ``"<mapper field>"`` (e.g. ``"p_occ"``, or ``"mapper.p_occ"``),
            ``"seg.<field>"``, ``"elev.<field>"``, ``"pipe.<field>"``, ``"head.<field>"``
            and ``"ref.<field>"``.

    Raises:
        ParameterError: An unknown key (the message lists the allowed ones) or a bad value.
    """
    head: dict[str, dict[str, object]] = {}
    for key, value in (sensor or {}).items():
        group, name = split_override_key(key) if "." in key else ("segmentation", key)
        head.setdefault(group, {})[name] = value
    changes: dict[str, dict[str, object]] = {
        group: head.pop(group, {}) | (dict(getattr(scenario, group)) if scenario else {})
        for group in OVERRIDE_PREFIXES
    }
    for key, value in (overrides or {}).items():
        group, name = split_override_key(key)
        changes[group][name] = value
    defaults = RunParams()
    return RunParams(
        **{
            group: replace_params(getattr(defaults, group), values, group)
            for group, values in changes.items()
        }
    )
