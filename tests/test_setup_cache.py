"""The set-up kept on disk by content: the robot model and the planned walk, bit for bit."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest

from fogsim.config import load_scenario
from fogsim.errors import FogsimError
from fogsim.robot import disk_cache, load_robot, model
from fogsim.robot.mjcf import mjcf_files
from fogsim.sim import route_cache
from fogsim.sim.route_cache import planned_route, route_key


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    """A fresh cache root, and no robot loaded in this process yet."""
    monkeypatch.setenv("FOGSIM_CACHE", str(tmp_path))
    load_robot.cache_clear()
    yield tmp_path
    load_robot.cache_clear()


def _refuse(*args):
    raise AssertionError("built again instead of loaded from the cache")


def test_a_cached_robot_is_the_loaded_one_and_is_not_built_again(empty_cache, monkeypatch):
    built = load_robot("icub")
    (cached_file,) = (empty_cache / "robot_models").glob("icub_*.pickle")
    load_robot.cache_clear()
    monkeypatch.setattr(model, "_load", _refuse)
    cached = load_robot("icub")
    assert cached is not built
    assert cached.pin_model == built.pin_model  # pinocchio compares every number exactly
    for field in dataclasses.fields(built):
        if field.name not in ("pin_model", "pin_data", "body_boxes"):
            assert np.array_equal(getattr(cached, field.name), getattr(built, field.name))
    for mine, theirs in zip(cached.body_boxes, built.body_boxes, strict=True):
        assert mine.name == theirs.name and mine.joint_id == theirs.joint_id
        assert np.array_equal(mine.transform_box_to_joint, theirs.transform_box_to_joint)
        assert np.array_equal(mine.half_extents_m, theirs.half_extents_m)
    q = built.neutral()
    assert np.array_equal(cached.transform_camera_to_world(q), built.transform_camera_to_world(q))
    assert cached_file.exists()


@pytest.mark.parametrize("deleted", [0, -1], ids=["the MJCF", "a mesh file"])
def test_a_cached_robot_whose_mjcf_was_deleted_is_built_again(empty_cache, deleted):
    built = load_robot("icub")
    files = mjcf_files(built.mjcf_path)
    assert len(files) > 1 and files[-1].suffix == ".msh"
    contents = [path.read_bytes() for path in files]
    files[deleted].unlink()
    load_robot.cache_clear()
    again = load_robot("icub")
    assert again.mjcf_path == built.mjcf_path
    assert [path.read_bytes() for path in mjcf_files(again.mjcf_path)] == contents


def test_a_cached_walk_is_the_planned_one_and_is_shared_by_seeds_and_camera_modes(
    empty_cache, monkeypatch
):
    scenario = load_scenario("stage")
    robot = load_robot("icub")
    planned = planned_route(scenario, robot)  # planned now (plan_route's own result)
    monkeypatch.setattr(route_cache, "plan_route", _refuse)
    other_run = scenario.with_overrides(["camera.mode=stereo", "encoders.bias_deg=1.0"])
    cached = planned_route(dataclasses.replace(other_run, seed=7), robot)
    assert cached is not planned
    for field in dataclasses.fields(planned):
        mine, theirs = getattr(cached, field.name), getattr(planned, field.name)
        assert np.array_equal(mine, theirs) if isinstance(mine, np.ndarray) else mine == theirs
    assert len(list((empty_cache / "routes").glob("stage_*.pickle"))) == 1


def test_the_walk_key_changes_with_the_route_the_objects_and_the_frame_rate():
    scenario = load_scenario("stage")
    robot = load_robot("icub")
    keys = {
        route_key(variant, robot)
        for variant in (
            scenario,
            dataclasses.replace(scenario, route=scenario.route[:-1]),
            dataclasses.replace(scenario, objects=scenario.objects[:-1]),
            dataclasses.replace(scenario, frame_rate_hz=25.0),
            dataclasses.replace(
                scenario, robot=dataclasses.replace(scenario.robot, start=(0.1, 0.5, 0.0))
            ),
        )
    }
    assert len(keys) == 5


def test_the_cache_keeps_the_most_recently_used_files(tmp_path):
    for name, stamp in (("a", 1), ("b", 2), ("c", 3)):
        disk_cache.load_or_build(tmp_path / f"{name}.pickle", lambda name=name: name, keep=3)
        os.utime(tmp_path / f"{name}.pickle", ns=(stamp, stamp))
    assert disk_cache.load_or_build(tmp_path / "a.pickle", _refuse, keep=3) == "a"  # used now
    disk_cache.load_or_build(tmp_path / "d.pickle", lambda: "d", keep=2)
    assert sorted(p.name for p in tmp_path.glob("*.pickle")) == ["a.pickle", "d.pickle"]


def test_an_unreadable_cached_file_is_an_error_naming_it(tmp_path):
    path = tmp_path / "broken.pickle"
    path.write_bytes(b"not a pickle")
    with pytest.raises(FogsimError, match=r"broken\.pickle.*delete it"):
        disk_cache.load_or_build(path, _refuse, keep=2)


def test_the_content_key_tells_apart_parts_that_concatenate_alike():
    assert disk_cache.content_key((b"ab", b"c")) != disk_cache.content_key((b"a", b"bc"))
