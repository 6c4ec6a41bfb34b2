"""The frame progress bar starts its clock at the end of the first frame (issue #14)."""

import io
import time
from contextlib import closing

from fogsim.run.progress import FrameProgress


def test_bar_starts_after_the_first_frame_counted_done() -> None:
    stream = io.StringIO()
    with closing(FrameProgress(10, "stage", file=stream)) as progress:
        assert progress.bar is None  # nothing shown while the first frame runs
        assert stream.getvalue() == ""
        first_frame_done = time.time()
        progress.update()
        bar = progress.bar
        assert bar is not None
        assert bar.n == 1 and bar.total == 10
        # The clock starts at the first frame's end: its one-off cost is not in the estimate.
        assert bar.start_t >= first_frame_done
        for _ in range(9):
            progress.update()
        assert bar.n == 10
    assert "10/10" in stream.getvalue()
    assert "stage" in stream.getvalue()


def test_no_frame_no_bar() -> None:
    stream = io.StringIO()
    with closing(FrameProgress(5, "empty", file=stream)) as progress:
        pass
    assert progress.bar is None
    assert stream.getvalue() == ""


def test_unknown_total_counts_frames() -> None:
    stream = io.StringIO()
    with closing(FrameProgress(None, "bag", file=stream)) as progress:
        for _ in range(3):
            progress.update()
    assert progress.bar is not None and progress.bar.n == 3
    assert "3frame" in stream.getvalue().replace(" ", "")
