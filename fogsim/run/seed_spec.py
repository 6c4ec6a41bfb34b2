"""A ``--seeds`` spec (``1-8``, ``1,3,5``, ``1-4,9``): its seeds, and back.

Apart from :mod:`fogsim.run.seeds` (which runs the seeds) so that the command line can name
what a spec allows in its help, and read one, without importing the runner of seeds.
"""

from __future__ import annotations

import collections
import itertools
import re
from collections.abc import Sequence

from fogsim.errors import FogsimError

MAX_SEED = 2**32 - 1
"""The largest seed a scenario takes (``seed`` in the scenario schema)."""

MAX_SEEDS = 1000
"""Most seeds of one ``--seeds`` spec. Each seed is a whole run (seconds to minutes); a thousand
runs of the stage take hours even on many cores, and the worst of a thousand seeds is more
statistics than a regression check needs. A larger spec is a slip (``1-10000000``) that would
otherwise build millions of jobs before the first run."""

SEEDS_ALLOWED = (
    "a range 1-8, a list 1,3,5, a single seed 2, or a mix such as 1-4,9 "
    f"(whole numbers 0 to {MAX_SEED}, each seed once, at most {MAX_SEEDS} seeds)"
)

_ITEM = re.compile(r"\s*(\d+)\s*(?:-\s*(\d+)\s*)?")


def parse_seeds(spec: str) -> tuple[int, ...]:
    """The seeds of a ``--seeds`` spec such as ``1-8``, ``1,3,5`` or ``2``, sorted.

    Args:
        spec: Comma-separated seeds and inclusive ranges ``first-last``.

    Raises:
        FogsimError: A malformed item, a backward range, a seed out of range, a repeated seed
            or more than :data:`MAX_SEEDS` seeds; the message names the argument, the spec and
            what is allowed.
    """
    seeds: list[int] = []
    for item in spec.split(","):
        match = _ITEM.fullmatch(item)
        if match is None:
            raise FogsimError(
                f"--seeds {spec!r}: {item.strip()!r} is not a seed or a range; "
                f"allowed: {SEEDS_ALLOWED}"
            )
        first = int(match[1])
        last = int(match[2]) if match[2] is not None else first
        if last < first:
            raise FogsimError(
                f"--seeds {spec!r}: range {item.strip()!r} ends before it starts; "
                f"allowed: {SEEDS_ALLOWED}"
            )
        if last > MAX_SEED:
            raise FogsimError(
                f"--seeds {spec!r}: seed {last} is above {MAX_SEED}; allowed: {SEEDS_ALLOWED}"
            )
        if len(seeds) + last - first + 1 > MAX_SEEDS:
            raise FogsimError(
                f"--seeds {spec!r}: more than {MAX_SEEDS} seeds; allowed: {SEEDS_ALLOWED}"
            )
        seeds.extend(range(first, last + 1))
    repeated = sorted(seed for seed, count in collections.Counter(seeds).items() if count > 1)
    if repeated:
        raise FogsimError(
            f"--seeds {spec!r}: seed {repeated[0]} is given twice; allowed: {SEEDS_ALLOWED}"
        )
    return tuple(sorted(seeds))


def format_seeds(seeds: Sequence[int]) -> str:
    """The canonical spec of sorted distinct seeds: runs of consecutive seeds as ranges.

    ``(1, 2, 3, 4, 9)`` → ``"1-4,9"``; :func:`parse_seeds` reads it back.
    """
    parts = []
    for _, run in itertools.groupby(enumerate(seeds), key=lambda pair: pair[1] - pair[0]):
        members = [seed for _, seed in run]
        first, last = members[0], members[-1]
        parts.append(str(first) if first == last else f"{first}-{last}")
    return ",".join(parts)
