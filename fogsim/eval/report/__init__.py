"""``report.json``: the run's results exactly as DESIGN.md "Results" lists them.

* :mod:`~fogsim.eval.report.schema` — the typed :class:`Report` (frozen dataclasses, one per
  JSON object, fields in key order);
* :mod:`~fogsim.eval.report.build` — :func:`build_report`, the report of a
  :class:`fogsim.eval.result.RunResult`;
* :mod:`~fogsim.eval.report.io` — :func:`write_report` and the typed :func:`load_report`;
* :mod:`~fogsim.eval.report.console` — :func:`format_table1`, the text ``fogsim run`` prints.

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
  ``obstacles``: per obstacle object, the share of it the FOG marks obstacle;
  ``averaging``: ``seen`` and ``floor_height`` stats of the baseline.
* ``events``: per removed / moved object, frames from the event until its old footprint is
  cleared (``fog_frames``, ``averaging_frames``; null = never) and until 90 % of it is floor at
  the true height (``*_frames_to_floor``); moves add ``intermediate_floor_cells``.
* ``timing``: ``frames``, ``withdrawn_frames``, ``z_matched_frames``, ``update_ms``,
  ``segmentation_ms`` and ``frame_ms`` (``median``, ``p99``, ``max``), ``wall_s``
  (whole run incl. setup when the caller passes it), ``realtime_factor``; ``pictures_s`` when
  pictures were written.
* ``pose_error``: believed-vs-true camera pose: ``camera_in_robot`` (encoder errors, the
  paper's "7° and 10 mm") and ``camera_in_world`` (with odometry drift), each
  ``rotation_deg`` / ``translation_mm`` ``{median, max}``.
* ``params``: ``mapper``, ``segmentation``, ``elevation``, ``pipeline`` parameters used.
* ``versions``: Python and package versions.
* ``pictures`` / ``video``: file names, when written.
"""

from fogsim.eval.report.build import build_report, package_versions
from fogsim.eval.report.console import format_table1
from fogsim.eval.report.io import load_report, write_report
from fogsim.eval.report.schema import REPORT_FORMAT, REPORT_VERSION, Report

__all__ = [
    "REPORT_FORMAT",
    "REPORT_VERSION",
    "Report",
    "build_report",
    "format_table1",
    "load_report",
    "package_versions",
    "write_report",
]
