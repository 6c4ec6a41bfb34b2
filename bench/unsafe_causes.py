"""Count a replay set's unsafe cells by cause, from `bench/spill_trace.py` JSON files.

Usage:
    PYTHONPATH=. python bench/unsafe_causes.py REC.npz TRACE.json [TRACE.json ...]

REC is any recording of the scene (only its final world is read: each box's top, base +
height, in metres, is the level its points should carry; the ground is 0). Each TRACE is
`spill_trace.py REC --json TRACE --cells N` of one seed (N at least the run's unsafe cells; its
points need ``meas_xyz``). A floor point of an unsafe cell is *wrong* when its floor height is
more than 20 mm off the cell's true floor (every floor point of a cell the truth calls an
obstacle). Each wrong point is one of:

* ``pose``: its height is its true surface's (within 20 mm), and the true camera pose with the
  measured depth would have put it in another cell: the believed pose moved it here;
* ``depth``: its height is its true surface's, and the true pose with the measured depth puts it
  in this cell too: the measured depth moved it (or the cell's edge is its true surface's);
* ``relabelled``: its height is not its true surface's: the segmentation gave it another
  region's level (a region grown over an edge, a point snapped onto a plane it is not on).

A cell's cause is the kind of most of its wrong points (``O:`` in front: the truth calls it an
obstacle). Printed: the cells by cause, by *surface* (the cell's true object, ``<-`` the
object whose level its FOG floor has) and by both, per seed (the seed read from a ``sN`` in the
file name, else the file's position).

Session 37, the zig-zag stage, seeds 1-8 (``bench/heading_oracle.py`` for the replays with a
true yaw or pose), unsafe cells mean (worst): stereo 31.1 (66) with the pipeline's pose, 17.75
(26) with the true yaw, 13.5 (26) with the true camera pose; depth 11.25 (44), 0.62 (2), 0.25
(1). Of the stereo run's 249 cells, 120 are ``pose`` (98, and 22 ``O:`` on the sill): the side
rows beside the staircase (y = -0.30 on seeds 3 and 5, y = 1.34 on seeds 1, 7, 8, as the
believed pose's mean offset in y of the traced points, -49 / -29 / +26 mm on seeds 5 / 3 / 1)
and the sill's front cells; 129 are ``relabelled``. Of the 108 cells left with the true pose,
28 are the first row of step_3 (and of the platform) holding step_2's (step_3's) height: pixels
of the riser face at x = 3.600 (true z 71-88 mm, measured depth right to ±2 cm) that the lower
tread's region took (stereo noise hides a 25 mm riser) and `scanline.floor_points` snapped along
their descending rays onto the lower tread's height, which carries them 0-4 cm forward past the
riser (placed at x = 3.60-3.64, median 3.62; the true pose puts their measured depth at 3.54-3.70,
median 3.60): every such point lands in the upper tread's first cell. 25 are ground beside the
staircase's side edges at a tread's or the platform's height: ground pixels in the tread's or
platform's region, measured at its depth (step_1's sides 3-8 cm short, the platform's 18-28 cm:
the matcher's fattened edge), 23 the sill's front cells (half sill, an obstacle to the truth),
25 rough box tops taken for floors (box_a on seed 4, box_c on seed 2). Depth mode's 90 cells are
82 ``pose``.
"""

from __future__ import annotations

import json
import math
import re
import sys
from collections import Counter
from pathlib import Path

CELL_M = 0.04
WRONG_MM = 20.0


def levels_mm(recording: str) -> tuple[dict[str, float], dict[str, object]]:
    """Each box's top in the recording's final world [mm] (the ground 0), and the boxes."""
    from fogsim.data.recording import load_recording

    rec = load_recording(recording)
    truth = rec.truth_at(rec.frames[-1].time_s)
    out = {"ground": 0.0}
    for obj in truth.objects:
        out[obj.name] = 1e3 * (obj.base_m + obj.size[2])
    return out, {obj.name: obj for obj in truth.objects}


