"""Count the unsafe cells of suite or seed folders by kind: riser, side edge, floor off.

Usage:
    PYTHONPATH=. python bench/unsafe_kinds.py FOLDER [FOLDER ...]

Each FOLDER holds ``seed_N/maps.npz`` (a scenario's folder of ``fogsim suite ... --out DIR``, or
``fogsim run ... --seeds 1-8 --out FOLDER``). A cell is unsafe as in the report
(`fogsim.eval.metrics.safety_scores`): FOG floor on a true obstacle, or a floor more than 20 mm
off the true floor, over the visited cells. Each is one of:

* ``riser`` / ``side``: a true obstacle labelled floor, split by where the truth's heights step
  around it — across x (4-neighbours) more than across y: the stairs of fogsim's scenes climb
  along x, so a riser; else a side edge (a scene turned on the ground mixes the two);
* ``hi`` / ``lo`` after it: the FOG's floor within 15 mm of the obstacle's top (the higher
  surface spread over the edge) or below it (the lower one);
* ``off_hi`` / ``off_lo``: a true floor whose FOG floor is more than 20 mm above / below it.

Printed per folder: the total over its seeds and the count of each kind. Session 49 (stereo,
seeds 1–8, default parameters): `stairs` 299 cells, all ``off`` (216 ``off_hi``: ground beside
the staircase at a tread's height), held-out `down_low_steps` 815 (310 risers, 308 side edges,
197 off).
"""

import sys
from collections import Counter
from pathlib import Path

import numpy as np

from fogsim.eval.metrics import HEIGHT_TOLERANCE_M
from mapper.grid import CellType

TOP_TOLERANCE_M = 0.015
"""A floor within this of an obstacle's top holds the higher surface (``hi``) [m]."""

_FLOOR, _OBSTACLE = int(CellType.FLOOR), int(CellType.OBSTACLE)


def kinds(maps: dict[str, np.ndarray]) -> Counter:
    """The unsafe cells of one run's ``maps.npz`` arrays, counted by kind (module doc)."""
    types, heights = maps["fog_types"], maps["fog_heights_m"]
    labels, true_floor, true_top = (
        maps["truth_labels"],
        maps["truth_floor_m"],
        maps["truth_obstacle_top_m"],
    )
    floor = maps["visited"] & (types == _FLOOR)
    off = (labels == _FLOOR) & (np.abs(heights - true_floor) > HEIGHT_TOLERANCE_M)
    true_height = np.where(labels == _FLOOR, true_floor, true_top)
    padded = np.pad(true_height, 1, constant_values=np.nan)
    counts: Counter = Counter()
    for ix, iy in np.argwhere(floor & ((labels == _OBSTACLE) | off)):
        if labels[ix, iy] == _FLOOR:
            counts["off_hi" if heights[ix, iy] > true_floor[ix, iy] else "off_lo"] += 1
            continue
        centre = padded[ix + 1, iy + 1]
        step_x = np.nanmax(np.abs(padded[[ix, ix + 2], iy + 1] - centre), initial=0.0)
        step_y = np.nanmax(np.abs(padded[ix + 1, [iy, iy + 2]] - centre), initial=0.0)
        where = "riser" if step_x > step_y else "side"
        side = "hi" if abs(heights[ix, iy] - true_top[ix, iy]) < TOP_TOLERANCE_M else "lo"
        counts[f"{where}_{side}"] += 1
    return counts


def main() -> None:
    for folder in map(Path, sys.argv[1:]):
        counts: Counter = Counter()
        for path in sorted(folder.glob("seed_*/maps.npz")):
            with np.load(path, allow_pickle=False) as f:
                counts += kinds({name: f[name] for name in f.files})
        print(f"{folder.name}: {sum(counts.values())} unsafe cells", dict(sorted(counts.items())))


if __name__ == "__main__":
    main()
