"""fogsim: a MuJoCo testbed for the floor and obstacle height map of Gutmann et al.

The public API is imported lazily (``import fogsim`` stays cheap and needs no MuJoCo):

* ``Frame`` — the per-frame contract (``fogsim.frames``);
* ``load_scenario``, ``list_scenarios`` (``fogsim.scenario``);
* ``run_frames``, ``replay_report``, ``resolve_params`` (``fogsim.pipeline``);
* ``save_recording``, ``load_recording``, ``Recording`` (``fogsim.recording``);
* ``run_scenario``, ``run_suite`` (``fogsim.suite``); ``main`` (the command line).
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

_EXPORTS = {
    "Frame": "fogsim.frames",
    "load_scenario": "fogsim.scenario",
    "list_scenarios": "fogsim.scenario",
    "run_frames": "fogsim.pipeline",
    "replay_report": "fogsim.pipeline",
    "resolve_params": "fogsim.pipeline",
    "save_recording": "fogsim.recording",
    "load_recording": "fogsim.recording",
    "Recording": "fogsim.recording",
    "run_scenario": "fogsim.suite",
    "run_suite": "fogsim.suite",
    "main": "fogsim.cli",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'fogsim' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)
