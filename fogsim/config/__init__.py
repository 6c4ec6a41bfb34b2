"""Layer 1 — configuration: the scenario schema, loading and writing scenario files, run parameters.

Modules (each imports only those above it): ``limits`` (what a scenario may ask for: name
pattern, file size, frame rate, counts, sizes), ``decode`` (msgspec decoding with errors naming
file, key, value and what is allowed), ``params`` (run parameters, the one mapping → parameter
dataclass helper), ``overrides`` (``--set KEY=VALUE``), ``write`` (TOML with ``tomli_w``),
``schema`` (the scenario's frozen dataclasses), ``load`` (finding and loading scenario files).
"""

from fogsim.config.load import find_scenario_files, load_scenario, scenario_from_toml
from fogsim.config.params import (
    OVERRIDE_PREFIXES,
    PipelineParams,
    RunParams,
    override_key,
    replace_params,
    resolve_params,
    split_override_key,
)
from fogsim.config.schema import (
    CAMERA_MODES,
    EVENT_KINDS,
    ROBOT_MODELS,
    ROUTE_KINDS,
    SURFACES,
    CameraConfig,
    EncoderConfig,
    Event,
    RobotSpec,
    RouteStep,
    Scenario,
    SceneObject,
    scenario_from_dict,
)

__all__ = [
    "CAMERA_MODES",
    "EVENT_KINDS",
    "OVERRIDE_PREFIXES",
    "ROBOT_MODELS",
    "ROUTE_KINDS",
    "SURFACES",
    "CameraConfig",
    "EncoderConfig",
    "Event",
    "PipelineParams",
    "RobotSpec",
    "RouteStep",
    "RunParams",
    "Scenario",
    "SceneObject",
    "find_scenario_files",
    "load_scenario",
    "override_key",
    "replace_params",
    "resolve_params",
    "scenario_from_dict",
    "scenario_from_toml",
    "split_override_key",
]
