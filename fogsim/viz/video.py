"""``run.mp4``: the robot walking, what its camera sees and the growing FOG, one frame per frame.

Each video frame is, left to right, at :data:`PANEL_HEIGHT_PX`:

* the third-person view of the robot on the course (simulated runs,
  :class:`fogsim.sim.third_person.ThirdPersonCamera`; a recording has no scene to render, so a
  replay's video starts with the next panel);
* the depth image (near bright, far dark, no measurement black; :data:`DEPTH_SPAN_M`);
* the FOG of the robot-centred grid (floor by height, obstacles black, unknown grey; x right,
  y up; :data:`FOG_HEIGHTS_MM`).

The stream is H.264 (yuv420p, the profile every browser plays) when PyAV (the ``av`` package)
carries an H.264 encoder (:data:`H264_ENCODERS`; PyAV's wheels carry libx264). Without one the
video is MPEG-4 Part 2 by OpenCV (``mp4v``; desktop players play it, browsers do not), and
:func:`video_codec` says why, which the writer prints on standard error: the fallback is never
silent, and the report names the codec. Encoding uses one thread, so the same frames give the
same file (with the same encoder version).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any, Protocol

import cv2
import numpy as np
from matplotlib.colors import Normalize
from numpy.typing import NDArray

from fogsim.atomic import OutputError, reason, temporary_path
from fogsim.data.frame import Frame
from fogsim.mapping.pipeline import Pipeline
from fogsim.viz.pictures import fog_rgb

PANEL_HEIGHT_PX = 360
"""Height of every panel and of the video [px]: the 88 × 72 depth image at 5 × (nearest
neighbour, pixels stay visible), the third-person view at its native 480 × 360."""
DEPTH_SPAN_M = 4.0
"""Depth shown from bright (0 m) to dark (at and beyond 4 m) [m]: the stage's 4 m course."""
FOG_HEIGHTS_MM = (-20.0, 150.0)
"""Height colours of the FOG panel [mm], fixed for the whole video so a colour keeps its
height: from just below the ground to just above the scenarios' highest walkable tops (the
stage's platform at 120 mm)."""
H264_ENCODERS = ("libx264", "libopenh264")
"""FFmpeg's H.264 encoders in order of preference: x264 (in PyAV's wheels), then Cisco's
OpenH264 (in some FFmpeg builds without x264)."""
H264_CRF = 23
"""x264's constant rate factor: its default quality (0 lossless … 51 worst); the stage's 832
frames at 1280 × 360 come to a few MB."""

Picture = NDArray[np.uint8]
"""An (height, width, 3) RGB image."""


@dataclass(frozen=True)
class VideoCodec:
    """How the video is encoded.

    Attributes:
        codec: The stream's codec as FFmpeg names it: ``h264``, or ``mpeg4`` (Part 2).
        encoder: What encodes it: ``libx264`` / ``libopenh264`` through PyAV, or ``opencv mp4v``.
        fallback: Why the video is not H.264 (None when it is).
    """

    codec: str
    encoder: str
    fallback: str | None = None

    def describe(self) -> str:
        """``h264 (libx264)``: for the report."""
        return f"{self.codec} ({self.encoder})"


def video_codec() -> VideoCodec:
    """H.264 through PyAV where it has an encoder for it, else MPEG-4 Part 2 through OpenCV."""
    try:
        import av
    except ImportError:
        return VideoCodec(
            "mpeg4",
            "opencv mp4v",
            "PyAV (pip package 'av') is not installed: run.mp4 is MPEG-4 Part 2, which browsers "
            "do not play",
        )
    for name in H264_ENCODERS:
        try:
            av.codec.Codec(name, "w")
        except av.codec.codec.UnknownCodecError:
            continue
        return VideoCodec("h264", name)
    return VideoCodec(
        "mpeg4",
        "opencv mp4v",
        f"PyAV {av.__version__} has none of the H.264 encoders {', '.join(H264_ENCODERS)}: "
        "run.mp4 is MPEG-4 Part 2, which browsers do not play",
    )


class _Encoder(Protocol):
    def write(self, picture: Picture) -> None: ...

    def close(self) -> None: ...


class _PyAvEncoder:
    """H.264 in MP4 through PyAV (yuv420p, one thread, moov atom first for the web)."""

    def __init__(self, path: Path, fps: float, size_px: tuple[int, int], encoder: str) -> None:
        import av

        self._av = av
        try:
            self._container: Any = av.open(
                str(path), mode="w", format="mp4", options={"movflags": "+faststart"}
            )
        except OSError as exc:
            raise OutputError(f"cannot write {path}: {reason(exc)}") from exc
        self._stream: Any = self._container.add_stream(
            encoder, rate=Fraction(fps).limit_denominator(1000)
        )
        self._stream.width, self._stream.height = size_px
        self._stream.pix_fmt = "yuv420p"
        self._stream.codec_context.thread_count = 1
        if encoder == "libx264":
            self._stream.options = {"crf": str(H264_CRF)}
        self._index = 0

    def write(self, picture: Picture) -> None:
        frame = self._av.VideoFrame.from_ndarray(picture, format="rgb24")
        frame.pts = self._index
        self._index += 1
        self._container.mux(self._stream.encode(frame))

    def close(self) -> None:
        self._container.mux(self._stream.encode(None))
        self._container.close()


