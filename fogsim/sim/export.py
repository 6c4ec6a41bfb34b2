"""A scenario's built MuJoCo scene as one self-contained MJCF file, for MuJoCo's own viewer.

``python -m mujoco.viewer --mjcf scene.xml`` opens the file: the stage, its objects and the robot
(or the free camera rig) exactly as :func:`fogsim.sim.scene.build_scene_mjcf` builds them —
robot meshes and height fields inline, textures built in, no other file needed. The file holds
one keyframe, ``start``: the robot standing at the first sample of its planned walk and every
moving object where the events put it at time 0. Load it in the viewer's *Simulation* panel
(*Key*, then *Load key*): the viewer opens at the model's reference pose, and its physics lets
the robot fall, since the testbed only ever poses it.
"""

from __future__ import annotations

import os
from pathlib import Path

from fogsim.atomic import write_text_atomic
from fogsim.config import Scenario
from fogsim.errors import FogsimError
from fogsim.sim.scene import build_scene_mjcf
from fogsim.sim.simulation import Simulation

START_KEYFRAME = "start"
"""Name of the keyframe holding the state at the run's first frame."""


def scene_xml(scenario: Scenario) -> str:
    """The MJCF text of the scenario's scene with the ``start`` keyframe.

    The state comes from a :class:`~fogsim.sim.simulation.Simulation` at its first frame
    (ray-cast depth backend: no OpenGL needed).

    Raises:
        FogsimError: The scene refers to asset files (the text would not stand alone).
    """
    simulation = Simulation(scenario, depth_backend="raycast")
    root = build_scene_mjcf(scenario, simulation.robot)
    assets = sorted(root.get_assets())
    if assets:
        raise FogsimError(
            f"scene of {scenario.name!r} refers to asset files {assets}; the export writes one "
            "self-contained MJCF file"
        )
    data = simulation.scene.data
    key = root.keyframe.add("key", name=START_KEYFRAME, time=0.0, qpos=data.qpos.copy())
    if data.mocap_pos.size:  # MuJoCo refuses empty mocap attributes
        # The MJCF places mocap bodies at the scenario's positions; an event at time 0 differs.
        key.mpos = data.mocap_pos.ravel().copy()
        key.mquat = data.mocap_quat.ravel().copy()
    return root.to_xml_string()


def export_scene(scenario: Scenario, path: str | os.PathLike[str]) -> Path:
    """Write the scenario's scene (:func:`scene_xml`) to ``path`` atomically; returns the path.

    Raises:
        FogsimError: See :func:`scene_xml`.
        OutputError: The file cannot be written.
    """
    return write_text_atomic(path, scene_xml(scenario))
