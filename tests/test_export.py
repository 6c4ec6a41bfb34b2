"""The scene exported for MuJoCo's viewer: the XML and its files, the built model, frame 0."""

import dataclasses
from pathlib import Path
from xml.etree import ElementTree

import mujoco
import numpy as np
import pytest

from fogsim.cli import main
from fogsim.config import load_scenario
from fogsim.robot.model import load_robot
from fogsim.sim.export import START_KEYFRAME, export_scene
from fogsim.sim.scene import PARKED_Z_M, compile_scene
from fogsim.sim.simulation import Simulation

OBJECT_KINDS = (
    mujoco.mjtObj.mjOBJ_BODY,
    mujoco.mjtObj.mjOBJ_GEOM,
    mujoco.mjtObj.mjOBJ_JOINT,
    mujoco.mjtObj.mjOBJ_CAMERA,
    mujoco.mjtObj.mjOBJ_MESH,
    mujoco.mjtObj.mjOBJ_HFIELD,
    mujoco.mjtObj.mjOBJ_MATERIAL,
    mujoco.mjtObj.mjOBJ_TEXTURE,
)
COUNTS = {
    mujoco.mjtObj.mjOBJ_BODY: "nbody",
    mujoco.mjtObj.mjOBJ_GEOM: "ngeom",
    mujoco.mjtObj.mjOBJ_JOINT: "njnt",
    mujoco.mjtObj.mjOBJ_CAMERA: "ncam",
    mujoco.mjtObj.mjOBJ_MESH: "nmesh",
    mujoco.mjtObj.mjOBJ_HFIELD: "nhfield",
    mujoco.mjtObj.mjOBJ_MATERIAL: "nmat",
    mujoco.mjtObj.mjOBJ_TEXTURE: "ntex",
}


def names(model, kind):
    return [mujoco.mj_id2name(model, kind, i) for i in range(getattr(model, COUNTS[kind]))]


# stage: rough tops (height fields), the robot's meshes; box_removal: a mocap object.
@pytest.mark.parametrize("name", ["stage", "box_removal"])
def test_the_saved_scene_is_the_built_model_and_starts_at_the_first_frame(tmp_path, name):
    scenario = load_scenario(name)
    path = export_scene(scenario, tmp_path / "scene.xml")
    named = sorted(e.attrib["file"] for e in ElementTree.parse(path).iter() if "file" in e.attrib)
    kinds = {Path(file).suffix for file in named}  # textures, meshes, height fields (stage)
    assert kinds == ({".png", ".msh", ".bin"} if name == "stage" else {".png", ".msh"})
    # The XML and the files it names, nothing else (no temporary left).
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted({*named, "scene.xml"})
    longest = max(len(v) for e in ElementTree.parse(path).iter() for v in e.attrib.values())
    assert longest < 600  # the keyframe's qpos; no mesh or height field as text

    saved = mujoco.MjModel.from_xml_path(str(path))
    simulation = Simulation(scenario, depth_backend="raycast")  # at its first frame
    built = simulation.scene.model
    for kind in OBJECT_KINDS:
        assert names(saved, kind) == names(built, kind), kind
    assert names(saved, mujoco.mjtObj.mjOBJ_BODY)[-1].startswith(f"{scenario.robot.model}/")
    assert saved.nhfield == sum(o.surface == "rough" for o in scenario.objects)
    assert (saved.nq, saved.nv, saved.nmocap) == (built.nq, built.nv, built.nmocap)
    for field in (
        *("body_pos", "body_quat", "geom_size", "geom_pos", "geom_rgba", "mesh_vertnum"),
        *("mesh_vert", "mesh_face", "mesh_texcoord", "mesh_normal", "hfield_data"),
    ):
        np.testing.assert_array_equal(getattr(saved, field), getattr(built, field), err_msg=field)

    assert saved.nkey == 1 and saved.key(0).name == START_KEYFRAME
    data = mujoco.MjData(saved)
    mujoco.mj_resetDataKeyframe(saved, data, 0)
    mujoco.mj_kinematics(saved, data)
    np.testing.assert_allclose(data.xpos, simulation.scene.data.xpos, atol=1e-12)
    np.testing.assert_allclose(data.xmat, simulation.scene.data.xmat, atol=1e-12)
    assert not np.allclose(data.qpos[7:], 0.0)  # the walk's first pose, not the reference one


def test_an_object_removed_at_time_zero_starts_parked(tmp_path):
    scenario = load_scenario("box_removal")
    (event,) = scenario.events
    scenario = dataclasses.replace(scenario, events=(dataclasses.replace(event, at=0.0),))
    saved = mujoco.MjModel.from_xml_path(str(export_scene(scenario, tmp_path / "scene.xml")))
    data = mujoco.MjData(saved)
    mujoco.mj_resetDataKeyframe(saved, data, 0)
    mujoco.mj_kinematics(saved, data)
    assert data.body(f"obj_{event.remove}").xpos[2] == PARKED_Z_M  # out of view, as in the run


def test_fogsim_scene_saves_a_file_mujoco_loads(tmp_path, capsys):
    path = tmp_path / "scene.xml"
    assert main(["scene", "flat_floor", "--out", str(path), "--seed", "3"]) == 0
    assert f"python -m mujoco.viewer --mjcf {path}" in capsys.readouterr().out
    assert mujoco.MjModel.from_xml_path(str(path)).nkey == 1
    assert main(["scene", "flat_floor", "--out", str(tmp_path)]) == 2  # a folder
    assert "--out" in capsys.readouterr().err


def test_a_stereo_scenario_saves_its_own_model_posed_as_its_depth_run(tmp_path):
    """`untextured` runs a stereo head, which the ray-cast backend refuses: the saved model is
    the stereo scenario's, the keyframe the start of the same walk in depth mode."""
    scenario = load_scenario("untextured")
    assert scenario.camera.mode == "stereo"
    path = tmp_path / "scene.xml"
    assert main(["scene", "untextured", "--out", str(path)]) == 0
    saved = mujoco.MjModel.from_xml_path(str(path))
    built = compile_scene(scenario, load_robot(scenario.robot.model))
    assert saved.nbody == built.nbody and saved.ncam == built.ncam == 3  # head, left, right
    assert (saved.vis.global_.offwidth, saved.vis.global_.offheight) == (
        built.vis.global_.offwidth,
        built.vis.global_.offheight,
    )
    depth = dataclasses.replace(scenario, camera=dataclasses.replace(scenario.camera, mode="depth"))
    start = Simulation(depth, depth_backend="raycast").scene.data.qpos
    np.testing.assert_array_equal(saved.key(0).qpos, start)
