"""Behaviour-preservation check: capture every shipped scenario's results, compare two captures.

A capture runs, through the ``fogsim`` command line only (so it works on any version of the
code), every scenario file in ``scenarios/``, one ``record`` + ``--replay`` and one short
``tune``; it keeps each ``report.json`` (and the tune's ``summary.json``). ``compare`` lists every
value that differs between two captures, ignoring the fields that legitimately change from run to
run: timing (``timing.*`` other than frame counts), wall time, package versions and tune's
per-trial times.

Usage::

    python bench/compare_reports.py capture runs/before
    # ... change the code ...
    python bench/compare_reports.py capture runs/after
    python bench/compare_reports.py compare runs/before runs/after
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOGSIM = [sys.executable, "-m", "fogsim"]

# Keys whose values are machine- or moment-dependent; frame counts in ``timing`` are kept.
_TIMING_KEEP = {"frames", "withdrawn_frames", "z_matched_frames"}
_IGNORED_LEAVES = {"wall_s", "realtime_factor", "versions", "median_replay_s", "median_scoring_s"}


def _ignored(path: tuple[str, ...]) -> bool:
    if any(p in _IGNORED_LEAVES for p in path):
        return True
    if "timing" in path:
        i = path.index("timing")
        return not (len(path) > i + 1 and path[i + 1] in _TIMING_KEEP)
    return any(p.endswith(("_s_median", "_time_s", "elapsed_s")) for p in path)


def _run(args: list[str]) -> None:
    print("$ fogsim", " ".join(args), flush=True)
    subprocess.run([*FOGSIM, *args], check=True, cwd=ROOT)


def capture(out: Path) -> None:
    """Run every shipped scenario, a replay and a tune into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    for path in sorted((ROOT / "scenarios").glob("*.toml")):
        _run(["run", path.stem, "--out", str(out / path.stem), "--no-pictures", "--quiet"])
    _run(
        [
            "run",
            "stage",
            "--camera-mode",
            "stereo",
            "--seed",
            "2",
            "--out",
            str(out / "stage_stereo"),
            "--no-pictures",
            "--quiet",
        ]
    )
    rec = out / "box_removal.npz"
    _run(["record", "box_removal", "--out", str(rec), "--quiet"])
    _run(
        [
            "run",
            "--replay",
            str(rec),
            "--set",
            "mapper.p_occ=0.8",
            "--out",
            str(out / "replay"),
            "--no-pictures",
            "--quiet",
        ]
    )
    _run(
        [
            "tune",
            "flat_floor",
            "box_removal",
            "--quick",
            "--param",
            "p_occ=0.55:0.95",
            "--trials",
            "3",
            "--workers",
            "1",
            "--seed",
            "3",
            "--no-progress",
            "--no-pictures",
            "--out",
            str(out / "tune"),
        ]
    )


def _leaves(value: object, path: tuple[str, ...] = ()) -> dict[tuple[str, ...], object]:
    if isinstance(value, dict):
        found: dict[tuple[str, ...], object] = {}
        for key, item in value.items():
            found.update(_leaves(item, (*path, str(key))))
        return found
    if isinstance(value, list):
        found = {}
        for i, item in enumerate(value):
            found.update(_leaves(item, (*path, str(i))))
        return found
    return {path: value}


def _same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def compare(before: Path, after: Path) -> int:
    """Print every differing value of the captures' JSON files; return the number found."""
    names = sorted(
        str(p.relative_to(before))
        for p in before.rglob("*.json")
        # Recordings are inputs; a manifest lists run ids and the sizes and hashes of files
        # whose timing fields differ from run to run.
        if "recordings" not in p.parts and p.name != "manifest.json"
    )
    differences = 0
    for name in names:
        other = after / name
        if not other.exists():
            print(f"{name}: missing in {after}")
            differences += 1
            continue
        a = _leaves(json.loads((before / name).read_text()))
        b = _leaves(json.loads(other.read_text()))
        for path in sorted(set(a) | set(b)):
            if _ignored(path):
                continue
            if path not in a or path not in b or not _same(a[path], b[path]):
                differences += 1
                print(
                    f"{name}: {'.'.join(path)}: {a.get(path, '<absent>')!r} -> "
                    f"{b.get(path, '<absent>')!r}"
                )
    print(f"{len(names)} files compared, {differences} differences")
    return differences


def main() -> int:
    """Command line: ``capture OUT`` or ``compare BEFORE AFTER``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("capture").add_argument("out", type=Path)
    cmp = sub.add_parser("compare")
    cmp.add_argument("before", type=Path)
    cmp.add_argument("after", type=Path)
    args = parser.parse_args()
    if args.command == "capture":
        capture(args.out)
        return 0
    return 1 if compare(args.before, args.after) else 0


if __name__ == "__main__":
    sys.exit(main())
