"""The maps of the comparison by name, and how each one is labelled for scoring.

``fog`` is the pipeline's own :class:`~mapper.mapper.FloorObstacleMapper`; every other map is
built here with the FOG's grid geometry, so all maps share their cells. Maps with their own
floor/obstacle labels (the FOG, and the averaging map's majority of floor-labelled points) are
scored twice: with their labels (row ``fog``) and with the rule for maps without labels
(:func:`mapper.backends.label_by_step`, row ``fog+rule``); the others once, with the rule.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from fogsim.errors import FogsimError
from mapper import AveragingMap, MapperParams
from mapper.backends import HeightMapBackend, StepRuleParams
from mapper.elevation_map import ElevationMap, ElevationMapParams
from mapper.last_map import LastMeasurementMap
from mapper.octomap_map import OctoMapHeights, OctoMapParams

MAP_NAMES = ("fog", "averaging", "elevation", "octomap", "last")
"""Every map ``--maps`` knows, in table order."""
LABELLED = ("fog", "averaging")
"""Maps with labels of their own (scored both ways)."""
RULE_SUFFIX = "+rule"
"""Row-name suffix of a labelled map scored with the rule."""


@dataclass(frozen=True)
class MapSettings:
    """Parameters of the maps built here (each default is the map's own, see its module).

    Attributes:
        rule: The labelling rule for maps without labels, applied to every map alike.
        elevation: The elevation map's noise model and fusion.
        octomap: OctoMap's sensor model.
    """

    rule: StepRuleParams = field(default_factory=StepRuleParams)
    elevation: ElevationMapParams = field(default_factory=ElevationMapParams)
    octomap: OctoMapParams = field(default_factory=OctoMapParams)


def parse_maps(spec: str) -> tuple[str, ...]:
    """The maps of a ``--maps`` spec (``fog,elevation``), in table order; ``fog`` always first.

    Raises:
        FogsimError: An unknown or repeated name, naming it and the allowed ones.
    """
    names = [name.strip() for name in spec.split(",") if name.strip()]
    for name in names:
        if name not in MAP_NAMES:
            raise FogsimError(
                f"--maps: unknown map {name!r} in {spec!r}; allowed: {', '.join(MAP_NAMES)}"
            )
    if len(set(names)) != len(names):
        raise FogsimError(f"--maps: a map is named twice in {spec!r}")
    return tuple(name for name in MAP_NAMES if name in names or name == "fog")


def row_names(maps: tuple[str, ...]) -> tuple[str, ...]:
    """The table's rows for ``maps``: each labelled map twice (own labels, then the rule)."""
    rows: list[str] = []
    for name in maps:
        rows.append(name)
        if name in LABELLED:
            rows.append(name + RULE_SUFFIX)
    return tuple(rows)


def build_map(name: str, grid: MapperParams, settings: MapSettings) -> HeightMapBackend:
    """A new map ``name`` (not ``fog``: that one is the pipeline's) on the FOG's grid."""
    if name == "averaging":
        return AveragingMap(grid)
    if name == "elevation":
        return ElevationMap(settings.elevation, grid, settings.rule)
    if name == "octomap":
        try:
            return OctoMapHeights(settings.octomap, grid, settings.rule)
        except ModuleNotFoundError as exc:
            raise FogsimError(
                "--maps octomap needs octomap-python (pip install -e '.[octomap]')"
            ) from exc
    if name == "last":
        return LastMeasurementMap(grid, settings.rule)
    raise FogsimError(f"no map {name!r} to build; allowed: {', '.join(MAP_NAMES[1:])}")
