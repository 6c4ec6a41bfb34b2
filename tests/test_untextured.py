"""The ``untextured`` scenario: stereo's known failure mode, measured against the truth.

Two equal 5 cm boxes side by side, one with the 1/f noise texture of every shipped surface and
one a plain colour (``texture = "none"``). Which pixels see which top is known exactly: the true
camera pose of the frame, ray-cast against the scenario's boxes (tests/synthetic_depth.py).
The textured top is measured to a few mm. Inside the plain top a block matcher has nothing to
match, and semi-global matching does not leave it empty: its smoothness term carries the
disparities of the box's outline and the ground into it, so most of its pixels get a depth
that is centimetres wrong (measured: 76 % of them, median 80 mm too far). These tests pin that
behaviour down, so a change of the matcher that fixes or worsens it shows.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fogsim.config import load_scenario
from fogsim.sim.simulation import Simulation
from tests.synthetic_depth import Box, render_scene

SETTLED_FRAME = 12
"""A frame after the look down (1 s at 12.5 Hz): the head has come to rest."""
INSET_M = 0.06
"""Pixels within this of a top's border are left out: the matcher's 5 px window straddles the
edge there (the box's outline is texture), and 6 cm is about 2 px at 1.3 m."""


@pytest.fixture(scope="module")
def stereo_frame():
    scenario = load_scenario("untextured")
    assert scenario.camera.mode == "stereo"
    with Simulation(scenario) as simulation:
        frame = next(itertools.islice(simulation.frames(), SETTLED_FRAME, None))
    return scenario, frame


def inner_top_pixels(scenario, frame, name):
    """Pixels whose true ray meets the top of object ``name`` at least INSET_M inside it."""
    (obj,) = [o for o in scenario.objects if o.name == name]
    inner = Box(
        tuple(obj.center), (obj.size[0] - 2 * INSET_M, obj.size[1] - 2 * INSET_M, obj.size[2])
    )
    rendering = render_scene(frame.intrinsics, frame.transform_camera_to_world_true, [inner])
    return (rendering.box_index == 0) & rendering.on_top


def test_the_textured_top_is_measured_and_the_plain_one_filled_wrongly(stereo_frame):
    scenario, frame = stereo_frame
    objects = [Box(tuple(o.center), tuple(o.size)) for o in scenario.objects]
    true_depth_m = render_scene(
        frame.intrinsics, frame.transform_camera_to_world_true, objects
    ).depth_m
    error_m = frame.depth_m - true_depth_m
    for name, most_valid, median_error_mm in (
        ("textured_box", 0.95, (-5, 5)),
        ("plain_box", 0.5, (30, 200)),
    ):
        top = inner_top_pixels(scenario, frame, name)
        assert top.sum() >= 100, name  # well in view
        valid = np.isfinite(frame.depth_m[top])
        assert valid.mean() >= most_valid, (name, valid.mean())
        median_mm = 1000 * float(np.median(error_m[top][valid]))
        assert median_error_mm[0] < median_mm < median_error_mm[1], (name, median_mm)


def test_only_the_plain_box_is_untextured():
    scenario = load_scenario("untextured")
    assert {o.name: o.texture for o in scenario.objects} == {
        "textured_box": "noise",
        "plain_box": "none",
    }
