"""Old import path of the scenario API, kept until its consumers import from ``fogsim.config``.

Only re-exports; ``list_scenarios`` is :func:`fogsim.config.find_scenario_files`.
"""

from fogsim.config.load import find_scenario_files as list_scenarios
from fogsim.config.load import load_scenario
from fogsim.config.schema import (
    CAMERA_MODES,
    ROBOT_MODELS,
    CameraConfig,
    EncoderConfig,
    Scenario,
    SceneObject,
    scenario_from_dict,
)

__all__ = [
    "CAMERA_MODES",
    "ROBOT_MODELS",
    "CameraConfig",
    "EncoderConfig",
    "Scenario",
    "SceneObject",
    "list_scenarios",
    "load_scenario",
    "scenario_from_dict",
]
