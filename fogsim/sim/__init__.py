"""Layer 5 — simulation: the MuJoCo scene, the head camera and the per-frame simulation loop.

* :mod:`fogsim.sim.assets` — the MJCF pieces of ``assets/mjcf/``;
* :mod:`fogsim.sim.scene` — :class:`Scene`, a scenario compiled into MuJoCo;
* :mod:`fogsim.sim.camera` — :class:`HeadCamera` and its parts (depth, stereo);
* :mod:`fogsim.sim.simulation` — :class:`Simulation`, the robot walking its route, frames out;
* :mod:`fogsim.sim.third_person` — the robot seen from a camera following it, for the video.
"""

from fogsim.sim.camera import HeadCamera
from fogsim.sim.scene import Scene
from fogsim.sim.simulation import Simulation

__all__ = ["HeadCamera", "Scene", "Simulation"]
