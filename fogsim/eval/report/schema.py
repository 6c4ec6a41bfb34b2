"""The typed ``report.json``: frozen dataclasses whose fields are the file's keys, in order.

Each class below is one JSON object of the report; its fields are that object's keys in the
order they are written, so :func:`fogsim.eval.report.io.write_report` needs no key mapping and
:func:`fogsim.eval.report.io.load_report` checks every key and type while decoding. Lengths are
in millimetres, times in ms or s as named. ``None`` is JSON ``null`` (not available, never, no
cell to measure); a field whose default is ``UNSET`` is a key that only some reports have.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from msgspec import UNSET, UnsetType

REPORT_FORMAT = "fogsim-report"
REPORT_VERSION = 2

Source = Literal["simulation", "replay"]
"""Where the frames came from: a simulation, or a recording replayed."""

ParamValue = bool | int | float | None
"""One parameter's value as JSON holds it (``None`` for an infinite limit such as
``max_range_m``)."""


@dataclass(frozen=True)
class Table1Row:
    """Estimated vs true height of one walkable surface (a row of the paper's Table I).

    Attributes:
        name: Surface name (``ground`` or a walkable object).
        ground_truth_mm: True top height [mm].
        estimated_mm: Median estimated floor height over the surface's interior cells that the
            map has [mm]; None when no cell was used.
        error_mm: ``estimated_mm - ground_truth_mm`` [mm]; None when no cell was used.
        cells: Interior cells whose estimate was used.
        surface_cells: Interior cells of the surface in the scored area.
    """

    name: str
    ground_truth_mm: float | None
    estimated_mm: float | None
    error_mm: float | None
    cells: int
    surface_cells: int


@dataclass(frozen=True)
class Table1:
    """Table I of both maps: one row per walkable surface and the ground, in surface order."""

    fog: tuple[Table1Row, ...]
    averaging: tuple[Table1Row, ...]


@dataclass(frozen=True)
class ErrorStats:
    """Statistics of absolute height errors over cells (None when no cell has a finite error).

    Attributes:
        cells: Cells with a finite error.
        median_abs_error_mm: Median absolute error [mm].
        p95_abs_error_mm: 95th percentile [mm].
        max_abs_error_mm: Largest absolute error [mm].
    """

    cells: int
    median_abs_error_mm: float | None
    p95_abs_error_mm: float | None
    max_abs_error_mm: float | None


@dataclass(frozen=True)
class ObstacleHeightStats(ErrorStats):
    """Obstacle-top errors of FOG obstacle cells over true obstacles.

    Attributes:
        within_one_cell_fraction: Share of them within one layer of the true top (None when
            there is none).
    """

    within_one_cell_fraction: float | None


@dataclass(frozen=True)
class ConfusionRow:
    """FOG labels of the cells of one true label, over the scored region (unknown included)."""

    unknown: int
    floor: int
    obstacle: int


@dataclass(frozen=True)
class Confusion:
    """Truth label → FOG label → cell count."""

    floor: ConfusionRow
    obstacle: ConfusionRow


@dataclass(frozen=True)
class ClassScores:
    """How well the FOG finds one class (floor or obstacle), over the seen cells.

    Only cells the FOG labels floor or obstacle count: a cell it leaves unknown is in neither
    figure (``cells.fog.in_view_seen`` says how much it leaves unknown).

    Attributes:
        truth_seen: Seen cells whose truth is this class.
        labelled: Seen cells the FOG labels this class.
        true_positive: Seen cells of this class in both.
        recall: ``true_positive / truth_seen``: the share of the class the FOG finds (None when
            no seen cell is of the class).
        precision: ``true_positive / labelled``: the share of the FOG's labels that are right
            (None when the FOG labels no cell so).
    """

    truth_seen: int
    labelled: int
    true_positive: int
    recall: float | None
    precision: float | None


@dataclass(frozen=True)
class FogClasses:
    """Recall and precision of the FOG's two labels."""

    floor: ClassScores
    obstacle: ClassScores


@dataclass(frozen=True)
class FogCellScores:
    """Cell labels and heights of the FOG against the truth.

    Attributes:
        region: Cells scored (those that were ever inside the map).
        in_view: Region cells the camera saw: a depth measurement, placed with the true camera
            pose, fell into the cell within the grid's height range in some frame.
        seen: Region cells the FOG labels floor or obstacle.
        in_view_seen: Cells in view that the FOG labels floor or obstacle (the rest of
            ``in_view`` it saw but left unknown).
        correct: Seen cells labelled as the truth.
        accuracy: ``correct / seen`` (None when nothing was seen).
        interior_seen: Seen cells that are interior (whole cell on one surface).
        interior_accuracy: Accuracy over those (None when there is none).
        confusion: Truth label → FOG label → count.
        classes: Recall and precision of floor and obstacle over the seen cells.
        obstacle_height: Obstacle-top errors.
        floor_height: Floor-height errors of FOG floor cells over true floor.
    """

    region: int
    in_view: int
    seen: int
    in_view_seen: int
    correct: int
    accuracy: float | None
    interior_seen: int
    interior_accuracy: float | None
    confusion: Confusion
    classes: FogClasses
    obstacle_height: ObstacleHeightStats
    floor_height: ErrorStats


@dataclass(frozen=True)
class ObstacleObjectScore:
    """How much of one obstacle object (not walkable, or hanging) the FOG marks obstacle.

    Attributes:
        name: The object's name.
        cells: Cells whose centre lies inside its footprint, half a cell in from the edge.
        seen: Of those, labelled floor or obstacle.
        obstacle_fraction: Of the seen ones, the share labelled obstacle (None if none seen).
        top_mm: True top [mm].
        median_top_error_mm: Median FOG obstacle height − true top [mm] (None if no obstacle
            cell).
    """

    name: str
    cells: int
    seen: int
    obstacle_fraction: float | None
    top_mm: float | None
    median_top_error_mm: float | None


@dataclass(frozen=True)
class AveragingCellScores:
    """The averaging baseline's cells (it has heights, no labels).

    Attributes:
        seen: Region cells with a baseline height.
        floor_height: Height errors of those that are true floor.
    """

    seen: int
    floor_height: ErrorStats


@dataclass(frozen=True)
class CellScores:
    """Per-cell scores of both maps and per obstacle object."""

    fog: FogCellScores
    obstacles: tuple[ObstacleObjectScore, ...]
    averaging: AveragingCellScores


@dataclass(frozen=True)
class Percentiles:
    """Percentiles of an absolute error [mm] over cells (None when no cell has one)."""

    p50: float | None
    p90: float | None
    p95: float | None
    p99: float | None
    max: float | None


@dataclass(frozen=True)
class Safety:
    """FOG floor cells a robot could not safely stand on (DESIGN.md "Ground truth").

    A cell is *unsafe* when the FOG labels it floor and either the truth is obstacle there
    (``floor_on_obstacle``) or the truth is floor more than ``height_tolerance_mm`` away from
    the FOG's height (``floor_height_off``). Over the scored region (cells ever in the map).

    Attributes:
        unsafe_cells: ``floor_on_obstacle + floor_height_off``.
        floor_on_obstacle: FOG floor where the truth is obstacle.
        floor_height_off: FOG floor on true floor, height off by more than the tolerance.
        height_tolerance_mm: The tolerance [mm] (20: a step a foot can stumble on).
        positions_xy_m: World (x, y) cell centres [m] of the unsafe cells, worst first (the
            largest height gap between the FOG's floor and the true top there: the floor's for
            floor cells, the obstacle's for obstacle cells), at most 200.
        floor_height_error_mm: Absolute floor-height error [mm] of FOG floor on true floor.
    """

    unsafe_cells: int
    floor_on_obstacle: int
    floor_height_off: int
    height_tolerance_mm: float
    positions_xy_m: tuple[tuple[float, float], ...]
    floor_height_error_mm: Percentiles


@dataclass(frozen=True)
class StepEdge:
    """Where the FOG puts one edge of a walkable surface, against the true edge.

    Table I leaves a surface's border cells out; this is about exactly those. The edge is one
    side of the object's footprint, named in the object's own frame (the world's when its yaw
    is 0): ``x_min``, ``x_max``, ``y_min``, ``y_max``. Along the edge, one cell apart (its end
    cells left out), the map's edge is where the FOG floor changes from the surface's height to
    its neighbour's, looking up to 0.2 m to either side along the edge normal (cells labelled
    obstacle or unknown in between put it in the middle of the gap). Only positions where the
    true heights on the two sides differ by at least 10 mm count; an edge with none, or with no
    cell seen, is not listed.

    Attributes:
        surface: The walkable object's name.
        edge: ``x_min``, ``x_max``, ``y_min`` or ``y_max``.
        cells: Positions along the edge where the map shows the step.
        median_error_mm: Median signed error [mm] along the edge normal, **+ = toward the
            higher side** (a riser the map puts toward a robot walking up is negative); None
            when the map shows the step nowhere along the edge.
        max_abs_error_mm: Largest absolute error [mm]; None likewise.
        median_nearest_error_mm: Median over the positions of the error of the edge nearest
            the true one that agrees with the map as well as the middle does [mm], signed as
            ``median_error_mm``: a band the map leaves unknown or obstacle between the two
            surfaces' floors may hold the edge anywhere, so this is 0 where the true edge lies
            in it and the map's floors reach past it nowhere; a surface's floor carried over
            the edge counts in full. None likewise; missing in reports before it.
        median_gap_mm: Median width of that band [mm] (0 where the two floors touch): what
            the map leaves undecided at the edge (a shadow behind a rise, a riser's face, a
            rim left unknown). None likewise; missing in reports before it.
    """

    surface: str
    edge: str
    cells: int
    median_error_mm: float | None
    max_abs_error_mm: float | None
    median_nearest_error_mm: float | UnsetType | None = UNSET
    median_gap_mm: float | UnsetType | None = UNSET


@dataclass(frozen=True)
class CeilingScores:
    """The ceiling map (lowest thing above the floor) against the true ceiling.

    Attributes:
        cells: Region cells where both the truth and the map have a ceiling.
        median_abs_error_mm: Median absolute ceiling error [mm] (None without cells).
        max_abs_error_mm: Largest absolute ceiling error [mm] (None without cells).
    """

    cells: int
    median_abs_error_mm: float | None
    max_abs_error_mm: float | None


@dataclass(frozen=True)
class Quality:
    """Whether the run's figures can be trusted at all (:mod:`fogsim.eval.report.quality`).

    Attributes:
        withdrawn_fraction: Frames withdrawn by the z-match rule / frames.
        frames_without_ground_plane: Frames whose segmentation found no ground plane (with z
            matching on, each of them is z-matched to the map or withdrawn).
        map_empty: The FOG labelled no cell floor or obstacle in the whole run.
        floor_right_fraction: Of the seen cells that are true floor, the share the FOG labels
            floor within 20 mm of the true height (None without ground truth or such cells).
        poor: One of the limits below is crossed.
        reasons: One sentence per crossed limit (the console prints each as a WARNING).
    """

    withdrawn_fraction: float
    frames_without_ground_plane: int
    map_empty: bool
    floor_right_fraction: float | None
    poor: bool
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class ArchiveScores:
    """Everything scored on the run's archive against the final truth.

    Attributes:
        table1: Table I of both maps.
        cells: Cell scores.
        safety: Unsafe FOG floor cells.
        step_edges: One row per edge of a walkable surface in view.
        unseen_objects: Objects present at the end none of whose cells the FOG ever labelled.
        ceiling: Ceiling errors where the truth has a ceiling in the region, else None.
    """

    table1: Table1
    cells: CellScores
    safety: Safety
    step_edges: tuple[StepEdge, ...]
    unseen_objects: tuple[str, ...]
    ceiling: CeilingScores | None


@dataclass(frozen=True)
class MaxFinal:
    """A per-frame cell count: its largest value and its value at the last frame."""

    max: int
    final: int


@dataclass(frozen=True)
class IntermediateFloorCells:
    """Floor cells between the floor and a moved object's old top, per map."""

    fog: MaxFinal
    averaging: MaxFinal


@dataclass(frozen=True)
class EventFrames:
    """One event figure of both maps, in frames from the event's start frame.

    None = never; also None when the map never saw the object before the event
    (:class:`EventSeen` tells the two apart).
    """

    fog: int | None
    averaging: int | None

    def text(self, seen: EventSeen) -> str:
        """Both maps' figure as text: ``FOG 12 / averaging never`` (or ``not seen``)."""
        return (
            f"FOG {_frames_text(self.fog, seen.fog)} / "
            f"averaging {_frames_text(self.averaging, seen.averaging)}"
        )


def _frames_text(frames: int | None, seen: bool) -> str:
    """One map's event figure: the frame count, ``never``, or ``not seen`` (no figure)."""
    if not seen:
        return "not seen"
    return "never" if frames is None else str(frames)


@dataclass(frozen=True)
class EventSeen:
    """Per map, whether it showed the object on its footprint in a frame before the event."""

    fog: bool
    averaging: bool


@dataclass(frozen=True)
class EventResult:
    """How fast each map forgot a removed or moved object (:mod:`fogsim.eval.events`).

    Attributes:
        object: The object's name.
        kind: ``remove`` or ``move``.
        at_s: Event time [s].
        start_frame: First frame at or after the event (None if the run ended before it).
        footprint_cells: Cells of the object's own footprint: its cells at the event (and, for a
            move, the cells it slid over, less those it covers at the end) that no other object
            covers from the event on.
        excluded_cells: Cells of the object's that were left out of the footprint because
            another object covers them from the event on.
        old_top_mm: The object's top [mm] (None without footprint).
        seen: Per map, whether it showed the object on its footprint before the event; a map
            that did not gets no figure.
        cleared_frames: Frames until no footprint cell shows the object (no obstacle, no height
            nearer its top than the floor).
        floor_again_frames: Frames until at least 90 % of the footprint is floor within 10 mm
            of the true height.
        intermediate_floor_cells: Moves only: floor cells at heights between the floor and the
            object's top in the footprint.
    """

    object: str
    kind: Literal["remove", "move"]
    at_s: float
    start_frame: int | None
    footprint_cells: int
    excluded_cells: int
    old_top_mm: float | None
    seen: EventSeen
    cleared_frames: EventFrames
    floor_again_frames: EventFrames
    intermediate_floor_cells: IntermediateFloorCells | UnsetType = UNSET

    def text(self) -> str:
        """The event's figures in the words of the report, for the console and the pictures.

        ``remove box (63 cells): cleared FOG 12 / averaging never; floor again FOG 9 /
        averaging never (frames after the event)``.
        """
        head = f"{self.kind} {self.object} ({self.footprint_cells} cells)"
        if self.start_frame is None:
            return f"{head}: the run ended before the event"
        return (
            f"{head}: cleared {self.cleared_frames.text(self.seen)}; "
            f"floor again {self.floor_again_frames.text(self.seen)} (frames after the event)"
        )


@dataclass(frozen=True)
class TimeStats:
    """Median, 99th percentile and maximum of a per-frame time [ms] (None without frames)."""

    median: float | None
    p99: float | None
    max: float | None


@dataclass(frozen=True)
class Timing:
    """Frame counts and times of the run.

    Attributes:
        frames: Frames processed.
        withdrawn_frames: Frames withdrawn by the z-match rule.
        z_matched_frames: Frames shifted by an accepted z match.
        update_ms: ``FloorObstacleMapper.update`` per applied frame [ms].
        segmentation_ms: ``segment_depth`` per frame [ms].
        frame_ms: Whole pipeline per frame, scoring excluded [ms].
        wall_s: Wall time of the run [s] (incl. setup when the caller measured it).
        realtime_factor: Simulated duration / wall time (None when unknown).
        pictures_s: Time writing the pictures [s]; only when pictures were written.
    """

    frames: int
    withdrawn_frames: int
    z_matched_frames: int
    update_ms: TimeStats
    segmentation_ms: TimeStats
    frame_ms: TimeStats
    wall_s: float
    realtime_factor: float | None
    pictures_s: float | UnsetType = UNSET


@dataclass(frozen=True)
class MedianMax:
    """Median and maximum of a per-frame error."""

    median: float | None
    max: float | None


@dataclass(frozen=True)
class MedianP95Max:
    """Median, 95th percentile and maximum of a per-frame error."""

    median: float | None
    p95: float | None
    max: float | None


@dataclass(frozen=True)
class PoseErrorPair:
    """Rotation [deg] and translation [mm] errors of a believed pose."""

    rotation_deg: MedianMax
    translation_mm: MedianMax


@dataclass(frozen=True)
class PoseErrorStats:
    """Believed-vs-true camera pose over the frames that have a true pose.

    Attributes:
        frames: Frames compared (0 without true poses: then the other keys are absent).
        camera_in_robot: Camera in the robot frame: what the encoders cause (the paper's 7° and
            10 mm).
        camera_in_world: Camera in the world: encoders plus odometry drift.
        residual_heading_deg: |Yaw| [deg] of the camera orientation after the pipeline's
            corrections (tilt, heading) against the true one, in the robot frame, as each frame
            was corrected when it was processed: the heading error the maps had at that
            moment (absent when no frame gave a corrected pose).
        map_heading_deg: The same as each frame was last mapped: the heading error the final
            maps hold. Lower than ``residual_heading_deg`` where frames mapped before the
            heading's first estimate were mapped again with it (`pipe.heading_rebuild_frames`);
            present with ``residual_heading_deg``.
        world_heading_deg: |Yaw| [deg] of the camera orientation as each frame was last
            mapped, brought into the world by the *believed* robot pose, against the true
            camera orientation in the world: ``map_heading_deg`` plus odometry's yaw error at
            the frame, the heading error of the maps (built in odometry's world, scored in the
            true one); present with ``residual_heading_deg``.
        residual_tilt_deg: Angle [deg] between the vertical of the camera pose each frame was
            last mapped with (the pipeline's tilt and heading corrections applied) and the true
            vertical, robot frame: the tilt the corrections left, over the frames mapped with a
            corrected pose (deferred frames included). Its 95th percentile shows a run of frames
            whose tilt went wrong (stereo: planes joining a tread and the ground beside it),
            which the median hides. Absent when no frame was mapped with a corrected pose.
    """

    frames: int
    camera_in_robot: PoseErrorPair | UnsetType = UNSET
    camera_in_world: PoseErrorPair | UnsetType = UNSET
    residual_heading_deg: MedianMax | UnsetType = UNSET
    map_heading_deg: MedianMax | UnsetType = UNSET
    world_heading_deg: MedianMax | UnsetType = UNSET
    residual_tilt_deg: MedianP95Max | UnsetType = UNSET


@dataclass(frozen=True)
class ParamTables:
    """The parameters used, one table per parameter group, name → value."""

    mapper: dict[str, ParamValue]
    segmentation: dict[str, ParamValue]
    elevation: dict[str, ParamValue]
    pipeline: dict[str, ParamValue]
    heading: dict[str, ParamValue] | UnsetType = UNSET
    reference: dict[str, ParamValue] | UnsetType = UNSET


@dataclass(frozen=True)
class Report:
    """One run's results, as ``report.json`` holds them (DESIGN.md "Results").

    Attributes:
        format: Always ``fogsim-report``.
        version: Schema version, 2.
        scenario: Scenario name (None for real data).
        seed: Scenario seed (None for real data).
        source: ``simulation`` or ``replay``.
        quality: Withdrawn frames, frames without a ground plane, an empty map; ``poor``.
        table1: Table I of both maps (None without ground truth).
        cells: Cell scores (None without ground truth).
        safety: Unsafe FOG floor cells (None without ground truth).
        step_edges: Edge position errors of the walkable surfaces in view (empty without
            ground truth).
        unseen_objects: Objects present at the end that the FOG never labelled (empty without
            ground truth).
        ceiling: Ceiling errors where the scene has something hanging in the mapped area
            (None otherwise or without ground truth).
        events: One result per removed or moved object.
        timing: Frame counts and times.
        pose_error: Believed-vs-true camera pose error.
        params: Parameters used.
        versions: Python's and key packages' versions (None = not installed).
        pictures: File names of the pictures written (only when written).
        video: File name of the video (only when written).
        video_codec: The video's codec and encoder, ``h264 (libx264)``, or ``mpeg4 (opencv
            mp4v)`` where no H.264 encoder is installed (only when a video was written).
    """

    format: Literal["fogsim-report"]
    version: Literal[2]
    scenario: str | None
    seed: int | None
    source: Source
    quality: Quality
    table1: Table1 | None
    cells: CellScores | None
    safety: Safety | None
    step_edges: tuple[StepEdge, ...]
    unseen_objects: tuple[str, ...]
    ceiling: CeilingScores | None
    events: tuple[EventResult, ...]
    timing: Timing
    pose_error: PoseErrorStats
    params: ParamTables
    versions: dict[str, str | None]
    pictures: tuple[str, ...] | UnsetType = UNSET
    video: str | UnsetType = UNSET
    video_codec: str | UnsetType = UNSET
