"""`bench/heading_trace.py`'s summary over replays, by hand."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
heading_trace = pytest.importorskip("heading_trace")


def test_the_summary_takes_first_every_and_final_errors_with_their_worst_replays():
    results = [
        heading_trace.EstimateErrors("a.npz", (1.0, -0.5), 0.25),
        heading_trace.EstimateErrors("b.npz", (-3.0,), -1.5),
        heading_trace.EstimateErrors("c.npz", (), 0.75),
    ]
    line = heading_trace.summarize(results)
    # First estimates: |1.0|, |-3.0| -> mean 2.0, worst 3.0 (b); every: 1.0, 0.5, 3.0 -> 1.5;
    # final: 0.25, 1.5, 0.75 -> 0.833, worst 1.5 (b); c accepted none.
    assert line == (
        "3 replays: first accepted estimate |error| 2.000° (worst 3.00°, b.npz); every "
        "accepted estimate 1.500° (worst 3.00°, b.npz) over 3; final correction 0.833° "
        "(worst 1.50°, b.npz); no estimate: c.npz"
    )


def test_a_summary_of_replays_without_estimates_says_none():
    line = heading_trace.summarize([heading_trace.EstimateErrors("c.npz", (), -0.5)])
    assert "first accepted estimate |error| none;" in line
    assert "final correction 0.500° (worst 0.50°, c.npz); no estimate: c.npz" in line
