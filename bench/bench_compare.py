"""The FOG beside the other height maps on recordings: the table of issue 16 and update times.

Run: PYTHONPATH=. .venv/bin/python bench/bench_compare.py --out DIR [--maps fog,elevation]
     [--no-pictures] [--ray ADDRESS] RECORDING [RECORDING ...]
(recordings made with ``fogsim record SCENARIO --seed N --out FILE``). Writes what ``fogsim
compare`` writes (``compare.json``, ``compare.md``, ``timing.md``, pictures) and prints the two
Markdown tables and the machine's load average at the start and the end (the update times are
wall-clock times: on a loaded machine they include waiting for a core; the figures do not).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")

from fogsim.compare.command import run_compare
from fogsim.compare.maps import MAP_NAMES, parse_maps
from fogsim.run.ray_cluster import RAY_ADDRESS_HELP


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("recordings", nargs="+")
    parser.add_argument("--out", required=True)
    parser.add_argument("--maps", default=",".join(MAP_NAMES))
    parser.add_argument("--no-pictures", action="store_true")
    parser.add_argument("--ray", metavar="ADDRESS", help=RAY_ADDRESS_HELP)
    args = parser.parse_args()
    print(f"load average at the start: {os.getloadavg()}")
    start = time.perf_counter()
    result = run_compare(
        args.recordings,
        parse_maps(args.maps),
        args.out,
        pictures=not args.no_pictures,
        ray_address=args.ray,
    )
    runs = sum(len(runs) for runs in result.groups.values())
    print(f"{runs} runs in {time.perf_counter() - start:.1f} s")
    for name in ("compare.md", "timing.md"):
        with open(os.path.join(args.out, name), encoding="utf-8") as handle:
            print(handle.read())
    print(f"load average at the end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
