"""Before/after table of two seed-runner summaries: each figure's mean and worst, worst first.

Reads the ``summary.json`` of two ``fogsim suite --seeds`` runs (or of two ``fogsim run SCENARIO
--seeds`` runs) and prints, per scenario, one markdown table: for every figure that either run
has, the mean and the worst value (with its seed) before and after. Scenarios are listed in the
order of the "after" run; rows put Table I first, then cells, safety, events and step edges.

Usage::

    fogsim suite --seeds 1-8 --out runs/before
    # ... change the code ...
    fogsim suite --seeds 1-8 --out runs/after
    python bench/seeds_table.py runs/before/summary.json runs/after/summary.json [--only stage]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import msgspec

from fogsim.eval.report.io import load_json
from fogsim.run.seeds import FigureStats, SeedsSummary
from fogsim.run.suite import SuiteSummary

_ORDER = ("table1.", "cells.", "safety.", "events.", "pose_error.", "step_edges.")
"""Figure groups in the order the tables list them."""


class _Format(msgspec.Struct):
    """The ``format`` key every summary carries (the other keys are ignored here)."""

    format: str


def _figures(path: Path) -> dict[str, dict[str, FigureStats]]:
    """Scenario → figure → statistics, from a suite or a seeds summary."""
    if msgspec.json.decode(path.read_bytes(), type=_Format).format == "fogsim-seeds":
        seeds = load_json(path, SeedsSummary, "seeds summary")
        return {seeds.scenario: seeds.figures}
    suite = load_json(path, SuiteSummary, "suite summary")
    return {name: runs.figures for name, runs in suite.scenarios.items()}


def _rank(name: str) -> tuple[int, str]:
    group = next((i for i, prefix in enumerate(_ORDER) if name.startswith(prefix)), len(_ORDER))
    return group, name


def _cell(stats: FigureStats | None) -> str:
    if stats is None:
        return "— | —"
    return f"{stats.mean:.4g} | {stats.worst:.4g} (s{stats.worst_seed})"


def table(before: Path, after: Path, only: set[str] | None = None) -> str:
    """The markdown tables of every scenario in ``after`` (and ``before``'s missing ones)."""
    old, new = _figures(before), _figures(after)
    names = list(new) + [name for name in old if name not in new]
    out = []
    for scenario in names:
        if only and scenario not in only:
            continue
        a, b = old.get(scenario, {}), new.get(scenario, {})
        rows = sorted(set(a) | set(b), key=_rank)
        rows = [r for r in rows if not r.startswith("timing.")]
        out.append(f"**{scenario}**\n")
        out.append("| figure | before mean | before worst | after mean | after worst |")
        out.append("|---|---:|---:|---:|---:|")
        out.extend(f"| {r} | {_cell(a.get(r))} | {_cell(b.get(r))} |" for r in rows)
        out.append("")
    return "\n".join(out)


def main() -> None:
    """Print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", type=Path, help="summary.json before")
    parser.add_argument("after", type=Path, help="summary.json after")
    parser.add_argument("--only", action="append", help="only this scenario (repeatable)")
    args = parser.parse_args()
    print(table(args.before, args.after, set(args.only) if args.only else None))


if __name__ == "__main__":
    main()
