"""``report.json``: the run's results exactly as DESIGN.md "Results" lists them.

Top-level keys (all lengths in mm, times in ms or s as named; null = not available):

* ``format``: ``"fogsim-report"``, ``version``: 1.
* ``scenario``: scenario name (null for real data), ``seed``, ``source``
  (``"simulation"`` / ``"replay"``).
* ``table1``: ``{"fog": rows, "averaging": rows}``, one row per walkable surface and the ground:
  ``name``, ``ground_truth_mm``, ``estimated_mm`` (median floor height over the surface's
  interior cells — border cells left out — that the map has: FOG floor cells, or any
  baseline height), ``error_mm`` (estimated − truth), ``cells`` (cells used),
  ``surface_cells`` (interior cells of the surface in the mapped area).
* ``cells``: ``fog``: over the cells that were ever inside the map: ``seen`` (labelled floor or
  obstacle), ``correct``, ``accuracy`` (= correct / seen), interior-only variants,
  ``confusion`` (truth → FOG label → count), ``obstacle_height`` and ``floor_height`` absolute
  error stats (median, p95, max [mm]; obstacles also ``within_one_cell_fraction``);
  ``averaging``: ``seen`` and ``floor_height`` stats of the baseline.
* ``events``: per removed / moved object, frames from the event until its old footprint is
  cleared (``fog_frames``, ``averaging_frames``; null = never) and until 90 % of it is floor at
  the true height (``*_frames_to_floor``); moves add ``intermediate_floor_cells``.
* ``timing``: ``frames``, ``withdrawn_frames``, ``z_matched_frames``, ``update_ms``,
  ``segmentation_ms`` and ``frame_ms`` (``median``, ``p99``, ``max``), ``wall_s``
  (whole run incl. setup when the caller passes it), ``realtime_factor``.
* ``pose_error``: believed-vs-true camera pose: ``camera_in_robot`` (encoder errors, the
  paper's "7° and 10 mm") and ``camera_in_world`` (with odometry drift), each
  ``rotation_deg`` / ``translation_mm`` ``{median, max}``.
* ``params``: ``mapper``, ``segmentation``, ``pipeline`` parameters used.
* ``versions``: Python and package versions.
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import os
import platform
from pathlib import Path
from typing import Any

import numpy as np

from fogsim.atomic import write_text_atomic

REPORT_FORMAT = "fogsim-report"
REPORT_VERSION = 1
_PACKAGES = ("fogsim", "numpy", "numba", "mujoco", "dm-control", "opencv-python-headless", "pin")


def package_versions() -> dict[str, str | None]:
    """Python and key package versions (None for a package that is not installed)."""
    versions: dict[str, str | None] = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = None
    return versions


def _stats_ms(values: np.ndarray) -> dict[str, float | None]:
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if not v.size:
        return {"median": None, "p99": None, "max": None}
    return {
        "median": round(float(np.median(v)), 4),
        "p99": round(float(np.percentile(v, 99)), 4),
        "max": round(float(np.max(v)), 4),
    }


def _plain(value: Any) -> Any:
    """JSON-able copy: numpy scalars → Python, NaN/inf → None, tuples → lists."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def build_report(
    result: Any,
    scenario: Any | None,
    *,
    source: str = "simulation",
    wall_s: float | None = None,
    duration_s: float | None = None,
) -> dict:
    """Assemble the report dict of a :class:`fogsim.eval.result.RunResult`.

    Args:
        result: The run's result.
        scenario: The scenario (name, seed), or None for real data.
        source: ``"simulation"`` or ``"replay"``.
        wall_s: Whole-run wall time incl. setup [s]; default the pipeline's own wall time.
        duration_s: Simulated duration [s] of the run, for ``realtime_factor``.
    """
    wall = float(result.wall_s if wall_s is None else wall_s)
    scores = result.scores or {}
    timing = {
        "frames": int(result.frames),
        "withdrawn_frames": int(result.withdrawn),
        "z_matched_frames": int(result.z_matched),
        "update_ms": _stats_ms(result.update_ms),
        "segmentation_ms": _stats_ms(result.segmentation_ms),
        "frame_ms": _stats_ms(result.frame_ms),
        "wall_s": round(wall, 3),
        "realtime_factor": (
            round(float(duration_s) / wall, 3) if duration_s and wall > 0 else None
        ),
    }
    report = {
        "format": REPORT_FORMAT,
        "version": REPORT_VERSION,
        "scenario": getattr(scenario, "name", None),
        "seed": getattr(scenario, "seed", None),
        "source": source,
        "table1": scores.get("table1"),
        "cells": scores.get("cells"),
        "events": result.events,
        "timing": timing,
        "pose_error": result.pose_error,
        "params": result.params,
        "versions": package_versions(),
    }
    return _plain(report)


def write_report(path: str | os.PathLike[str], report: dict) -> Path:
    """Write a report as indented JSON, atomically (NaN written as null)."""
    text = json.dumps(_plain(report), indent=2, allow_nan=False) + "\n"
    return write_text_atomic(path, text)


def load_report(path: str | os.PathLike[str]) -> dict:
    """Read a report.json."""
    return json.loads(Path(path).read_text(encoding="utf-8"))


def format_table1(report: dict) -> str:
    """Short text Table I (FOG and averaging side by side), as printed after ``fogsim run``."""
    table = report.get("table1") or {}
    fog = {row["name"]: row for row in table.get("fog") or []}
    avg = {row["name"]: row for row in table.get("averaging") or []}
    if not fog:
        return "Table I: no ground truth (nothing to score)."

    def num(value: Any) -> str:
        return "-" if value is None else f"{value:.1f}"

    lines = [
        f"{'floor':<16}{'truth mm':>10}{'FOG mm':>10}{'err':>8}{'cells':>7}"
        f"{'avg mm':>10}{'err':>8}",
    ]
    for name, row in fog.items():
        other = avg.get(name, {})
        lines.append(
            f"{name:<16}{num(row['ground_truth_mm']):>10}{num(row['estimated_mm']):>10}"
            f"{num(row['error_mm']):>8}{row['cells']:>7}"
            f"{num(other.get('estimated_mm')):>10}{num(other.get('error_mm')):>8}"
        )
    cells = (report.get("cells") or {}).get("fog") or {}
    if cells.get("accuracy") is not None:
        lines.append(
            f"cells labelled right: {100 * cells['accuracy']:.1f} % of {cells['seen']} seen"
        )
    for event in report.get("events") or []:
        lines.append(
            f"{event['kind']} {event['object']}: footprint cleared after "
            f"FOG {event['fog_frames']} / averaging {event['averaging_frames']} frames"
        )
    return "\n".join(lines)
