"""The short text summary of a report that ``fogsim run`` prints."""

from __future__ import annotations

from fogsim.eval.report.schema import Report

NO_TRUTH = "Table I: no ground truth (nothing to score)."


def _num(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


def format_table1(report: Report) -> str:
    """Table I (FOG and averaging side by side), cell accuracy and event clearing, as text."""
    if report.table1 is None or not report.table1.fog:
        return NO_TRUTH
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
    for event in report.events:
        lines.append(
            f"{event.kind} {event.object}: footprint cleared after "
            f"FOG {event.fog_frames} / averaging {event.averaging_frames} frames"
        )
    return "\n".join(lines)
