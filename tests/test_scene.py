"""Scenes from scenarios: named elements, events, rough tops, the attached robot."""

from __future__ import annotations

import dataclasses
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path
from xml.etree import ElementTree

import mujoco
import numpy as np
import pytest

from fogsim.config import load_scenario
from fogsim.errors import FogsimError
from fogsim.robot.mj_xml import model_from_xml_string
from fogsim.robot.mjcf import mjcf_files
from fogsim.robot.model import CAMERA_NAMES, load_robot
from fogsim.sim import model_cache
from fogsim.sim.assets import MJCF_DIR, load_mjcf_piece
from fogsim.sim.model_cache import content_key, model_cache_dir
from fogsim.sim.scene import (
    TERRAIN_MIN_SPAN_M,
    Scene,
    box_mesh,
    build_scene_mjcf,
    compile_scene,
    rough_elevation,
    scene_key,
)
from fogsim.world import SceneTruth, object_center_at

ROOT = Path(__file__).resolve().parent.parent


def ray_down(scene: Scene, xy) -> np.ndarray:
    """Height [m] of the first surface hit by vertical rays cast from 5 m down at points xy."""
    heights = []
    geomid = np.zeros(1, dtype=np.int32)
    groups = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)
    for x, y in xy:
        dist = mujoco.mj_ray(
            scene.model,
            scene.data,
            np.array([x, y, 5.0]),
            np.array([0.0, 0.0, -1.0]),
            groups,
            1,
            -1,
            geomid,
        )
        heights.append(5.0 - dist)
    return np.array(heights)


def test_every_object_is_named_and_placed():
    scenario = load_scenario("stage")
    scene = Scene(scenario)
    for obj in scenario.objects:
        assert scene.model.body(f"obj_{obj.name}").id > 0
        # A box geom sits at the box centre; a rough top's height field at the base of its bumps.
        z_geom = obj.size[2] - obj.roughness_m if obj.surface == "rough" else obj.size[2] / 2
        np.testing.assert_allclose(
            scene.data.geom(f"geom_{obj.name}").xpos,
            [*obj.center, obj.base + z_geom],
            atol=1e-12,
        )
    assert scene.model.geom("floor").id >= 0
    assert set(scene.camera_ids) == set(CAMERA_NAMES)
    assert not scene.has_robot
    # Tops seen from above are the scenario's heights (the stage's Table I surfaces).
    xy = [[1.2, 0.5], [2.7, 0.5], [2.9, 0.5], [3.1, 0.5], [3.6, 0.5], [0.3, 0.5]]
    np.testing.assert_allclose(
        ray_down(scene, xy), [0.038, 0.031, 0.061, 0.092, 0.122, 0.0], atol=1e-9
    )
    truth = SceneTruth.from_scenario(scenario, 0.0)
    np.testing.assert_allclose(ray_down(scene, xy), truth.support_height_m(xy), atol=1e-9)


def test_events_remove_and_move_objects():
    removal = load_scenario("box_removal")
    scene = Scene(removal)
    at = removal.events[0].at
    center = removal.object("flat_box").center
    scene.set_time(at - 0.1)
    scene.forward()
    assert ray_down(scene, [center])[0] == pytest.approx(0.05, abs=1e-9)
    scene.set_time(at)
    scene.forward()
    assert ray_down(scene, [center])[0] == pytest.approx(0.0, abs=1e-9)

    moving = load_scenario("moving_box")
    scene = Scene(moving)
    for t in (0.0, 3.0, 7.5, 30.0):
        scene.set_time(t)
        scene.forward()
        expected = object_center_at(moving, "flat_box", t)
        np.testing.assert_allclose(scene.data.geom("geom_flat_box").xpos[:2], expected, atol=1e-12)


def test_rough_tops_are_bumpy_deterministic_and_bounded():
    world = load_scenario("simulated_world")
    rough = [o for o in world.objects if o.surface == "rough"]
    a = rough_elevation(rough[0], world.seed, 2)
    np.testing.assert_array_equal(a, rough_elevation(rough[0], world.seed, 2))
    assert not np.array_equal(a, rough_elevation(rough[0], world.seed + 1, 2))
    assert a.min() == 0.0 and a.max() == 1.0
    scene = Scene(world)
    obj = rough[0]
    xs = np.linspace(-0.4, 0.4, 21) * obj.size[0] + obj.center[0]
    ys = np.linspace(-0.4, 0.4, 21) * obj.size[1] + obj.center[1]
    grid = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    tops = ray_down(scene, grid)
    assert tops.max() <= obj.top_m + 1e-9
    assert tops.min() >= obj.top_m - obj.roughness_m - 1e-9
    assert tops.std() > 0.15 * obj.roughness_m  # no plane: iid bumps, bilinear in between
    assert np.ptp(tops) > 0.5 * obj.roughness_m


