"""Layer 2 — the world over time: where each object is at a time, and the truth it implies.

* :mod:`fogsim.world.timeline` — :class:`ObjectState`, :func:`object_center_at`,
  :func:`moving_objects`: the event timeline of the scenario's objects;
* :mod:`fogsim.world.truth_params` — :class:`TruthParams`: the robot's foot and the mapper
  grid's top, which the paper's definitions of floor and obstacle need;
* :mod:`fogsim.world.truth` — :class:`SceneTruth`, :class:`GroundTruthGrid`: the ground truth
  at one instant by the paper's definitions, on points and on grids.
"""

from fogsim.world.timeline import ObjectState, moving_objects, object_center_at
from fogsim.world.truth import GROUND, GroundTruthGrid, SceneTruth, TruthLabel
from fogsim.world.truth_params import TruthParams

__all__ = [
    "GROUND",
    "GroundTruthGrid",
    "ObjectState",
    "SceneTruth",
    "TruthLabel",
    "TruthParams",
    "moving_objects",
    "object_center_at",
]
