"""``fogsim compare``: replay recordings (or simulate scenarios) into every map, write the tables.

Each input is a recording file (``fogsim record``; its own scenario and seed) or a scenario name,
simulated once per seed of ``seeds``. Each such run is one job (all maps in it: they share the
FOG's pipeline input, :mod:`fogsim.compare.replay`); with ``--ray ADDRESS`` the jobs run as Ray
tasks, each recording put into the object store once. Runs are grouped by scenario; ``OUT`` gets
``compare.json`` and ``compare.md`` (mean and worst over each group's runs, no timing: the same
inputs give the same bytes), ``timing.md`` (update time per frame of each map) and, with
pictures, ``<run>.png`` of each group's first run (:mod:`fogsim.compare.pictures`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from fogsim.atomic import write_atomic
from fogsim.compare.maps import MapSettings, parse_maps
from fogsim.compare.pictures import draw_comparison
from fogsim.compare.replay import RunComparison, compare_frames
from fogsim.compare.scans import HeightScanParams
from fogsim.compare.table import comparison_json, comparison_markdown, timing_markdown
from fogsim.config import Scenario, load_scenario, resolve_params
from fogsim.data.recording import Recording, load_recording
from fogsim.errors import FogsimError
from fogsim.run.output_paths import check_output_path
from fogsim.run.ray_cluster import RayCluster, check_ray_address
from fogsim.run.runner import sensor_fields
from fogsim.run.seed_spec import parse_seeds
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


CompareJob = str | Scenario
"""One run to compare: a recording file's path, or a scenario with its seed applied."""


def compare_jobs(inputs: Sequence[str], seeds: Sequence[int] | None) -> list[CompareJob]:
    """The runs of the inputs, in order: recordings as they are, scenarios once per seed.

    Raises:
        FogsimError: A name that is no file without ``seeds``, or an unknown scenario.
    """
    jobs: list[CompareJob] = []
    for item in inputs:
        if os.path.isfile(item):
            jobs.append(item)
            continue
        if seeds is None:
            raise FogsimError(
                f"{item!r} is no recording file; to simulate a scenario give --seeds SPEC"
            )
        base = load_scenario(item)
        jobs += [base.with_overrides([f"seed={seed}"]) for seed in seeds]
    return jobs


def compare_source(
    source: Recording | Scenario,
    fallback_name: str,
    maps: tuple[str, ...],
    settings: MapSettings,
    scan: HeightScanParams,
) -> tuple[str, RunComparison]:
    """(group, comparison) of one recording, or of one scenario simulated at its seed.

    Args:
        source: A loaded recording, or a scenario with its seed.
        fallback_name: Group and run name of a recording without a scenario (its file's stem).
        maps: Map names.
        settings: Parameters of the maps.
        scan: The height-scan pattern.
    """
    if isinstance(source, Recording):
        scenario = source.scenario
        frames, truth_at = source.frames, source.truth_at
    else:
        scenario = source
        simulation = Simulation(scenario)
        frames, truth_at = simulation.frames(), simulation.truth_at
    group = scenario.name if scenario is not None else fallback_name
    name = f"{group}_s{scenario.seed}" if scenario is not None else fallback_name
    params = resolve_params(scenario, sensor=sensor_fields(scenario))
    return group, compare_frames(name, frames, truth_at, scenario, params, maps, settings, scan)


def _run_jobs(
    jobs: Sequence[CompareJob],
    arguments: tuple[tuple[str, ...], MapSettings, HeightScanParams],
    ray_address: str | None,
) -> list[tuple[str, RunComparison]]:
    """Every job's (group, comparison) in order: here, one at a time, or as Ray tasks.

    Here each recording is loaded when its turn comes; for Ray the driver loads each one and
    puts it into the object store once, so the nodes need no copy of the files.
    """
    if ray_address is None:
        return [
            compare_source(
                load_recording(job) if isinstance(job, str) else job, _stem(job), *arguments
            )
            for job in jobs
        ]
    with RayCluster(ray_address) as cluster:
        tasks = [
            (
                cluster.put(load_recording(job)) if isinstance(job, str) else job,
                _stem(job),
                *arguments,
            )
            for job in jobs
        ]
        return cluster.map(compare_source, tasks)


def _stem(job: CompareJob) -> str:
    """A recording's file stem: its name when it holds no scenario."""
    return Path(job).stem if isinstance(job, str) else ""


def run_compare(
    inputs: Sequence[str],
    maps: tuple[str, ...],
    out: str | os.PathLike[str],
    *,
    seeds: Sequence[int] | None = None,
    settings: MapSettings | None = None,
    scan: HeightScanParams | None = None,
    pictures: bool = True,
    ray_address: str | None = None,
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
        ray_address: Run the runs as tasks on this Ray cluster
            (:class:`~fogsim.run.ray_cluster.RayCluster`; the tables are the same bit for bit);
            None = one after the other in this process.

    Raises:
        FogsimError: No inputs, a scenario name without seeds, an invalid or unreachable
            ``ray_address`` (all before any run), a run without ground truth.
    """
    if not inputs:
        raise FogsimError("fogsim compare needs recordings or scenario names")
    if ray_address is not None:
        check_ray_address(ray_address)
    settings = settings if settings is not None else MapSettings()
    scan = scan if scan is not None else HeightScanParams()
    jobs = compare_jobs(inputs, seeds)
    groups: dict[str, list[RunComparison]] = {}
    for group, run in _run_jobs(jobs, (maps, settings, scan), ray_address):
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
    ray_address: str | None = None,
) -> int:
    """``fogsim compare INPUTS --maps SPEC --out DIR [--seeds SPEC]``: check, run, print.

    Args:
        inputs: Recording files and scenario names.
        maps: ``--maps`` (``fog,averaging,elevation,octomap,last``).
        out: ``--out``, checked before any work.
        seeds: ``--seeds`` for the scenario names.
        pictures: Draw each group's first run.
        quiet: Print only the files written, not the tables.
        ray_address: ``--ray``: run the runs as tasks on this Ray cluster.

    Returns:
        The exit code (0).

    Raises:
        FogsimError: Bad ``--maps``, ``--seeds``, ``--ray`` or inputs (exit 2 in the command
            line).
        OutputError: ``out`` cannot be written.
    """
    names = parse_maps(maps)
    seed_list = parse_seeds(seeds) if seeds is not None else None
    folder = check_output_path(out, "folder", "--out")
    result = run_compare(
        inputs, names, folder, seeds=seed_list, pictures=pictures, ray_address=ray_address
    )
    if not quiet:
        print((folder / "compare.md").read_text(encoding="utf-8"))
        print((folder / "timing.md").read_text(encoding="utf-8"))
    print("wrote " + ", ".join(str(path) for path in result.files))
    return 0
