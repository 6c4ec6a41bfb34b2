"""A frame progress bar whose time estimate is honest from its first frame.

A run's or a recording's first frame carries one-off costs the others do not: the renderer's
OpenGL context and the first physics steps (``fogsim record`` stage: 1.2 s, then 3–5 ms a
frame), the segmentation thread filling its queue (``fogsim run`` stage: 0.12 s, then 5 ms).
A bar started before it estimates the rest of the run from that frame alone — 6 min 53 s for a
3 s recording, 1 min 43 s for a 4 s run (session 35, Intel Xeon) — and a cold run used to show
ten hours. :class:`FrameProgress` shows the bar once the first frame is done, counted as done,
with its clock starting there: its first estimate comes from the second frame, a frame like
the rest. The elapsed time it shows is the frames' after the first.
"""

from __future__ import annotations

from typing import TextIO

from tqdm import tqdm


class FrameProgress:
    """A tqdm bar over ``total`` frames, started at the end of the first.

    Closed by :meth:`close` (``contextlib.closing`` in a ``with``).

    Attributes:
        bar: The tqdm bar; None until the first frame is done.
    """

    def __init__(self, total: int | None, desc: str, file: TextIO | None = None) -> None:
        """A bar not shown yet.

        Args:
            total: Frames expected (None: unknown, no estimate).
            desc: The bar's label (the scenario's name).
            file: Stream of the bar (None: tqdm's default, standard error).
        """
        self._total = total
        self._desc = desc
        self._file = file
        self.bar: tqdm | None = None

    def update(self) -> None:
        """Count one more frame done (the first one starts the bar's clock)."""
        if self.bar is None:
            self.bar = tqdm(
                total=self._total, initial=1, unit="frame", desc=self._desc, file=self._file
            )
        else:
            self.bar.update(1)

    def close(self) -> None:
        """Close the bar (if it was started)."""
        if self.bar is not None:
            self.bar.close()
