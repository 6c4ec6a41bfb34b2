"""A recording's stored ground truth keeps a terrain's height field (replays score it so)."""

from __future__ import annotations

import msgspec

from fogsim.config import load_scenario
from fogsim.data.meta import SceneTruthMeta
from fogsim.world import SceneTruth


def test_a_terrain_truth_survives_the_recording_meta():
    truth = SceneTruth.from_scenario(load_scenario("eth_stairs"), 0.0)
    stored = msgspec.json.decode(
        msgspec.json.encode(SceneTruthMeta.from_truth(truth)), type=SceneTruthMeta
    )
    assert stored.to_truth() == truth  # without the height field: a flat 0.95 m box


def test_a_box_truth_is_stored_without_terrain_keys():
    truth = SceneTruth.from_scenario(load_scenario("stage"), 0.0)
    text = msgspec.json.encode(SceneTruthMeta.from_truth(truth))
    assert b"heightfield" not in text  # box-only recordings read as before
    assert msgspec.json.decode(text, type=SceneTruthMeta).to_truth() == truth
