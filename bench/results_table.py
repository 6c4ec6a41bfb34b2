"""The README's per-scenario Results table from one ``fogsim suite --seeds`` run's summary.

One row per scenario, worst first (by the worst seed of its worst Table I row, then by name):
the worst Table I row [mm] (highest worst seed, then mean) as mean (worst seed), the
lowest Table I coverage [%] of a surface other than the ground, floor recall and precision,
obstacle recall and precision [%], unsafe cells, the events' frames, and the residual camera
heading [deg] as each frame was processed, as it was last mapped (robot frame) and in the world
(``pose_error.world_heading_deg``: what the maps hold, odometry's yaw included). A figure the
runs do not have is ``–``.

Usage::

    fogsim suite --seeds 1-8 --out runs/suite
    python bench/results_table.py runs/suite/summary.json
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Mapping
from pathlib import Path

from fogsim.errors import ReportError
from fogsim.eval.report.io import load_json
from fogsim.run.seeds import FigureStats
from fogsim.run.suite import SuiteSummary

HEADER = (
    "| scenario | worst Table I row [mm]: mean (worst seed) | lowest Table I coverage % (not "
    "ground) | floor recall % | floor precision % | obstacle recall % | obstacle precision % | "
    "unsafe cells | events [frames] | residual heading ° as processed | as last mapped | in the "
    "world |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
)
"""The table's header and separator lines."""


def _pair(stats: FigureStats, fmt: str, scale: float = 1.0) -> str:
    return f"{stats.mean * scale:{fmt}} ({stats.worst * scale:{fmt}})"


def _rows_of(figures: Mapping[str, FigureStats], metric: str) -> dict[str, FigureStats]:
    """Table I rows' ``metric`` figures by surface name, in the summary's order."""
    return {
        key.split(".")[1]: stats
        for key, stats in figures.items()
        if key.startswith("table1.") and key.endswith("." + metric)
    }


def row(name: str, figures: Mapping[str, FigureStats]) -> tuple[float, str]:
    """The scenario's sort key (its worst row's worst seed) and its table row."""
    errors = _rows_of(figures, "abs_error_mm")
    worst = max(
        errors, key=lambda surface: (errors[surface].worst, errors[surface].mean), default=None
    )
    cells = [f"`{name}`"]
    cells.append("–" if worst is None else f"{worst} {_pair(errors[worst], '.2f')}")
    coverage = {k: v for k, v in _rows_of(figures, "coverage").items() if k != "ground"}
    lowest = min(coverage, key=lambda surface: coverage[surface].mean, default=None)
    cells.append("–" if lowest is None else f"{lowest} {_pair(coverage[lowest], '.0f', 100.0)}")
    for key in ("floor_recall", "floor_precision", "obstacle_recall", "obstacle_precision"):
        stats = figures.get(f"cells.{key}")
        cells.append("–" if stats is None else _pair(stats, ".1f", 100.0))
    unsafe = figures.get("safety.unsafe_cells")
    cells.append("–" if unsafe is None else _pair(unsafe, ".0f"))
    events = []
    for key, stats in figures.items():
        if key.startswith("events."):
            what = "cleared" if key.endswith("cleared_frames") else "floor again"
            events.append(f"{what} {_pair(stats, '.3g')}")
    cells.append("; ".join(events) or "–")
    for key in ("residual_heading_deg", "map_heading_deg", "world_heading_deg"):
        stats = figures.get(f"pose_error.{key}.median")
        cells.append("–" if stats is None else _pair(stats, ".2f"))
    return (-errors[worst].worst if worst is not None else 0.0), "| " + " | ".join(cells) + " |"


def main() -> None:
    """Print the table of the summary given on the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("summary", type=Path, help="a suite's summary.json")
    args = parser.parse_args()
    try:
        summary = load_json(args.summary, SuiteSummary, "summary")
    except ReportError as error:  # bad input: the message and exit code 2, no traceback
        print(f"results_table: {error}", file=sys.stderr)
        raise SystemExit(2) from None
    rows = {name: row(name, scenario.figures) for name, scenario in summary.scenarios.items()}
    print(HEADER)
    for name in sorted(rows, key=lambda name: (rows[name][0], name)):
        print(rows[name][1])


if __name__ == "__main__":
    main()