class _OpenCvEncoder:
    """MPEG-4 Part 2 (``mp4v``) in MP4 through OpenCV."""

    def __init__(self, path: Path, fps: float, size_px: tuple[int, int]) -> None:
        self._writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, size_px)
        if not self._writer.isOpened():
            raise OutputError(f"cannot write {path}: OpenCV cannot open it")

    def write(self, picture: Picture) -> None:
        self._writer.write(np.ascontiguousarray(picture[:, :, ::-1]))  # RGB → BGR

    def close(self) -> None:
        self._writer.release()


def _to_height(picture: Picture, height_px: int) -> Picture:
    """``picture`` scaled to ``height_px`` rows, aspect kept, nearest neighbour."""
    width = max(1, round(picture.shape[1] * height_px / picture.shape[0]))
    return cv2.resize(picture, (width, height_px), interpolation=cv2.INTER_NEAREST)


def depth_panel(depth_m: NDArray[np.floating], height_px: int) -> Picture:
    """The depth image in magma: 0 m bright, :data:`DEPTH_SPAN_M` and beyond dark, NaN black."""
    depth = np.asarray(depth_m, dtype=np.float64)
    finite = np.isfinite(depth)
    scaled = np.zeros(depth.shape, dtype=np.uint8)
    scaled[finite] = np.clip(255.0 * (1.0 - depth[finite] / DEPTH_SPAN_M), 0, 255).astype(np.uint8)
    rgb = cv2.applyColorMap(scaled, cv2.COLORMAP_MAGMA)[:, :, ::-1]
    rgb[~finite] = 0
    return _to_height(np.ascontiguousarray(rgb), height_px)


def fog_panel(
    types: NDArray[np.integer], heights_m: NDArray[np.floating], height_px: int
) -> Picture:
    """The FOG (x right, y up) in :func:`fogsim.viz.pictures.fog_rgb`'s colours."""
    rgb = fog_rgb(types, heights_m, Normalize(*FOG_HEIGHTS_MM))[::-1]  # row 0 at the top
    picture = np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)
    return _to_height(picture, height_px)


def side_by_side(panels: list[Picture]) -> Picture:
    """Panels of one height left to right, padded black to an even width and height (yuv420p)."""
    image = np.concatenate(panels, axis=1)
    height, width = image.shape[:2]
    return np.pad(image, ((0, height % 2), (0, width % 2), (0, 0)))


class RunVideoWriter:
    """``run.mp4`` of a run (see the module docstring), one video frame per camera frame.

    :meth:`add` is the pipeline's frame callback; :meth:`close` finishes the file and moves it
    into place (complete or absent).

    Args:
        path: The file to write.
        fps: Frames per second: the scenario's frame rate.
        third_person: The third-person picture of a frame index (a simulation's
            :meth:`~fogsim.sim.third_person.ThirdPersonCamera.take`); None: no such panel.
        height_px: Height of the video [px].

    Attributes:
        codec: How the video is encoded (:func:`video_codec`).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        fps: float,
        third_person: Callable[[int], Picture] | None = None,
        height_px: int = PANEL_HEIGHT_PX,
    ) -> None:
        self.path = Path(path)
        self.fps = float(fps)
        self.height_px = int(height_px)
        self.codec = video_codec()
        if self.codec.fallback is not None:
            print(f"fogsim: {self.codec.fallback}", file=sys.stderr, flush=True)
        self._third_person = third_person
        self._tmp = temporary_path(self.path, suffix=".mp4")  # the container is chosen by it
        self._encoder: _Encoder | None = None

    def picture(self, frame: Frame, pipeline: Pipeline) -> Picture:
        """The video frame of ``frame``: third-person view, depth image, the current FOG."""
        panels = []
        if self._third_person is not None:
            panels.append(_to_height(self._third_person(frame.index), self.height_px))
        panels.append(depth_panel(frame.depth_m, self.height_px))
        types, heights_m, _ = pipeline.maps()
        panels.append(fog_panel(types, heights_m, self.height_px))
        return side_by_side(panels)

    def add(self, frame: Frame, pipeline: Pipeline) -> None:
        """Append the video frame of ``frame`` (opens the file at the first)."""
        picture = self.picture(frame, pipeline)
        if self._encoder is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            size_px = (picture.shape[1], picture.shape[0])
            if self.codec.codec == "h264":
                self._encoder = _PyAvEncoder(self._tmp, self.fps, size_px, self.codec.encoder)
            else:
                self._encoder = _OpenCvEncoder(self._tmp, self.fps, size_px)
        self._encoder.write(picture)

    def close(self) -> None:
        """Finish the file and move it into place (atomic: complete or absent).

        Raises:
            OutputError: The video cannot be moved into place.
        """
        if self._encoder is None:
            return
        self._encoder.close()
        self._encoder = None
        try:
            os.replace(self._tmp, self.path)
        except OSError as exc:
            raise OutputError(f"cannot write {self.path}: {reason(exc)}") from exc
