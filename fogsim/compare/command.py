"""``fogsim compare``: replay recordings (or simulate scenarios) into every map, write the tables.

Each input is a recording file (``fogsim record``; its own scenario and seed) or a scenario name,
simulated once per seed of ``seeds``. Runs are grouped by scenario; ``OUT`` gets
``compare.json`` and ``compare.md`` (mean and worst over each group's runs, no timing: the same
inputs give the same bytes), ``timing.md`` (update time per frame of each map) and, with
pictures, ``<run>.png`` of each group's first run (:mod:`fogsim.compare.pictures`).
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from fogsim.atomic import write_atomic
from fogsim.compare.maps import MapSettings, parse_maps
from fogsim.compare.pictures import draw_comparison
from fogsim.compare.replay import RunComparison, compare_frames
from fogsim.compare.scans import HeightScanParams
from fogsim.compare.table import comparison_json, comparison_markdown, timing_markdown
from fogsim.config import load_scenario, resolve_params
from fogsim.data.recording import load_recording
from fogsim.errors import FogsimError
from fogsim.run.output_paths import check_output_path
from fogsim.run.runner import sensor_fields
from fogsim.run.seeds import parse_seeds
from fogsim.sim.simulation import Simulation


@dataclass(frozen=True)
class CompareResult:
    """What :func:`run_compare` wrote and measured.

    Attributes:
        groups: Per scenario, its runs' comparisons.
        files: The files written into ``OUT``.
    """

    groups: dict[str, list[RunComparison]]
    files: tuple[Path, ...]


def _runs(
    inputs: Sequence[str],
    seeds: Sequence[int] | None,
    maps: tuple[str, ...],
    settings: MapSettings,
    scan: HeightScanParams,
) -> Iterator[tuple[str, RunComparison]]:
    """(group, comparison) of every input, in order: recordings as they are, scenarios per seed."""
    for item in inputs:
        if os.path.isfile(item):
            recording = load_recording(item)
            scenario = recording.scenario
            group = scenario.name if scenario is not None else Path(item).stem
            name = f"{group}_s{scenario.seed}" if scenario is not None else Path(item).stem
            yield (
                group,
                compare_frames(
                    name,
                    recording.frames,
                    recording.truth_at,
                    scenario,
                    resolve_params(scenario, sensor=sensor_fields(scenario)),
                    maps,
                    settings,
                    scan,
                ),
            )
            continue
        if seeds is None:
            raise FogsimError(
                f"{item!r} is no recording file; to simulate a scenario give --seeds SPEC"
            )
        base = load_scenario(item)
        for seed in seeds:
            scenario = base.with_overrides([f"seed={seed}"])
            simulation = Simulation(scenario)
            yield (
                base.name,
                compare_frames(
                    f"{base.name}_s{seed}",
                    simulation.frames(),
                    simulation.truth_at,
                    scenario,
                    resolve_params(scenario, sensor=sensor_fields(scenario)),
                    maps,
                    settings,
                    scan,
                ),
            )


def run_compare(
    inputs: Sequence[str],
    maps: tuple[str, ...],
    out: str | os.PathLike[str],
    *,
    seeds: Sequence[int] | None = None,
    settings: MapSettings | None = None,
    scan: HeightScanParams | None = None,
    pictures: bool = True,
) -> CompareResult:
    """Compare the maps on every input and write the tables (module docstring).

    Args:
        inputs: Recording files and scenario names.
        maps: Map names (:func:`fogsim.compare.maps.parse_maps`).
        out: Output folder (created; the files named in the module are replaced).
        seeds: Seeds of the scenarios named in ``inputs``.
        settings: Parameters of the maps.
        scan: The height-scan pattern.
        pictures: Also draw each group's first run.

    Raises:
        FogsimError: No inputs, a scenario name without seeds, a run without ground truth.
    """
    if not inputs:
        raise FogsimError("fogsim compare needs recordings or scenario names")
    settings = settings if settings is not None else MapSettings()
    scan = scan if scan is not None else HeightScanParams()
    groups: dict[str, list[RunComparison]] = {}
    for group, run in _runs(inputs, seeds, maps, settings, scan):
        groups.setdefault(group, []).append(run)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    texts = {
        "compare.json": comparison_json(groups, maps),
        "compare.md": comparison_markdown(groups),
        "timing.md": timing_markdown(groups),
    }
    files = [
        write_atomic(folder / name, lambda handle, text=text: handle.write(text.encode()))
        for name, text in texts.items()
    ]
    if pictures:
        files += [
            draw_comparison(runs[0], folder / f"{runs[0].name}.png") for runs in groups.values()
        ]
    return CompareResult(groups, tuple(files))


def compare_main(
    inputs: Sequence[str],
    maps: str,
    out: str | os.PathLike[str],
    *,
    seeds: str | None = None,
    pictures: bool = True,
    quiet: bool = False,
) -> int:
    """``fogsim compare INPUTS --maps SPEC --out DIR [--seeds SPEC]``: check, run, print.

    Args:
        inputs: Recording files and scenario names.
        maps: ``--maps`` (``fog,averaging,elevation,octomap,last``).
        out: ``--out``, checked before any work.
        seeds: ``--seeds`` for the scenario names.
        pictures: Draw each group's first run.
        quiet: Print only the files written, not the tables.

    Returns:
        The exit code (0).

    Raises:
        FogsimError: Bad ``--maps``, ``--seeds`` or inputs (exit 2 in the command line).
        OutputError: ``out`` cannot be written.
    """
    names = parse_maps(maps)
    seed_list = parse_seeds(seeds) if seeds is not None else None
    folder = check_output_path(out, "folder", "--out")
    result = run_compare(inputs, names, folder, seeds=seed_list, pictures=pictures)
    if not quiet:
        print((folder / "compare.md").read_text(encoding="utf-8"))
        print((folder / "timing.md").read_text(encoding="utf-8"))
    print("wrote " + ", ".join(str(path) for path in result.files))
    return 0
