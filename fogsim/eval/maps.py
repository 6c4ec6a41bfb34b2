"""The run's maps on the world-fixed archive, with the truth on the same cells: ``maps.npz``.

Every run writes ``maps.npz`` (:func:`write_maps`) so that any figure of the report can be
recomputed outside the project; :func:`load_maps` reads it back as a typed :class:`RunMaps`.
The cells are the archive's (:class:`fogsim.eval.archive.WorldArchive`): the world-fixed lattice
of the mapper's cells over every place the robot-centred grid has been, each holding the last
value it had while inside the grid. Arrays are indexed ``[ix, iy]`` (x along the first axis, y
along the second), heights in metres in the world frame (z up, the ground at 0), NaN = none.

File format, version 1 (a NumPy ``.npz`` zip archive; read it with ``allow_pickle=False``):

==========================  ===============  ==================================================
key                         shape, dtype     meaning
==========================  ===============  ==================================================
``meta_json``               0-d str          JSON object: ``format`` (``"fogsim-maps"``),
                                             ``version`` (1), ``cell_m`` (cell side [m]),
                                             ``cell_types`` (``unknown`` 0, ``floor`` 1,
                                             ``obstacle`` 2), ``has_truth``, and with the
                                             truth ``object_names``, ``surface_names`` and
                                             ``surface_heights_m`` (name → true top [m])
``cell_centers_xy``         (nx, ny, 2) f8   world x, y of each cell's centre [m]
``visited``                 (nx, ny) bool    the cell was inside the robot's grid in some
                                             frame (the region the report scores)
``in_view``                 (nx, ny) bool    the camera saw the cell in some frame (a depth
                                             point in the grid's height range, true pose)
``seen``                    (nx, ny) bool    the FOG labels the cell floor or obstacle
``fog_types``               (nx, ny) i1      FOG label (``cell_types``; unknown outside the
                                             visited region)
``fog_heights_m``           (nx, ny) f8      FOG height: floor height of a floor cell, coarse
                                             obstacle top of an obstacle cell
``floor_m``                 (nx, ny) f8      the floor height map (fine 2.5-D floor, also
                                             under obstacles where it was verified)
``obstacle_m``              (nx, ny) f8      the obstacle height map: top of the highest
                                             occupied 3-D cell of the column (eq. 10)
``ceiling_m``               (nx, ny) f8      the ceiling map: bottom of the lowest occupied
                                             cell above the free space over the floor
``averaging_heights_m``     (nx, ny) f8      the averaging (Kagami) baseline's heights
``truth_labels``            (nx, ny) i1      true label (``cell_types``, floor or obstacle)
``truth_floor_m``           (nx, ny) f8      true floor height, NaN where not floor
``truth_obstacle_top_m``    (nx, ny) f8      top of the highest thing over an obstacle cell
``truth_ceiling_m``         (nx, ny) f8      bottom of the lowest object hanging over the
                                             surface one stands on, NaN where none
``truth_object_id``         (nx, ny) i4      index into ``object_names`` of the object whose
                                             top or body is the highest thing over the cell,
                                             -1 for the ground
``truth_surface_id``        (nx, ny) i4      index into ``surface_names`` (Table I rows) of a
                                             floor cell's surface, -1 otherwise
``truth_interior``          (nx, ny) bool    the whole cell lies on one surface (Table I
                                             leaves the others out)
==========================  ===============  ==================================================

The ``truth_*`` keys are there when the run had ground truth (``has_truth``): the world at the
run's last frame, by the rules of :mod:`fogsim.world.truth`.

Reading it with numpy alone::

    import json, numpy as np
    with np.load("runs/stage/maps.npz", allow_pickle=False) as f:
        meta = json.loads(str(f["meta_json"]))
        error_m = f["fog_heights_m"] - f["truth_floor_m"]
        floor = (f["fog_types"] == 1) & (f["truth_labels"] == 1)
        print(np.nanmedian(np.abs(error_m[floor])) * 1000, "mm")
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import DTypeLike, NDArray

from fogsim.atomic import write_atomic
from fogsim.errors import ReportError
from fogsim.eval.archive import WorldArchive
from fogsim.eval.result import RunResult
from fogsim.world.truth import GroundTruthGrid
from mapper import CellType

MAPS_FORMAT = "fogsim-maps"
MAPS_VERSION = 1
CELL_TYPES = {t.name.lower(): int(t) for t in CellType}
"""The label values of ``fog_types`` and ``truth_labels``."""


@dataclass(frozen=True)
class TruthMaps:
    """The ground truth on the archive's cells (the ``truth_*`` keys of ``maps.npz``).

    Attributes:
        labels: (nx, ny) int8 true label (``mapper.CellType``: FLOOR or OBSTACLE).
        floor_m: (nx, ny) true floor height [m], NaN where not floor.
        obstacle_top_m: (nx, ny) top of the highest thing over an obstacle cell [m], NaN.
        ceiling_m: (nx, ny) bottom of the lowest object hanging over the surface [m], NaN.
        object_id: (nx, ny) int32 index into ``object_names``, -1 for the ground.
        surface_id: (nx, ny) int32 index into ``surface_names``, -1 where no Table I surface.
        interior: (nx, ny) bool, the whole cell lies on one surface.
        object_names: Every object of the scenario, in file order.
        surface_names: ``ground`` and every walkable object (the Table I rows).
        surface_heights_m: True top of every surface [m].
    """

    labels: NDArray[np.int8]
    floor_m: NDArray[np.float64]
    obstacle_top_m: NDArray[np.float64]
    ceiling_m: NDArray[np.float64]
    object_id: NDArray[np.int32]
    surface_id: NDArray[np.int32]
    interior: NDArray[np.bool_]
    object_names: tuple[str, ...]
    surface_names: tuple[str, ...]
    surface_heights_m: Mapping[str, float]


@dataclass(frozen=True)
class RunMaps:
    """A run's archived maps and the truth on the same cells (``maps.npz``, module docstring).

    Attributes:
        cell_m: Cell side [m].
        cell_centers_xy: (nx, ny, 2) world cell centres [m].
        visited: (nx, ny) the cell was inside the robot's grid in some frame.
        in_view: (nx, ny) the camera saw the cell in some frame.
        seen: (nx, ny) the FOG labels the cell floor or obstacle.
        fog_types: (nx, ny) int8 FOG label (``mapper.CellType``).
        fog_heights_m: (nx, ny) FOG height [m].
        floor_m: (nx, ny) floor height map [m].
        obstacle_m: (nx, ny) obstacle height map [m].
        ceiling_m: (nx, ny) ceiling map [m].
        averaging_heights_m: (nx, ny) averaging baseline heights [m].
        truth: The truth on the same cells, None without ground truth.
    """

    cell_m: float
    cell_centers_xy: NDArray[np.float64]
    visited: NDArray[np.bool_]
    in_view: NDArray[np.bool_]
    seen: NDArray[np.bool_]
    fog_types: NDArray[np.int8]
    fog_heights_m: NDArray[np.float64]
    floor_m: NDArray[np.float64]
    obstacle_m: NDArray[np.float64]
    ceiling_m: NDArray[np.float64]
    averaging_heights_m: NDArray[np.float64]
    truth: TruthMaps | None


_MAP_ARRAYS: dict[str, DTypeLike] = {
    "visited": np.bool_,
    "in_view": np.bool_,
    "seen": np.bool_,
    "fog_types": np.int8,
    "fog_heights_m": np.float64,
    "floor_m": np.float64,
    "obstacle_m": np.float64,
    "ceiling_m": np.float64,
    "averaging_heights_m": np.float64,
}
"""The (nx, ny) arrays of :class:`RunMaps`: file key = field name, and their dtypes."""

_TRUTH_ARRAYS: dict[str, DTypeLike] = {
    "labels": np.int8,
    "floor_m": np.float64,
    "obstacle_top_m": np.float64,
    "ceiling_m": np.float64,
    "object_id": np.int32,
    "surface_id": np.int32,
    "interior": np.bool_,
}
"""The (nx, ny) arrays of :class:`TruthMaps`: file key ``truth_`` + field name, and dtypes."""


def archive_maps(archive: WorldArchive, truth: GroundTruthGrid | None) -> RunMaps:
    """The archive's maps with the truth on its cells.

    Args:
        archive: The run's world-fixed archive.
        truth: The final world rasterised on ``archive.cell_centers_xy()``; None without truth.

    Raises:
        ReportError: The truth is on other cells than the archive's.
    """
    shape = archive.visited.shape
    truth_maps = None
    if truth is not None:
        if truth.labels.shape != shape or truth.cell_m != archive.cell_m:
            raise ReportError(
                f"maps: the truth must lie on the archive's cells, {shape} of {archive.cell_m} m;"
                f" got {truth.labels.shape} of {truth.cell_m} m"
            )
        truth_maps = TruthMaps(
            **{name: np.asarray(getattr(truth, name), dt) for name, dt in _TRUTH_ARRAYS.items()},
            object_names=tuple(truth.object_names),
            surface_names=tuple(truth.surface_names),
            surface_heights_m=dict(truth.surface_heights_m),
        )
    return RunMaps(
        cell_m=archive.cell_m,
        cell_centers_xy=archive.cell_centers_xy(),
        visited=archive.visited.copy(),
        in_view=archive.in_view.copy(),
        seen=archive.visited & (archive.fog_types != CellType.UNKNOWN),
        fog_types=archive.fog_types.copy(),
        fog_heights_m=archive.fog_heights_m.copy(),
        floor_m=archive.floor_m.copy(),
        obstacle_m=archive.obstacle_m.copy(),
        ceiling_m=archive.ceiling_m.copy(),
        averaging_heights_m=archive.baseline_heights_m.copy(),
        truth=truth_maps,
    )


def save_maps(path: str | os.PathLike[str], maps: RunMaps) -> Path:
    """Write ``maps.npz`` (module docstring) atomically; returns the path."""
    meta: dict[str, Any] = {
        "format": MAPS_FORMAT,
        "version": MAPS_VERSION,
        "cell_m": maps.cell_m,
        "cell_types": CELL_TYPES,
        "has_truth": maps.truth is not None,
    }
    arrays: dict[str, NDArray[Any]] = {
        "cell_centers_xy": np.asarray(maps.cell_centers_xy, dtype=np.float64),
        **{key: np.asarray(getattr(maps, key), dt) for key, dt in _MAP_ARRAYS.items()},
    }
    if maps.truth is not None:
        meta["object_names"] = list(maps.truth.object_names)
        meta["surface_names"] = list(maps.truth.surface_names)
        meta["surface_heights_m"] = dict(maps.truth.surface_heights_m)
        for name, dt in _TRUTH_ARRAYS.items():
            arrays[f"truth_{name}"] = np.asarray(getattr(maps.truth, name), dt)
    arrays["meta_json"] = np.array(json.dumps(meta))
    return write_atomic(path, lambda handle: np.savez_compressed(handle, **arrays))


def write_maps(
    path: str | os.PathLike[str], result: RunResult, truth: GroundTruthGrid | None
) -> Path:
    """Write a run's ``maps.npz``: its archive and the truth on the archive's cells.

    Args:
        path: The file (``OUT/maps.npz``).
        result: The run's result (its archive).
        truth: The final world rasterised on the archive's cells; None without truth.
    """
    return save_maps(path, archive_maps(result.archive, truth))


def load_maps(path: str | os.PathLike[str]) -> RunMaps:
    """Read a ``maps.npz`` written by :func:`write_maps`.

    Raises:
        ReportError: The file is missing, no maps file, of another version, or an array is
            missing or has the wrong shape or type (the message names it).
    """
    source = Path(path)
    try:
        with np.load(io.BytesIO(source.read_bytes()), allow_pickle=False) as data:
            arrays = {key: data[key] for key in data.files}
    except (OSError, ValueError) as exc:
        raise ReportError(f"{source} is not a readable maps .npz file: {exc}") from exc
    try:
        meta = json.loads(str(arrays["meta_json"]))
    except (KeyError, json.JSONDecodeError) as exc:
        raise ReportError(f"{source}: meta_json is missing or no JSON: {exc}") from exc
    if meta.get("format") != MAPS_FORMAT or meta.get("version") != MAPS_VERSION:
        raise ReportError(
            f"{source}: format {meta.get('format')!r} version {meta.get('version')!r}; "
            f"expected {MAPS_FORMAT!r} version {MAPS_VERSION}"
        )
    centers = _array(source, arrays, "cell_centers_xy", np.float64)
    shape = centers.shape[:2]
    if centers.shape != (*shape, 2):
        raise ReportError(f"{source}: cell_centers_xy must be (nx, ny, 2), got {centers.shape}")
    layers = {key: _array(source, arrays, key, dt, shape) for key, dt in _MAP_ARRAYS.items()}
    try:
        cell_m = float(meta["cell_m"])
        has_truth = bool(meta["has_truth"])
        names = (
            {
                "object_names": tuple(str(n) for n in meta["object_names"]),
                "surface_names": tuple(str(n) for n in meta["surface_names"]),
                "surface_heights_m": {
                    str(k): float(v) for k, v in meta["surface_heights_m"].items()
                },
            }
            if has_truth
            else {}
        )
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ReportError(
            f"{source}: meta_json needs cell_m, has_truth and, with the truth, object_names, "
            f"surface_names and surface_heights_m: {exc!r}"
        ) from exc
    truth = None
    if has_truth:
        truth_layers = {
            name: _array(source, arrays, f"truth_{name}", dt, shape)
            for name, dt in _TRUTH_ARRAYS.items()
        }
        truth = TruthMaps(**truth_layers, **names)
    return RunMaps(cell_m=cell_m, cell_centers_xy=centers, truth=truth, **layers)


def _array(
    source: Path,
    arrays: Mapping[str, NDArray[Any]],
    key: str,
    dtype: DTypeLike,
    shape: tuple[int, ...] | None = None,
) -> NDArray[Any]:
    """``arrays[key]`` checked for its dtype and (nx, ny) shape."""
    if key not in arrays:
        raise ReportError(f"{source}: array {key!r} is missing")
    array = arrays[key]
    if array.dtype != np.dtype(dtype) or (shape is not None and array.shape != shape):
        raise ReportError(
            f"{source}: array {key!r} must be {np.dtype(dtype)} of shape {shape}, "
            f"got {array.dtype} of shape {array.shape}"
        )
    return array