def test_camera_rig_pose_round_trip():
    scene = Scene(load_scenario("flat_floor"))
    t = np.eye(4)
    t[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    t[:3, 3] = [0.3, 0.5, 0.9]
    scene.set_camera_rig_pose(t)
    scene.forward()
    np.testing.assert_allclose(scene.camera_to_world(), t, atol=1e-12)
    rel = scene.transform_between_cameras("head_camera_left", "head_camera")
    np.testing.assert_allclose(rel[:3, 3], [-0.035, 0.0, 0.0], atol=1e-12)
    with pytest.raises(FogsimError, match="no robot"):
        scene.set_robot_qpos(np.zeros(7))


@pytest.fixture(scope="module")
def robot():
    return load_robot("icub")


def test_attached_robot_cameras_match_pinocchio(robot):
    scene = Scene(load_scenario("stage"), robot)
    assert scene.has_robot
    rng = np.random.default_rng(4)
    for _ in range(3):
        q = robot.neutral()
        q[:3] = rng.uniform([0, 0, 0.5], [3, 1, 0.7])
        q[7:] = rng.uniform(-0.3, 0.3, robot.n_joints)
        scene.set_robot_qpos(robot.qpos_mujoco(q))
        scene.forward()
        for name in CAMERA_NAMES:
            np.testing.assert_allclose(
                scene.camera_to_world(name), robot.transform_camera_to_world(q, name), atol=1e-9
            )
    # The robot's own meshes are in a rendered group, so the camera can see its body.
    robot_geoms = [
        g for g in range(scene.model.ngeom) if scene.model.geom(g).name.startswith("icub/")
    ]
    assert robot_geoms
    assert set(scene.model.geom_group[robot_geoms]) <= set(scene.render_geomgroups)
    with pytest.raises(FogsimError, match="has a robot"):
        scene.set_camera_rig_pose(np.eye(4))


def test_render_and_depth_buffer_settings_come_from_the_asset_pieces():
    scene = Scene(load_scenario("simulated_world"))
    model = scene.model
    assert model.names.split(b"\0", 1)[0] == b"fogsim_simulated_world"
    # Depth buffer: 5 cm near and 20 m far plane (MuJoCo scales both by the extent; float32).
    assert model.stat.extent == 10.0
    assert model.vis.map.znear * model.stat.extent == pytest.approx(0.05, rel=1e-6)
    assert model.vis.map.zfar * model.stat.extent == pytest.approx(20.0, rel=1e-6)
    assert model.vis.quality.shadowsize == 0 and model.vis.quality.offsamples == 0
    assert (model.vis.global_.offwidth, model.vis.global_.offheight) == (640, 480)
    assert not model.light_castshadow[model.light("sun").id]
    # Objects' materials are of class "object": the box texture, repeated 2 x 2 by the meshes'
    # texture coordinates (not texuniform: that streaks a flat box's top, materials.xml).
    tex_box = model.texture("tex_box").id
    for obj in load_scenario("simulated_world").objects:
        material = model.material(f"mat_{obj.name}").id
        assert tex_box in model.mat_texid[material]
        assert not model.mat_texuniform[material]
        np.testing.assert_array_equal(model.mat_texrepeat[material], [2.0, 2.0])
    floor = model.material("mat_floor").id
    assert model.texture("tex_speckle").id in model.mat_texid[floor]
    # Every element is named (the world body is MuJoCo's own).
    counts = {
        mujoco.mjtObj.mjOBJ_BODY: model.nbody,
        mujoco.mjtObj.mjOBJ_GEOM: model.ngeom,
        mujoco.mjtObj.mjOBJ_CAMERA: model.ncam,
        mujoco.mjtObj.mjOBJ_LIGHT: model.nlight,
        mujoco.mjtObj.mjOBJ_TEXTURE: model.ntex,
        mujoco.mjtObj.mjOBJ_MATERIAL: model.nmat,
        mujoco.mjtObj.mjOBJ_HFIELD: model.nhfield,
    }
    for kind, count in counts.items():
        assert count > 0
        assert all(mujoco.mj_id2name(model, kind, i) for i in range(count)), kind


def test_every_piece_loads_and_an_unknown_piece_names_the_pieces():
    pieces = sorted(p.stem for p in MJCF_DIR.glob("*.xml"))
    assert pieces == ["camera_rig", "floor", "lighting", "materials", "visual"]
    for name in pieces:
        assert load_mjcf_piece(name).model == name
    with pytest.raises(FogsimError, match=r"no MJCF piece 'sky'.*camera_rig, floor, lighting"):
        load_mjcf_piece("sky")


def _model_bytes(model: mujoco.MjModel) -> bytes:
    buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer.tobytes()


def test_cached_scene_is_the_compiled_scene_and_a_changed_scenario_misses(tmp_path, monkeypatch):
    monkeypatch.setenv("FOGSIM_CACHE", str(tmp_path))
    scenario = load_scenario("stage")
    first = Scene(scenario)  # compiles and saves
    files = sorted(model_cache_dir().glob("*.mjb"))
    assert [f.name for f in files] == [f"{scene_key(scenario, None)}.mjb"]
    second = Scene(scenario)  # loads
    assert sorted(model_cache_dir().glob("*.mjb")) == files
    fresh = compile_scene(scenario, None)
    assert _model_bytes(first.model) == _model_bytes(second.model) == _model_bytes(fresh)
    assert first.camera_ids == second.camera_ids
    assert first._mocap_ids == second._mocap_ids
    assert first._rig_mocap_id == second._rig_mocap_id
    assert second.physics.data.ptr is second.data  # dm_control's view shares the state

    moved = scenario.objects[0]
    changed = dataclasses.replace(
        scenario,
        objects=(
            dataclasses.replace(moved, center=(moved.center[0] + 0.01, moved.center[1])),
            *scenario.objects[1:],
        ),
    )
    assert scene_key(changed, None) != scene_key(scenario, None)
    body = f"obj_{moved.name}"
    assert Scene(changed).model.body(body).pos[0] == pytest.approx(
        first.model.body(body).pos[0] + 0.01
    )
    assert len(list(model_cache_dir().glob("*.mjb"))) == 2
    reseeded = dataclasses.replace(scenario, seed=scenario.seed + 1)
    assert scene_key(reseeded, None) != scene_key(scenario, None)
    narrower = dataclasses.replace(scenario.camera, fov_deg=(40.0, 30.0))
    assert scene_key(dataclasses.replace(scenario, camera=narrower), None) != scene_key(
        scenario, None
    )
    # The camera's mode and noise do not enter the model: the compiled scene is reused.
    stereo = dataclasses.replace(scenario.camera, mode="stereo", dropout=0.5)
    assert scene_key(dataclasses.replace(scenario, camera=stereo), None) == scene_key(
        scenario, None
    )


def test_model_cache_keeps_the_most_recently_used(tmp_path, monkeypatch):
    monkeypatch.setenv("FOGSIM_CACHE", str(tmp_path))
    monkeypatch.setattr(model_cache, "MAX_CACHED_MODELS", 2)
    compiled = []

    def compile_box(size: float):
        compiled.append(size)
        return mujoco.MjModel.from_xml_string(
            f'<mujoco><worldbody><geom type="box" size="{size} 1 1"/></worldbody></mujoco>'
        )

    for size in (1.0, 2.0):
        model_cache.load_or_compile(f"k{size}", lambda size=size: compile_box(size))
        time.sleep(0.01)
    model = model_cache.load_or_compile("k1.0", lambda: compile_box(9.0))  # hit: used again
    assert model.geom_size[0, 0] == 1.0 and compiled == [1.0, 2.0]
    time.sleep(0.01)
    model_cache.load_or_compile("k3.0", lambda: compile_box(3.0))
    names = sorted(p.name for p in model_cache_dir().glob("*.mjb"))
    assert names == ["k1.0.mjb", "k3.0.mjb"]
    assert content_key((b"ab", b"c")) != content_key((b"a", b"bc"))


def test_a_cached_scene_is_loaded_without_dm_control(tmp_path):
    """dm_control (a quarter second of imports) builds scenes; a cached one does without it."""
    code = (
        "import sys\n"
        "from fogsim.config import load_scenario\n"
        "from fogsim.sim.scene import Scene\n"
        "Scene(load_scenario('flat_floor'))\n"
        "print(any(name.startswith('dm_control') for name in sys.modules))\n"
    )
    env = {**os.environ, "FOGSIM_CACHE": str(tmp_path), "PYTHONPATH": str(ROOT)}
    imported = [
        subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        ).stdout.split()[-1]
        for _ in range(2)
    ]
    assert imported == ["True", "False"]  # built (and cached) by the first, loaded by the second


