"""A/B of the maps on a set of recordings: each replayed under two variants, then compared.

Usage:
    PYTHONPATH=. python bench/replay_ab.py --out DIR [--tree-a DIR] [--tree-b DIR]
        [--set-a KEY=VALUE ...] [--set-b KEY=VALUE ...] [--workers 2] REC.npz [REC.npz ...]

Each recording (``fogsim record SCENARIO --seed N --out REC.npz``, any camera mode) is replayed
with ``fogsim run --replay REC --no-pictures --quiet`` twice: variant A (the code of ``--tree-a``,
this tree by default, with the ``--set-a`` overrides) into ``DIR/a/<recording>`` and variant B
into ``DIR/b/<recording>``, ``--workers`` replays at a time (separate processes: the cores are
used). A replay whose ``report.json`` is already there is not run again, so one A side serves
several B experiments. A replay maps the recorded frames exactly as the run that recorded them
(the same maps as ``fogsim suite`` on the same seeds), without simulating them: the 64 stereo
recordings of the eight held-out scenes (seeds 1–8) take about 2.5 minutes on 2 cores against
6 for the suite (session 57).

Printed, worst scenario first (by B's unsafe cells): per scenario (the reports' scenario name)
the unsafe cells mean (worst seed) A → B, the worst Table I row |error| with its seed, and at the
end the sums of the means, the Table I rows 0.5 mm or more better / worse seed by seed, and how
many recordings gave the same ``maps.npz`` bit for bit (every array) — a speed change that
claims "the same maps" is checked here.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ROW_CHANGE_MM = 0.5
"""A Table I row counts as better or worse when its |error| moves by at least this [mm]."""


@dataclass(frozen=True)
class Replayed:
    """One replay's figures: its scenario and seed, unsafe cells and Table I rows [mm]."""

    scenario: str
    seed: int
    unsafe_cells: int
    rows_mm: dict[str, float | None]


def read_report(folder: Path) -> Replayed:
    """The figures of ``folder/report.json`` (a ``fogsim run`` output folder)."""
    report = json.loads((folder / "report.json").read_text())
    return Replayed(
        scenario=str(report["scenario"]),
        seed=int(report["seed"]),
        unsafe_cells=int(report["safety"]["unsafe_cells"]),
        rows_mm={row["name"]: row["error_mm"] for row in report["table1"]["fog"]},
    )


def same_maps(folder_a: Path, folder_b: Path) -> bool:
    """Whether the two folders' ``maps.npz`` hold the same arrays bit for bit (NaN = NaN)."""
    with np.load(folder_a / "maps.npz") as a, np.load(folder_b / "maps.npz") as b:
        if sorted(a.files) != sorted(b.files):
            return False
        return all(np.array_equal(a[key], b[key], equal_nan=a[key].dtype.kind in "fc") for key in a)


def compare(pairs: list[tuple[Replayed, Replayed, bool]]) -> list[str]:
    """The comparison's lines (module doc) of (A, B, same maps) per recording."""
    by_scenario: dict[str, list[tuple[Replayed, Replayed]]] = defaultdict(list)
    better = worse = same = 0
    for a, b, identical in pairs:
        by_scenario[a.scenario].append((a, b))
        same += identical
        for name, error_a in a.rows_mm.items():
            error_b = b.rows_mm.get(name)
            if error_a is None or error_b is None:
                continue
            if abs(error_b) <= abs(error_a) - ROW_CHANGE_MM:
                better += 1
            elif abs(error_b) >= abs(error_a) + ROW_CHANGE_MM:
                worse += 1
    lines = []
    total_a = total_b = 0.0
    rows = []
    for scenario, runs in by_scenario.items():
        mean_a = sum(a.unsafe_cells for a, _ in runs) / len(runs)
        mean_b = sum(b.unsafe_cells for _, b in runs) / len(runs)
        total_a += mean_a
        total_b += mean_b
        worst_a = max(a.unsafe_cells for a, _ in runs)
        worst_b = max(b.unsafe_cells for _, b in runs)
        rows.append(
            (
                -mean_b,
                f"| `{scenario}` | {mean_a:.2f} ({worst_a}) → {mean_b:.2f} ({worst_b}) | "
                f"{_worst_row([a for a, _ in runs])} → {_worst_row([b for _, b in runs])} |",
            )
        )
    lines.append("| scenario | unsafe cells, A → B | worst Table I row [mm], A → B |")
    lines.append("|---|---|---|")
    lines.extend(line for _, line in sorted(rows))
    lines.append(
        f"in all {total_a:.2f} → {total_b:.2f} unsafe cells; Table I rows {ROW_CHANGE_MM} mm or "
        f"more better / worse: {better} / {worse}; the same maps bit for bit: {same} of "
        f"{len(pairs)} recordings"
    )
    return lines


def _worst_row(runs: list[Replayed]) -> str:
    """``name |error| (seed N)`` of the largest Table I error over the runs, ``-`` if none."""
    worst = None
    for run in runs:
        for name, error in run.rows_mm.items():
            if error is not None and (worst is None or abs(error) > worst[0]):
                worst = (abs(error), name, run.seed)
    return "-" if worst is None else f"{worst[1]} {worst[0]:.2f} (seed {worst[2]})"


def replay(recording: Path, tree: Path, overrides: list[str], out: Path) -> None:
    """``fogsim run --replay`` of one recording with ``tree``'s code into ``out`` (if not there)."""
    if (out / "report.json").exists():
        return
    command = [sys.executable, "-m", "fogsim", "run", "--replay", str(recording)]
    command += ["--no-pictures", "--quiet", "--out", str(out)]
    for item in overrides:
        command += ["--set", item]
    environment = dict(os.environ, PYTHONPATH=str(tree), MUJOCO_GL="egl")
    subprocess.run(command, cwd=tree, env=environment, check=True, stdout=subprocess.DEVNULL)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--tree-a", type=Path, default=ROOT)
    parser.add_argument("--tree-b", type=Path, default=ROOT)
    parser.add_argument("--set-a", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--set-b", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    jobs = []
    for recording in args.recordings:
        name = recording.name.removesuffix(".npz")
        jobs.append((recording, args.tree_a.resolve(), args.set_a, args.out / "a" / name))
        jobs.append((recording, args.tree_b.resolve(), args.set_b, args.out / "b" / name))
    with ThreadPoolExecutor(args.workers) as pool:
        list(pool.map(lambda job: replay(*job), jobs))
    pairs = []
    for recording in args.recordings:
        name = recording.name.removesuffix(".npz")
        folder_a, folder_b = args.out / "a" / name, args.out / "b" / name
        pairs.append((read_report(folder_a), read_report(folder_b), same_maps(folder_a, folder_b)))
    print("\n".join(compare(pairs)))


if __name__ == "__main__":
    main()
