"""Frustum culling: which geoms lie outside a camera's view, and renders unchanged by it."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from fogsim.config import CameraConfig, load_scenario
from fogsim.sim.camera import RendererDepth, camera_intrinsics, set_model_intrinsics
from fogsim.sim.camera.culling import FrustumCulling
from fogsim.sim.camera.depth import VISIBLE_GEOMGROUPS, scene_option
from fogsim.sim.simulation import Simulation

INTRINSICS = camera_intrinsics(CameraConfig())  # 88 x 72 px, 47 x 39 deg

# A camera 2 m above the floor looking straight down (MuJoCo's camera looks along its -z, image
# up = world +y): the view's border on the floor is at |x| = 2 tan(23.5 deg) = 0.87 m and
# |y| = 2 tan(19.5 deg) = 0.71 m.
BOXES = {
    "centre": ((0.0, 0.0, 0.0), True),  # below the camera
    "right_edge": ((0.9, 0.0, 0.0), True),  # 0.8..1.0 m: straddles the border at 0.87 m
    "right_out": ((1.5, 0.0, 0.0), False),  # 1.4..1.6 m: wholly right of the view
    "top_out": ((0.0, 1.4, 0.0), False),  # 1.3..1.5 m: wholly beyond its top (y 0.71 m)
    "above": ((0.0, 0.0, 2.5), False),  # behind the camera (it looks down)
    "beside": ((0.5, 0.0, 2.0), False),  # level with the camera: beyond every side plane
}
"""Box name: (centre [m], seen): 0.2 m cubes."""


def _scene_xml(material: str = "", light: str = "") -> str:
    boxes = "".join(
        f'<geom name="{name}" type="box" size=".1 .1 .1" pos="{x} {y} {z}"{material}/>'
        for name, ((x, y, z), _) in BOXES.items()
    )
    return f"""<mujoco><statistic extent="10"/><visual><map znear="0.005" zfar="2"/>
    <quality offsamples="0"/></visual><asset><material name="shiny" reflectance="0.5"/></asset>
    <worldbody>{light}<geom name="floor" type="plane" size="5 5 .1"/>{boxes}
    <camera name="down" pos="0 0 2"/></worldbody></mujoco>"""


def _posed(xml: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(xml)
    set_model_intrinsics(model, 0, INTRINSICS)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def _names(model: mujoco.MjModel, geoms: np.ndarray) -> set[str]:
    return {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) for g in geoms}


def test_the_boxes_wholly_outside_the_view_are_culled():
    model, data = _posed(_scene_xml())
    culling = FrustumCulling(model, INTRINSICS, VISIBLE_GEOMGROUPS)
    assert culling.active
    assert _names(model, culling.outside(data, 0)) == {
        name for name, (_, seen) in BOXES.items() if not seen
    }


def test_a_mesh_on_the_camera_body_is_culled_when_each_of_its_triangles_is_outside():
    """Two triangles each outside the view (one behind the camera, one far right of it) whose
    bounding box spans the view: culled on the camera's body, kept on another body (the box
    test alone); one triangle in view (below the camera) keeps the mesh."""
    behind = "-1 -1 0.5  1 -1 0.5  0 1 0.5"  # the camera's body frame: it looks along -z
    meshes = {
        "unseen": f"{behind}  3 0 -1  3.5 0 -1  3 0.5 -1",  # x/z = 3: right of the view
        "seen": f"{behind}  -0.1 -0.1 -1  0.1 -0.1 -1  0 0.1 -1",  # straight below
    }
    assets = "".join(
        f'<mesh name="{name}" inertia="shell" vertex="{vertices}" face="0 1 2  3 4 5"/>'
        for name, vertices in meshes.items()
    )
    xml = f"""<mujoco><asset>{assets}</asset><worldbody>
    <geom name="floor" type="plane" size="5 5 .1"/>
    <body name="head" pos="0 0 2"><camera name="down"/>
      <geom name="unseen" type="mesh" mesh="unseen"/><geom name="seen" type="mesh" mesh="seen"/>
    </body>
    <body name="other" pos="0 0 2"><geom name="elsewhere" type="mesh" mesh="unseen"/></body>
    </worldbody></mujoco>"""
    model, data = _posed(xml)
    culling = FrustumCulling(model, INTRINSICS, VISIBLE_GEOMGROUPS)
    assert _names(model, culling.outside(data, 0)) == {"unseen"}


def test_the_hidden_geoms_are_back_in_their_groups_afterwards_even_on_an_error():
    model, data = _posed(_scene_xml())
    culling = FrustumCulling(model, INTRINSICS, VISIBLE_GEOMGROUPS)
    before = model.geom_group.copy()
    outside = culling.outside(data, 0)
    with pytest.raises(RuntimeError), culling.hidden(data, 0):
        assert np.all(model.geom_group[outside] == 3)  # the first group not drawn
        assert np.array_equal(np.delete(model.geom_group, outside), np.delete(before, outside))
        raise RuntimeError("render failed")
    assert np.array_equal(model.geom_group, before)


@pytest.mark.parametrize(
    ("material", "light", "geomgroups"),
    [
        (' material="shiny"', "", VISIBLE_GEOMGROUPS),  # a reflection may show any geom
        ("", '<light pos="0 0 5" castshadow="true"/>', VISIBLE_GEOMGROUPS),  # and a shadow
        ("", "", tuple(range(mujoco.mjNGROUP))),  # no group left to hide geoms in
    ],
)
def test_nothing_is_culled_where_an_unseen_geom_can_show(material, light, geomgroups):
    model, data = _posed(_scene_xml(material, light))
    culling = FrustumCulling(model, INTRINSICS, geomgroups)
    assert not culling.active
    assert culling.outside(data, 0).size == 0


def _unculled_depth(renderer: mujoco.Renderer, data, camera_id: int, far_m: float) -> np.ndarray:
    """What RendererDepth renders, by MuJoCo's renderer with every geom in the scene."""
    renderer.update_scene(data, camera=camera_id, scene_option=scene_option(VISIBLE_GEOMGROUPS))
    depth = renderer.render().astype(np.float32, copy=True)
    depth[depth >= np.float32(far_m * (1.0 - 1e-5))] = np.nan
    return depth


