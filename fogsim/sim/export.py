"""A scenario's built MuJoCo scene as an MJCF file (and its textures), for MuJoCo's own viewer.

``python -m mujoco.viewer --mjcf scene.xml`` opens the file: the stage, its objects and the robot
(or the free camera rig) exactly as :func:`fogsim.sim.scene.build_scene_mjcf` builds them. The
files the MJCF names by their content hash — the generated surface textures (``assets/mjcf/
textures.toml``, PNG), the meshes (the robot's and the boxes', MuJoCo's binary ``.msh``) and
the height fields (MuJoCo's binary height-field files, ``.bin``) — are written beside the XML
file, so the folder holding ``scene.xml`` is all the viewer needs. The file holds
one keyframe, ``start``: the robot standing at the first sample of its planned walk and every
moving object where the events put it at time 0. Load it in the viewer's *Simulation* panel
(*Key*, then *Load key*): the viewer opens at the model's reference pose, and its physics lets
the robot fall, since the testbed only ever poses it.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from fogsim.atomic import write_atomic, write_text_atomic
from fogsim.config import Scenario
from fogsim.sim.scene import build_scene_mjcf
from fogsim.sim.simulation import Simulation

START_KEYFRAME = "start"
"""Name of the keyframe holding the state at the run's first frame."""


def scene_xml(scenario: Scenario) -> tuple[str, dict[str, bytes]]:
    """The MJCF text of the scenario's scene with the ``start`` keyframe, and its asset files.

    The state comes from a :class:`~fogsim.sim.simulation.Simulation` at its first frame
    (ray-cast depth backend: no OpenGL needed). A stereo camera needs rendered images, which
    the ray-cast backend cannot give, so that simulation runs the ``depth`` mode instead: the
    camera mode changes what the camera measures, not the robot's walk or the objects' state;
    the model saved is built from the scenario as it is.

    Returns:
        The MJCF text and the files it names (file name → content), to be written beside it.
    """
    posed = scenario
    if scenario.camera.mode == "stereo":
        posed = replace(scenario, camera=replace(scenario.camera, mode="depth"))
    simulation = Simulation(posed, depth_backend="raycast")
    root = build_scene_mjcf(scenario, simulation.robot)
    assets = dict(sorted(root.get_assets().items()))
    data = simulation.scene.data
    key = root.keyframe.add("key", name=START_KEYFRAME, time=0.0, qpos=data.qpos.copy())
    if data.mocap_pos.size:  # MuJoCo refuses empty mocap attributes
        # The MJCF places mocap bodies at the scenario's positions; an event at time 0 differs.
        key.mpos = data.mocap_pos.ravel().copy()
        key.mquat = data.mocap_quat.ravel().copy()
    return root.to_xml_string(), assets


def export_scene(scenario: Scenario, path: str | os.PathLike[str]) -> Path:
    """Write the scenario's scene (:func:`scene_xml`) to ``path`` and its assets beside it.

    Every file is written atomically, the assets first (their names are content hashes, so an
    earlier export's are either the same bytes or not named by the new XML file).

    Returns:
        The path of the XML file.

    Raises:
        OutputError: A file cannot be written.
    """
    text, assets = scene_xml(scenario)
    folder = Path(path).parent
    for name, content in assets.items():
        write_atomic(folder / name, lambda stream, data=content: stream.write(data))
    return write_text_atomic(path, text)
