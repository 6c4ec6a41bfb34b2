"""fogsim: a MuJoCo testbed for the floor and obstacle height map of Gutmann et al.

The public API is imported lazily (``import fogsim`` stays cheap and needs no MuJoCo):

* ``Frame`` — the per-frame contract (``fogsim.data.frame``);
* ``load_scenario``, ``find_scenario_files`` (``fogsim.config``);
* ``resolve_params`` (``fogsim.config``); ``run_frames``, ``replay_report``,
  ``run_scenario`` (``fogsim.run.runner``);
* ``save_recording``, ``load_recording``, ``Recording`` (``fogsim.data.recording``);
* ``run_suite`` (``fogsim.run.suite``); ``main`` (the command line).
"""

from __future__ import annotations

import os

from fogsim.lazy import lazy_getattr

# Rendering is headless: MuJoCo picks its OpenGL backend from these when it is first imported,
# so they are set (unless the user chose otherwise) before any fogsim module imports it.
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")

__version__ = "0.1.0"

_EXPORTS = {
    "Frame": "fogsim.data.frame",
    "load_scenario": "fogsim.config",
    "find_scenario_files": "fogsim.config",
    "run_frames": "fogsim.run.runner",
    "replay_report": "fogsim.run.runner",
    "resolve_params": "fogsim.config",
    "save_recording": "fogsim.data.recording",
    "load_recording": "fogsim.data.recording",
    "Recording": "fogsim.data.recording",
    "run_scenario": "fogsim.run.runner",
    "run_suite": "fogsim.run.suite",
    "main": "fogsim.cli",
}

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_getattr(__name__, _EXPORTS)