@pytest.fixture(scope="module")
def stage_walk():
    with Simulation(load_scenario("stage")) as simulation:
        yield simulation


def _pose(simulation: Simulation, index: int, torso_pitch_rad: float | None = None) -> None:
    q = simulation.trajectory.q[index].copy()
    if torso_pitch_rad is not None:
        q[7 + simulation.robot.joint_index("torso_pitch")] = torso_pitch_rad
    simulation.scene.set_time(float(simulation.trajectory.times_s[index]))
    simulation.scene.set_robot_qpos(simulation.robot.qpos_mujoco(q))
    simulation.scene.forward()


def test_stage_walk_depth_is_the_same_with_most_of_the_robot_culled(stage_walk):
    """Every 16th frame of the walk, and bowing so that the legs and feet are in view."""
    scene = stage_walk.scene
    camera_id = scene.camera_ids["head_camera"]
    depth = RendererDepth(scene.model, INTRINSICS)
    reference = mujoco.Renderer(scene.model, INTRINSICS.height, INTRINSICS.width)
    reference.enable_depth_rendering()
    culling = FrustumCulling(scene.model, INTRINSICS, VISIBLE_GEOMGROUPS)
    chest, head = (
        mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_GEOM, f"icub/{name}_0")
        for name in ("chest", "head")
    )
    far_m = float(scene.model.vis.map.zfar * scene.model.stat.extent)
    try:
        poses = [(i, None) for i in range(0, stage_walk.frame_count, 16)] + [(0, 1.1), (400, 1.1)]
        for index, torso_pitch_rad in poses:
            _pose(stage_walk, index, torso_pitch_rad)
            assert {chest, head} <= set(culling.outside(scene.data, camera_id).tolist())
            expected = _unculled_depth(reference, scene.data, camera_id, far_m)
            np.testing.assert_array_equal(depth.render(scene.data, camera_id), expected)
        robot_geoms = np.flatnonzero(scene.model.geom_bodyid > 0)
        seen = np.setdiff1d(robot_geoms, culling.outside(scene.data, camera_id))
        assert _names(scene.model, seen) >= {"icub/l_foot_0", "icub/r_foot_0"}  # bowing
    finally:
        depth.close()
        reference.close()


def test_stage_walk_stereo_images_are_the_same_with_the_robot_culled(monkeypatch):
    """The stereo mode's left and right grey images, every 104th frame, culled and not."""
    scenario = load_scenario("stage").with_overrides(["camera.mode=stereo"])
    with Simulation(scenario) as simulation:
        matcher = simulation.camera._stereo
        assert matcher is not None
        scene = simulation.scene
        culling = FrustumCulling(scene.model, matcher.intrinsics_render, VISIBLE_GEOMGROUPS)
        every_group = tuple(range(mujoco.mjNGROUP))
        for index in range(0, simulation.frame_count, 104):
            _pose(simulation, index)
            for name in ("head_camera_left", "head_camera_right"):
                camera_id = scene.camera_ids[name]
                assert culling.outside(scene.data, camera_id).size > 0
                monkeypatch.setattr(matcher, "_culling", culling)
                culled = matcher.grey_image(scene.data, camera_id, np.random.default_rng(index))
                monkeypatch.setattr(
                    matcher, "_culling", FrustumCulling(scene.model, INTRINSICS, every_group)
                )
                unculled = matcher.grey_image(scene.data, camera_id, np.random.default_rng(index))
                np.testing.assert_array_equal(culled, unculled)