def _as_text_attributes(xml: str, assets: dict[str, bytes]) -> str:
    """``xml`` with every ``.msh`` mesh and binary height field written as numbers in text.

    Reads the files as MuJoCo's documentation describes them (not with fogsim's writer), so
    the text is the MJCF of the same numbers as the files: the attributes the scene once had.
    """
    root = ElementTree.fromstring(xml)
    numbers = lambda values: " ".join(repr(v.item()) for v in values)  # noqa: E731
    for mesh in root.iter("mesh"):
        data = assets[mesh.attrib.pop("file")]
        nvert, nnormal, ntex, nface = np.frombuffer(data[:16], "<i4")
        arrays = np.split(
            np.frombuffer(data[16:], "<f4"), np.cumsum([3 * nvert, 3 * nnormal, 2 * ntex])
        )
        assert nnormal == 0 and arrays[3].size == 3 * nface  # faces are int32: same size
        mesh.set("vertex", numbers(arrays[0]))
        mesh.set("face", numbers(arrays[3].view("<i4")))
        if ntex:
            mesh.set("texcoord", numbers(arrays[2]))
    for hfield in root.iter("hfield"):
        data = assets[hfield.attrib.pop("file")]
        nrow, ncol = np.frombuffer(data[:8], "<i4")
        heights = np.frombuffer(data[8:], "<f4").reshape(nrow, ncol)
        hfield.set("nrow", str(nrow))
        hfield.set("ncol", str(ncol))
        hfield.set("elevation", numbers(heights[::-1].ravel()))  # MuJoCo flips its rows
    return ElementTree.tostring(root, encoding="unicode")


