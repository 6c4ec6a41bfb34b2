"""A run's frames one row each: ``frames.csv`` (what the pipeline decided and the pose it left).

The report gives a run's medians and maxima; this table gives every frame, so that a map error
can be traced to the frames that made it (a run of frames whose tilt went 1.5° off, the frames
a heading estimate was late for): :func:`write_frame_log` writes it beside ``report.json``,
:func:`read_frame_log` reads it back as a typed :class:`FrameLog`.

No timing is kept: the file is the same bit for bit for the same seed (the report's ``timing``
has the run's times).

File format, version 1: CSV (RFC 4180, ``,``, a header row), one row per frame in the order
processed; a first line ``# fogsim-frames 1`` names the format and version. Columns:

============================  ===========================================================
column                        meaning
============================  ===========================================================
``frame``                     the frame's index (``Frame.index``)
``time_s``                    its simulation or recording time [s]
``withdrawn``                 1: the z-match rule withdrew it (no map update), else 0
``z_matched``                 1: an accepted z shift was applied to its data
``ground_plane_found``        1: the segmentation found the ground plane (Sec. IV)
``camera_rotation_deg``       believed vs true camera pose in the robot frame: rotation
``camera_translation_mm``     ... and offset
``world_rotation_deg``        believed vs true camera pose in the world: rotation
``world_translation_mm``      ... and offset
``residual_tilt_deg``         tilt left by the corrections (as last mapped), robot frame
``residual_heading_deg``      signed yaw left as processed, robot frame (+ = left)
``map_heading_deg``           signed yaw left as last mapped, robot frame
``world_heading_deg``         signed yaw left as last mapped, in the world
============================  ===========================================================

Deferred frames (waiting for the height reference) are given with their outcome once mapped.
An empty field is not known (no true pose, or no corrected pose: real data has no truth).
Floats are written with ``repr`` (shortest round trip): read back, they are the same numbers.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from fogsim.errors import ReportError
from fogsim.eval.pose_error import FramePoseErrors

FORMAT_LINE = "# fogsim-frames 1"
"""The file's first line: format name and version."""


@dataclass(frozen=True)
class FrameLog:
    """Every frame of a run (module docstring for the columns), arrays of one length.

    Attributes:
        frame: (N,) frame indices.
        time_s: (N,) frame times [s].
        withdrawn: (N,) the frame was withdrawn.
        z_matched: (N,) an accepted z shift was applied.
        ground_plane_found: (N,) the segmentation found the ground plane.
        pose: The frames' camera pose errors (NaN = not known).
    """

    frame: NDArray[np.int64]
    time_s: NDArray[np.float64]
    withdrawn: NDArray[np.bool_]
    z_matched: NDArray[np.bool_]
    ground_plane_found: NDArray[np.bool_]
    pose: FramePoseErrors

    def __len__(self) -> int:
        return int(self.frame.shape[0])


_FLAGS = ("withdrawn", "z_matched", "ground_plane_found")
_POSE = tuple(f.name for f in fields(FramePoseErrors))
COLUMNS = ("frame", "time_s", *_FLAGS, *_POSE)
"""The header row, in order."""


def _number(value: float) -> str:
    return "" if math.isnan(value) else repr(float(value))


def write_frame_log(path: str | Path, log: FrameLog) -> None:
    """Write ``log`` as ``frames.csv`` (format in the module docstring).

    The run writes it into its temporary output folder, which is renamed into place whole
    (`fogsim.run.run_folder`): no partial file is ever seen at the target.
    """
    pose = [getattr(log.pose, name) for name in _POSE]
    with open(path, "w", newline="", encoding="utf-8") as file:
        file.write(FORMAT_LINE + "\n")
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow(COLUMNS)
        for i in range(len(log)):
            writer.writerow(
                [
                    int(log.frame[i]),
                    repr(float(log.time_s[i])),
                    *(int(bool(getattr(log, name)[i])) for name in _FLAGS),
                    *(_number(column[i]) for column in pose),
                ]
            )


def read_frame_log(path: str | Path) -> FrameLog:
    """Read a ``frames.csv`` written by :func:`write_frame_log`.

    Raises:
        ReportError: Not such a file: the first line or the header differs, or a row does not
            have one value per column, naming the file and the line.
    """
    path = Path(path)
    with open(path, newline="", encoding="utf-8") as file:
        first = file.readline().rstrip("\n")
        if first != FORMAT_LINE:
            raise ReportError(f"{path}: line 1 is {first[:60]!r}, expected {FORMAT_LINE!r}")
        rows = list(csv.reader(file))
    if not rows or tuple(rows[0]) != COLUMNS:
        raise ReportError(f"{path}: line 2 must be the header {','.join(COLUMNS)}")
    body = rows[1:]
    for line, row in enumerate(body, start=3):
        if len(row) != len(COLUMNS):
            raise ReportError(f"{path}: line {line} has {len(row)} values, expected {len(COLUMNS)}")
    try:
        table = [[float(v) if v != "" else math.nan for v in row] for row in body]
    except ValueError as error:
        raise ReportError(f"{path}: a value is not a number ({error})") from None
    values = np.array(table, dtype=np.float64).reshape(len(body), len(COLUMNS))
    column = {name: values[:, k] for k, name in enumerate(COLUMNS)}
    return FrameLog(
        frame=column["frame"].astype(np.int64),
        time_s=column["time_s"],
        withdrawn=column["withdrawn"] != 0,
        z_matched=column["z_matched"] != 0,
        ground_plane_found=column["ground_plane_found"] != 0,
        pose=FramePoseErrors(*(column[name] for name in _POSE)),
    )
