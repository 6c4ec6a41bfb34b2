"""List every unsafe cell of replay/seed folders, with what lies around it.

Usage:
    PYTHONPATH=. python bench/unsafe_cells.py FOLDER [FIRST-LAST] [-v]

FOLDER holds ``seed_N/maps.npz`` (``fogsim run ... --out FOLDER/seed_N``). A cell is unsafe as
in the report (`fogsim.eval.metrics.safety_scores`): FOG floor on a true obstacle, or a floor
more than 20 mm off the true floor, over the visited cells. Per cell: seed, indices, world
centre [m], the truth's object, label and heights [mm], the FOG's height, the stored floor and
obstacle top [mm]; ``-v`` adds the 3 × 3 cells around it (truth label and height, FOG label
and height, stored floor, obstacle top), rows along x.
"""

import json
import sys
from pathlib import Path

import numpy as np

_LABELS = "UFO"  # CellType: unknown 0, floor 1, obstacle 2


def _mm(v: float) -> str:
    return f"{v * 1e3:6.1f}"


def main() -> None:
    folder = Path(sys.argv[1])
    spec = next((a for a in sys.argv[2:] if not a.startswith("-")), "1-8")
    first, last = (int(x) for x in spec.split("-"))
    verbose = "-v" in sys.argv
    total = 0
    for seed in range(first, last + 1):
        path = folder / f"seed_{seed}" / "maps.npz"
        if not path.exists():
            continue
        with np.load(path, allow_pickle=False) as f:
            m = {k: f[k] for k in f.files}
        names = json.loads(str(m["meta_json"]))["object_names"]
        types, heights = m["fog_types"], m["fog_heights_m"]
        labels, true_floor, true_top = (
            m["truth_labels"],
            m["truth_floor_m"],
            m["truth_obstacle_top_m"],
        )
        floor = types == 1
        off = (labels == 1) & (np.abs(heights - true_floor) > 0.02)
        unsafe = m["visited"] & floor & ((labels == 2) | off)
        for ix, iy in np.argwhere(unsafe):
            total += 1
            x, y = m["cell_centers_xy"][ix, iy]
            oid = m["truth_object_id"][ix, iy]
            name = names[oid] if oid >= 0 else "ground"
            print(
                f"s{seed} ({ix:3d},{iy:3d}) xy=({x:.2f},{y:.2f}) {name:12s} truth "
                f"{_LABELS[labels[ix, iy]]} floor {_mm(true_floor[ix, iy])} top "
                f"{_mm(true_top[ix, iy])} | fog {_mm(heights[ix, iy])} floor "
                f"{_mm(m['floor_m'][ix, iy])} obstacle {_mm(m['obstacle_m'][ix, iy])}"
            )
            if not verbose:
                continue
            for jx in range(ix - 1, ix + 2):
                row = []
                for jy in range(iy - 1, iy + 2):
                    t = labels[jx, jy]
                    th = true_floor[jx, jy] if t == 1 else true_top[jx, jy]
                    row.append(
                        f"T{_LABELS[t]}{_mm(th)} F{_LABELS[types[jx, jy]]}{_mm(heights[jx, jy])}"
                        f" f{_mm(m['floor_m'][jx, jy])} o{_mm(m['obstacle_m'][jx, jy])}"
                    )
                print("     " + " | ".join(row))
    print("total", total)


if __name__ == "__main__":
    main()
