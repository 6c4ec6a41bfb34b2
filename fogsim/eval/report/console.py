"""The short text summary of a report that ``fogsim run`` prints."""

from __future__ import annotations

from itertools import groupby

from msgspec import UnsetType

from fogsim.eval.report.schema import PoseErrorStats, Report, Safety, StepEdge

NO_TRUTH = "Table I: no ground truth (nothing to score)."


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"


def _safety_line(safety: Safety) -> str:
    errors = safety.floor_height_error_mm
    return (
        f"unsafe cells: {safety.unsafe_cells} ({safety.floor_on_obstacle} floor on obstacle, "
        f"{safety.floor_height_off} floor off > {safety.height_tolerance_mm:.0f} mm); "
        f"floor height error p50 {_num(errors.p50)} / p95 {_num(errors.p95)} / "
        f"max {_num(errors.max)} mm"
    )


def _pose_line(pose: PoseErrorStats) -> str | None:
    """The tilt and heading the corrections left, or None when the report has neither."""
    tilt, heading = pose.residual_tilt_deg, pose.map_heading_deg
    if isinstance(tilt, UnsetType) or isinstance(heading, UnsetType):
        return None
    return (
        f"camera left by the corrections (as mapped; every frame in frames.csv): "
        f"tilt median {_deg(tilt.median)} / p95 {_deg(tilt.p95)} / max {_deg(tilt.max)}°, "
        f"heading median {_deg(heading.median)} / max {_deg(heading.max)}°"
    )


def _deg(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def _step_edge_lines(edges: tuple[StepEdge, ...]) -> list[str]:
    lines = [
        "step edges, median / max |error| mm (+ = toward the higher side),"
        " [nearest edge the map allows, undecided band] mm:"
    ]
    for surface, rows in groupby(edges, key=lambda edge: edge.surface):
        lines.append(
            f"  {surface}: "
            + "  ".join(
                f"{row.edge} {_num(row.median_error_mm)} / {_num(row.max_abs_error_mm)}"
                + _edge_band(row)
                for row in rows
            )
        )
    return lines


def _edge_band(row: StepEdge) -> str:
    """`` [nearest, gap]`` of an edge, or nothing for a report from before those figures."""
    nearest, gap = row.median_nearest_error_mm, row.median_gap_mm
    if isinstance(nearest, UnsetType) or isinstance(gap, UnsetType):
        return ""
    return f" [{_num(nearest)}, {_num(gap)}]"


def format_warnings(report: Report) -> list[str]:
    """One ``WARNING`` line per reason the run is poor (none for a good run)."""
    return [f"WARNING: poor run: {reason}" for reason in report.quality.reasons]


def format_table1(report: Report) -> str:
    """The run's figures as text, one compact line each.

    Table I (FOG and averaging side by side), cell accuracy, per-class recall and precision,
    unsafe cells, step edges, the tilt and heading the corrections left, objects never seen,
    the ceiling, the events (``cleared`` and ``floor again``), and a WARNING line per reason
    the run is poor (also without ground truth).
    """
    if report.table1 is None or not report.table1.fog:
        return "\n".join([NO_TRUTH, *format_warnings(report)])
    averaging = {row.name: row for row in report.table1.averaging}
    lines = [
        f"{'floor':<16}{'truth mm':>10}{'FOG mm':>10}{'err':>8}{'cells':>7}"
        f"{'avg mm':>10}{'err':>8}",
    ]
    for row in report.table1.fog:
        other = averaging.get(row.name)
        lines.append(
            f"{row.name:<16}{_num(row.ground_truth_mm):>10}{_num(row.estimated_mm):>10}"
            f"{_num(row.error_mm):>8}{row.cells:>7}"
            f"{_num(other.estimated_mm if other else None):>10}"
            f"{_num(other.error_mm if other else None):>8}"
        )
    if report.cells is not None and report.cells.fog.accuracy is not None:
        fog = report.cells.fog
        lines.append(f"cells labelled right: {100 * fog.accuracy:.1f} % of {fog.seen} seen")
        floor, obstacle = fog.classes.floor, fog.classes.obstacle
        lines.append(
            f"floor: recall {_pct(floor.recall)}, precision {_pct(floor.precision)}; "
            f"obstacle: recall {_pct(obstacle.recall)}, precision {_pct(obstacle.precision)}"
        )
    if report.safety is not None:
        lines.append(_safety_line(report.safety))
    if report.step_edges:
        lines.extend(_step_edge_lines(report.step_edges))
    pose_line = _pose_line(report.pose_error)
    if pose_line is not None:
        lines.append(pose_line)
    if report.unseen_objects:
        lines.append(f"never seen: {', '.join(report.unseen_objects)}")
    if report.ceiling is not None:
        ceiling = report.ceiling
        lines.append(
            f"ceiling: {ceiling.cells} cells, |error| median {_num(ceiling.median_abs_error_mm)}"
            f" / max {_num(ceiling.max_abs_error_mm)} mm"
        )
    lines.extend(event.text() for event in report.events)
    lines.extend(format_warnings(report))
    return "\n".join(lines)
