"""Layer 5 — simulation: the MuJoCo scene, the head camera and the per-frame simulation loop.

* :mod:`fogsim.sim.assets` — the MJCF pieces of ``assets/mjcf/``;
* :mod:`fogsim.sim.scene` — :class:`Scene`, a scenario compiled into MuJoCo;
* :mod:`fogsim.sim.camera` — :class:`HeadCamera` and its parts (depth, stereo);
* :mod:`fogsim.sim.simulation` — :class:`Simulation`, the robot walking its route, frames out;
* :mod:`fogsim.sim.third_person` — the robot seen from a camera following it, for the video.
"""

from fogsim.lazy import lazy_getattr

_EXPORTS = {
    "HeadCamera": "fogsim.sim.camera",
    "Scene": "fogsim.sim.scene",
    "Simulation": "fogsim.sim.simulation",
}
"""The package's names and their modules, imported on first use: a replay imports
:mod:`fogsim.sim.background` and :mod:`fogsim.sim.camera.noise_model` only, never MuJoCo."""

__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr(__name__, _EXPORTS)