def _footprint_m(obj, x: float, y: float) -> float:
    """Distance [m] from (x, y) to the box's footprint (0 inside)."""
    c, s = math.cos(obj.yaw_rad), math.sin(obj.yaw_rad)
    dx, dy = x - obj.center_xy[0], y - obj.center_xy[1]
    u, v = c * dx + s * dy, -s * dx + c * dy
    return math.hypot(max(abs(u) - obj.size[0] / 2, 0.0), max(abs(v) - obj.size[1] / 2, 0.0))


def _nearest(level_mm: dict[str, float], boxes: dict, h_mm: float, x: float, y: float) -> str:
    """The object whose level is nearest ``h_mm``; of levels within 10 mm of it, the box
    whose footprint is nearest (x, y) (the sill and step_1 share 45 mm)."""
    best = min(abs(v - h_mm) for v in level_mm.values())
    close = [k for k, v in level_mm.items() if abs(v - h_mm) <= best + 10.0]
    if len(close) == 1:
        return close[0]
    return min(close, key=lambda k: _footprint_m(boxes[k], x, y) if k in boxes else 0.5)


def classify(entry: dict, level_mm: dict[str, float]) -> tuple[str, Counter]:
    """The cause of one traced cell and the count of its points by kind."""
    x, y = entry["xy"]
    true_mm = entry["truth_floor_mm"]
    obstacle = true_mm is None or (isinstance(true_mm, float) and math.isnan(true_mm))
    kinds: Counter = Counter()
    for fr in entry["frames"]:
        for i, h in enumerate(fr["floor_mm"]):
            if not obstacle and abs(h - true_mm) <= WRONG_MM:
                kinds["right"] += 1
                continue
            hit = fr["true_hit"][i]
            if hit in level_mm and abs(h - level_mm[hit]) <= WRONG_MM:
                mx, my = fr["meas_xyz"][i][:2]
                here = abs(mx - x) <= CELL_M / 2 and abs(my - y) <= CELL_M / 2
                kinds["depth" if here else "pose"] += 1
            else:
                kinds["relabelled"] += 1
    wrong = {k: v for k, v in kinds.items() if k != "right"}
    cause = max(wrong, key=wrong.get) if wrong else "none"
    return ("O:" if obstacle else "") + cause, kinds


def main() -> None:
    if len(sys.argv) < 3:
        raise SystemExit(__doc__)
    level_mm, boxes = levels_mm(sys.argv[1])
    rows = []
    seeds = []
    for position, name in enumerate(sys.argv[2:], start=1):
        m = re.search(r"s(\d+)\D*$", Path(name).stem)
        seed = int(m.group(1)) if m else position
        seeds.append(seed)
        for entry in json.loads(Path(name).read_text()):
            cause, kinds = classify(entry, level_mm)
            near = _nearest(level_mm, boxes, entry["fog_mm"], *entry["xy"])
            surface = f"{entry['truth']} <- {near}"
            rows.append((seed, cause, surface, kinds))
    seeds = sorted(set(seeds))
    print(f"{len(rows)} cells over {len(seeds)} runs ({len(rows) / max(len(seeds), 1):.2f} a run)")
    points: Counter = Counter()
    for r in rows:
        points.update(r[3])
    print("points:", dict(points.most_common()))
    for title, key in (("cause", 1), ("surface", 2)):
        counts = Counter(r[key] for r in rows)
        print(f"by {title} (total; per seed {' '.join(f's{s}' for s in seeds)}):")
        for value, n in counts.most_common():
            per = " ".join(
                f"{sum(1 for r in rows if r[0] == s and r[key] == value):3d}" for s in seeds
            )
            print(f"  {n:4d}  {value:28s} {per}")
    print("by surface and cause:")
    for (surface, cause), n in Counter((r[2], r[1]) for r in rows).most_common():
        print(f"  {n:4d}  {surface:28s} {cause}")


if __name__ == "__main__":
    main()
