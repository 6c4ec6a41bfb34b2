"""``report.json``: the run's results exactly as DESIGN.md "Results" lists them.

* :mod:`~fogsim.eval.report.schema` — the typed :class:`Report` (frozen dataclasses, one per
  JSON object, fields in key order);
* :mod:`~fogsim.eval.report.build` — :func:`build_report`, the report of a
  :class:`fogsim.eval.result.RunResult`;
* :mod:`~fogsim.eval.report.io` — :func:`write_report` and the typed :func:`load_report`;
* :mod:`~fogsim.eval.report.console` — :func:`format_table1`, the text ``fogsim run`` prints
  (with a ``WARNING`` line per reason a run is poor, :func:`format_warnings`);
* :mod:`~fogsim.eval.report.quality` — the quality gate (:func:`assess_quality`).

Top-level keys (all lengths in mm, times in ms or s as named; null = not available). "Seen" cells
are those the FOG labels floor or obstacle; the scored region is every cell that was ever inside
the robot-centred grid (a world-fixed archive keeps each cell's last value):

* ``format``: ``"fogsim-report"``, ``version``: 2.
* ``scenario``: scenario name (null for real data), ``seed``, ``source``
  (``"simulation"`` / ``"replay"``).
* ``quality``: ``withdrawn_fraction`` (frames withdrawn by the z-match rule / frames),
  ``frames_without_ground_plane``, ``map_empty``, ``floor_right_fraction`` (seen true floor
  labelled floor within 20 mm), ``poor`` and ``reasons``: a run is poor when more than 20 % of
  its frames are withdrawn, more than 50 % have no ground plane while z matching is off, the
  map is empty, or less than 50 % of the seen floor is right; ``fogsim run`` prints a WARNING
  line per reason.
* ``table1``: ``{"fog": rows, "averaging": rows}``, one row per walkable surface and the ground:
  ``name``, ``ground_truth_mm``, ``estimated_mm`` (median floor height over the surface's
  interior cells — border cells left out — that the map has: FOG floor cells, or any
  baseline height), ``error_mm`` (estimated − truth), ``cells`` (cells used),
  ``surface_cells`` (interior cells of the surface in the mapped area).
* ``cells``: ``fog``: ``region`` (cells scored), ``in_view`` (cells into which a depth
  measurement fell, placed with the true camera pose), ``seen``, ``in_view_seen`` (cells in view
  the FOG labelled: the rest it saw but left unknown), ``correct``, ``accuracy`` (= correct /
  seen), interior-only variants, ``confusion`` (truth → FOG label → count, unknown included),
  ``classes.floor`` / ``classes.obstacle`` over the seen cells (``truth_seen``, ``labelled``,
  ``true_positive``, ``recall`` = true_positive / truth_seen, ``precision`` = true_positive /
  labelled), ``obstacle_height`` and ``floor_height`` absolute error stats (median, p95, max
  [mm]; obstacles also ``within_one_cell_fraction``); ``obstacles``: per obstacle object, the
  share of it the FOG marks obstacle; ``averaging``: ``seen`` and ``floor_height`` stats of the
  baseline.
* ``safety``: FOG floor cells a robot could not stand on: ``unsafe_cells`` =
  ``floor_on_obstacle`` (FOG floor, true obstacle) + ``floor_height_off`` (FOG floor on true
  floor more than ``height_tolerance_mm`` = 20 mm off); ``positions_xy_m`` of up to 200 of them,
  worst first; ``floor_height_error_mm`` percentiles (``p50``, ``p90``, ``p95``, ``p99``, ``max``)
  of the absolute FOG floor error on true floor.
* ``step_edges``: per edge (``x_min``, ``x_max``, ``y_min``, ``y_max`` in the object's frame) of
  each walkable surface in view: ``cells`` (positions one cell apart along the edge where the map
  shows the step), ``median_error_mm`` (signed, along the edge normal, + = the map puts the edge
  toward the higher side; a riser mapped toward a robot walking up is negative),
  ``max_abs_error_mm``, ``median_nearest_error_mm`` (the edge nearest the true one that agrees
  with the map as well: 0 where the true edge lies in a band the map leaves unknown or obstacle)
  and ``median_gap_mm`` (that band's width: 0 where the two floors touch). Table I leaves border
  cells out; this is about exactly those.
* ``unseen_objects``: objects present at the end none of whose cells the FOG ever labelled.
* ``ceiling``: where the truth has a ceiling (something hanging) in the region: ``cells`` with a
  mapped ceiling, ``median_abs_error_mm``, ``max_abs_error_mm``; null where nothing hangs.
* ``events``: per removed / moved object, its own footprint at its event time
  (``footprint_cells``; ``excluded_cells`` another object covers from then on), ``seen`` per
  map (whether it showed the object before the event; a map that did not gets no figure), and
  two figures per map ``{fog, averaging}`` in frames from ``start_frame`` (null = never):
  ``cleared_frames`` (no footprint cell shows the object) and ``floor_again_frames`` (90 % of
  it floor within 10 mm of the true height); moves add ``intermediate_floor_cells``.
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
from fogsim.eval.report.console import format_table1, format_warnings
from fogsim.eval.report.io import load_report, write_report
from fogsim.eval.report.schema import REPORT_FORMAT, REPORT_VERSION, Report

__all__ = [
    "REPORT_FORMAT",
    "REPORT_VERSION",
    "Report",
    "build_report",
    "format_table1",
    "format_warnings",
    "load_report",
    "package_versions",
    "write_report",
]
