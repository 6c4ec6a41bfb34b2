"""`bench/bench_mapper.py --stages`: the per-stage breakdown of ``FloorObstacleMapper.update``."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
bench_mapper = pytest.importorskip("bench_mapper")

import mapper.mapper as mapper_module  # noqa: E402


def test_stage_breakdown_times_every_stage_and_puts_the_functions_back():
    originals = {name: getattr(mapper_module, name) for name in bench_mapper.STAGES}
    frames = bench_mapper.synthetic_frames("edge", 88, 72, 3)
    rows = bench_mapper.stage_breakdown(frames, "host")
    peers = [row.peer for row in rows]
    assert peers == [f"update: {name}" for name in (*bench_mapper.STAGES, "(stages summed)")]
    by_peer = {row.peer: row.median_ms for row in rows}
    assert all(ms >= 0.0 for ms in by_peer.values())
    assert by_peer["update: insert_frame_columns"] > 0.0
    assert by_peer["update: (stages summed)"] >= by_peer["update: insert_frame_columns"]
    assert {name: getattr(mapper_module, name) for name in bench_mapper.STAGES} == originals