# stage: box meshes, rough tops, iCub; eth_stairs: the largest height field; talos_course: TALOS.
@pytest.mark.parametrize("name", ["stage", "eth_stairs", "talos_course"])
def test_meshes_and_heights_as_files_compile_to_the_model_of_the_same_numbers_as_text(name):
    scenario = load_scenario(name)
    robot = load_robot(scenario.robot.model)
    root = build_scene_mjcf(scenario, robot)
    xml, assets = root.to_xml_string(), root.get_assets()
    longest = max(len(v) for e in ElementTree.fromstring(xml).iter() for v in e.attrib.values())
    assert longest < 300  # no long numeric text for MuJoCo to parse
    text_xml = _as_text_attributes(xml, assets)
    assert len(text_xml) > 10 * len(xml)
    files = compile_scene(scenario, robot)
    text = model_from_xml_string(text_xml, assets)
    assert files.nmesh == text.nmesh > 0 and files.nhfield == text.nhfield > 0
    compared = 0
    for field in dir(files):
        value = getattr(files, field)
        # Every array but the file names (paths, and _sizes holding their count and length).
        if isinstance(value, np.ndarray) and "path" not in field and field != "_sizes":
            np.testing.assert_array_equal(value, getattr(text, field), err_msg=field)
            compared += 1
    assert compared > 200
    # The files hold the scene's own numbers (as float32, what MuJoCo keeps of text too).
    named = {
        e.get("name"): e.get("file") for e in ElementTree.fromstring(xml).iter() if e.get("file")
    }
    for index, obj in enumerate(scenario.objects):
        if obj.heightfield is not None:  # a terrain: its heights from its lowest over its span
            heights_m = obj.heightfield_m()
            elevation = (heights_m - heights_m.min()) / max(np.ptp(heights_m), TERRAIN_MIN_SPAN_M)
        elif obj.surface == "rough":
            elevation = rough_elevation(obj, scenario.seed, index)
        else:
            vertices, faces, texcoords = box_mesh(obj.size)
            expected = (vertices.astype("<f4"), texcoords.astype("<f4"), faces.astype("<i4"))
            data = assets[named[f"mesh_{obj.name}"]]
            assert data[16:] == b"".join(a.tobytes() for a in expected)
            continue
        heights = np.frombuffer(assets[named[f"hf_{obj.name}"]][8:], "<f4")
        np.testing.assert_array_equal(heights, elevation[::-1].ravel().astype(np.float32))


def test_the_scene_key_reads_the_robot_mesh_files(robot, tmp_path):
    """The key is of the robot's MJCF and mesh contents: a changed mesh is a new scene."""
    scenario = load_scenario("stage")
    folder = robot.mjcf_path.with_suffix("")
    copy = tmp_path / robot.mjcf_path.name
    shutil.copy(robot.mjcf_path, copy)
    shutil.copytree(folder, tmp_path / folder.name)
    moved = dataclasses.replace(robot, mjcf_path=copy)
    assert scene_key(scenario, moved) == scene_key(scenario, robot)  # contents, not place
    mesh = mjcf_files(copy)[-1]
    data = bytearray(mesh.read_bytes())
    data[16] ^= 1  # the lowest bit of the first vertex's x (after the 16-byte header)
    mesh.write_bytes(bytes(data))
    assert scene_key(scenario, moved) != scene_key(scenario, robot)
