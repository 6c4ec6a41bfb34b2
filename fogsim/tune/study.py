"""``fogsim tune``: search mapper and segmentation thresholds over a suite of recordings.

Each trial scores one parameter set by replaying every recording of the suite with it
(:func:`fogsim.run.runner.replay_report`, no rendering) and reducing the reports to one objective
(:mod:`fogsim.tune.objective`). The search is Optuna's: TPE (default), random, or a grid.

Storage and resuming: trials live in an Optuna SQLite database ``OUT/tune.db``. Only the driver
process talks to it (ask, tell, heartbeats); workers only score. Every trial is stored the moment
it finishes. A running trial carries a heartbeat; when a run is killed, the next run over the
same ``OUT`` fails its stale trials and queues their parameters again, so a resumed run
continues the trial count where the killed one stopped. ``--trials N`` is the total number of
scored trials the study should hold, not the number to add. SQLite transactions keep two runs on
one database from corrupting each other; a run whose search space, weights or suite differ from
the stored study is refused.

Determinism: the driver asks a batch of as many trials as there are workers, waits for the whole
batch and only then asks again, so with the same seed, suite and worker count the same
parameters are tried in the same order, whatever the workers' timing.

Parallelism: ``workers=1`` scores in the driver process, ``workers>1`` in a local process pool
(the recordings are handed to each worker once, at start), ``ray_address`` on a Ray cluster
(``ray start --head`` on one machine, ``ray start --address=HEAD:6379`` on the others; pass
``auto`` or the head's address, or ``local`` for a fresh local instance). With Ray the recordings
travel to the workers through Ray's object store (``ray.put`` once), not a shared disk; the
cluster's Python environments need ``fogsim`` importable.

Outputs in ``OUT``: ``best_params.toml`` (``[mapper]``/``[segmentation]`` blocks ready to paste
into a scenario), ``trials.md`` (the top trials), ``summary.json``, one
``objective_<parameter>.png`` per tuned parameter, and ``recordings/`` (recordings made from
scenario files, keyed by the scenario's hash).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import datetime
import hashlib
import itertools
import json
import math
import multiprocessing
import os
import statistics
import sys
import threading
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fogsim.atomic import write_atomic, write_text_atomic
from fogsim.errors import FogsimError
from fogsim.tune.objective import (
    ObjectiveWeights,
    ReportFunction,
    SuiteEntry,
    TrialScore,
    score_parameters,
)

if TYPE_CHECKING:  # optuna and sqlalchemy are imported where used: `fogsim --help` stays fast
    import optuna
    from optuna.distributions import BaseDistribution
    from optuna.trial import FrozenTrial

SEGMENTATION_PREFIX = "seg."
STUDY_FILE = "tune.db"
RECORDINGS_DIR = "recordings"
_CONFIG_ATTR = "fogsim_config"
_ABORT_AFTER_FAILURES = 4
"""A run stops when this many trials failed before any trial of it was scored."""
_HEARTBEAT_TRIALS_SQL = "SELECT trial_id FROM trial_heartbeats"
"""Trials that have a heartbeat (Optuna's RDB schema, table ``trial_heartbeats``)."""
TERM_COLUMNS = ("table1_mm", "cell_error_pct", "unknown_pct", "clearing_s")


class SamplerKind(StrEnum):
    """Search strategies."""

    TPE = "tpe"
    RANDOM = "random"
    GRID = "grid"


# ----------------------------------------------------------------------------- search space


def _numeric_defaults() -> dict[str, int | float]:
    """Defaults of every numeric (not bool) MapperParams and ``seg.`` SegmentationParams field."""
    from mapper.params import MapperParams
    from mapper.segmentation import SegmentationParams

    out: dict[str, int | float] = {}
    for prefix, params in (("", MapperParams()), (SEGMENTATION_PREFIX, SegmentationParams())):
        for f in dataclasses.fields(params):
            value = getattr(params, f.name)
            if isinstance(value, int | float) and not isinstance(value, bool):
                out[prefix + f.name] = value
    return out


def tunable_parameter_names() -> tuple[str, ...]:
    """Every name ``--param`` accepts (keys of a scenario's ``[mapper]``/``[segmentation]``).

    Numeric MapperParams fields, and ``seg.`` + numeric SegmentationParams fields.
    """
    return tuple(_numeric_defaults())


def parameter_defaults(names: Sequence[str]) -> dict[str, int | float]:
    """Library defaults (``MapperParams()``, ``SegmentationParams()``) of the named parameters.

    Raises:
        FogsimError: a name is not a tunable parameter (the message lists the allowed ones).
    """
    defaults = _numeric_defaults()
    unknown = [n for n in names if n not in defaults]
    if unknown:
        raise FogsimError(f"not tunable parameters: {unknown}; tunable: {', '.join(defaults)}")
    return {n: defaults[n] for n in names}


def _parse_bound(text: str, what: str, spec: str) -> int | float:
    text = text.strip()
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise FogsimError(f"--param {spec!r}: {what} bound {text!r} is not a number") from None
    if not math.isfinite(value):
        raise FogsimError(f"--param {spec!r}: {what} bound must be finite, got {text!r}")
    return value


@dataclass(frozen=True)
class ParamSpec:
    """One tuned parameter and its range.

    Attributes:
        name: A MapperParams field (``p_occ``) or ``seg.`` + a SegmentationParams field.
        low: Lower bound (inclusive).
        high: Upper bound (inclusive), > low.
        log: Sample on a log scale (needs low > 0).
        integer: Integer parameter (both bounds were written as integers).
    """

    name: str
    low: float
    high: float
    log: bool = False
    integer: bool = False

    def __post_init__(self) -> None:
        if not self.name:
            raise FogsimError("a tuned parameter needs a name")
        if not (math.isfinite(self.low) and math.isfinite(self.high)) or self.low >= self.high:
            raise FogsimError(
                f"parameter {self.name}: range must be finite with low < high, "
                f"got {self.low}:{self.high}"
            )
        if self.log and self.low <= 0:
            raise FogsimError(f"parameter {self.name}: a log range needs low > 0, got {self.low}")
        if self.integer and (self.low != int(self.low) or self.high != int(self.high)):
            raise FogsimError(f"parameter {self.name}: integer bounds must be whole numbers")

    @classmethod
    def parse(cls, text: str, allowed: Sequence[str] | None = None) -> ParamSpec:
        """Parse ``name=lo:hi`` or ``name=lo:hi:log`` (integer if both bounds are integers).

        Args:
            text: The ``--param`` value.
            allowed: Valid names; None = :func:`tunable_parameter_names`.

        Raises:
            FogsimError: naming what is wrong and what is allowed.
        """
        name, sep, rest = text.partition("=")
        name = name.strip()
        parts = rest.split(":")
        if not sep or len(parts) not in (2, 3) or (len(parts) == 3 and parts[2].strip() != "log"):
            raise FogsimError(
                f"--param {text!r} must look like name=lo:hi or name=lo:hi:log "
                "(e.g. p_occ=0.55:0.95, eps_m=0.005:0.05:log)"
            )
        names = tunable_parameter_names() if allowed is None else tuple(allowed)
        if name not in names:
            raise FogsimError(f"--param {text!r}: unknown parameter {name!r}; tunable: {names}")
        low = _parse_bound(parts[0], "lower", text)
        high = _parse_bound(parts[1], "upper", text)
        integer = isinstance(low, int) and isinstance(high, int)
        return cls(name, float(low), float(high), log=len(parts) == 3, integer=integer)

    def distribution(self) -> BaseDistribution:
        """The Optuna distribution of this range."""
        from optuna.distributions import FloatDistribution, IntDistribution

        if self.integer:
            return IntDistribution(int(self.low), int(self.high), log=self.log)
        return FloatDistribution(self.low, self.high, log=self.log)

    def suggest(self, trial: optuna.Trial) -> int | float:
        """Ask a trial for a value of this parameter."""
        if self.integer:
            return trial.suggest_int(self.name, int(self.low), int(self.high), log=self.log)
        return trial.suggest_float(self.name, self.low, self.high, log=self.log)

    def grid(self, points: int) -> list[int | float]:
        """``points`` values spread over the range (geometrically if ``log``), ends included."""
        if points < 2:
            raise FogsimError(f"grid points must be >= 2, got {points}")
        spread = np.geomspace if self.log else np.linspace
        values = spread(self.low, self.high, points)
        if self.integer:
            return sorted({int(v) for v in np.rint(values)})
        return [float(v) for v in values]

    def to_text(self) -> str:
        """The ``--param`` form of this spec."""
        fmt = (lambda v: str(int(v))) if self.integer else repr
        return f"{self.name}={fmt(self.low)}:{fmt(self.high)}" + (":log" if self.log else "")


# ----------------------------------------------------------------------------- configuration


@dataclass(frozen=True)
class TuneConfig:
    """What to tune and how.

    Attributes:
        params: The tuned parameters (at least one, distinct names).
        trials: Total number of scored trials the study should hold (resuming counts old ones).
        out_dir: Output directory (study database, recordings cache, results).
        sampler: Search strategy.
        seed: Sampler seed (same seed, suite and workers: same trials).
        workers: Parallel scoring processes (1 = in the driver process).
        ray_address: Ray cluster address (``auto``, ``HOST:PORT``, ``local``); None = no Ray.
        weights: Objective weights.
        grid_points: Values per parameter for the grid sampler.
        study_name: Name of the Optuna study in the database.
        top: Rows of the top-trials table.
        heartbeat_s: Heartbeat interval of running trials [s].
        grace_s: A running trial without heartbeat for this long is stale (its run died) [s].
        progress: Show a progress bar.
        pictures: Write the per-parameter pictures.
    """

    params: tuple[ParamSpec, ...]
    trials: int
    out_dir: Path
    sampler: SamplerKind = SamplerKind.TPE
    seed: int = 0
    workers: int = 1
    ray_address: str | None = None
    weights: ObjectiveWeights = field(default_factory=ObjectiveWeights)
    grid_points: int = 5
    study_name: str = "fogsim-tune"
    top: int = 10
    heartbeat_s: int = 10
    grace_s: int = 30
    progress: bool = True
    pictures: bool = True

    def __post_init__(self) -> None:
        if not self.params:
            raise FogsimError("tune needs at least one --param name=lo:hi")
        names = [p.name for p in self.params]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise FogsimError(f"parameters given more than once: {duplicates}")
        if self.trials < 1:
            raise FogsimError(f"trials must be >= 1, got {self.trials}")
        if self.workers < 1:
            raise FogsimError(f"workers must be >= 1, got {self.workers}")
        if self.grid_points < 2:
            raise FogsimError(f"grid_points must be >= 2, got {self.grid_points}")
        if self.top < 1:
            raise FogsimError(f"top must be >= 1, got {self.top}")
        if self.heartbeat_s < 1 or self.grace_s <= self.heartbeat_s:
            raise FogsimError(
                f"need heartbeat_s >= 1 and grace_s > heartbeat_s, got {self.heartbeat_s}, "
                f"{self.grace_s}"
            )
        object.__setattr__(self, "sampler", SamplerKind(self.sampler))
        object.__setattr__(self, "out_dir", Path(self.out_dir))

    @property
    def study_path(self) -> Path:
        """The SQLite database of the study."""
        return self.out_dir / STUDY_FILE

    @property
    def batch_size(self) -> int:
        """Trials asked at once (one per worker)."""
        return self.workers


# ----------------------------------------------------------------------------- the suite


def scenario_hash(scenario: Any) -> str:
    """16 hex digits of SHA-256 over the scenario's canonical TOML (the recording cache key)."""
    return hashlib.sha256(scenario.to_toml().encode("utf-8")).hexdigest()[:16]


def _record_scenario(scenario: Any, path: Path, max_frames: int | None) -> None:
    """Simulate a scenario once (its first ``max_frames`` frames) and save them with the truth."""
    from fogsim.data.recording import save_recording
    from fogsim.sim.simulation import Simulation

    simulation = Simulation(scenario)
    frames = list(itertools.islice(simulation.frames(), max_frames))
    truths = [simulation.truth_at(frame.time_s) for frame in frames]
    save_recording(path, frames, scenario=scenario, truths=truths)


def _first_frames(recording: Any, max_frames: int | None) -> Any:
    """The recording cut after ``max_frames`` frames (unchanged if shorter or None)."""
    if max_frames is None or len(recording.frames) <= max_frames:
        return recording
    return dataclasses.replace(
        recording, frames=recording.frames[:max_frames], truths=recording.truths[:max_frames]
    )


def _frame_rate_hz(recording: Any) -> float:
    scenario = getattr(recording, "scenario", None)
    if scenario is not None:
        return float(scenario.frame_rate_hz)
    times = [frame.time_s for frame in recording.frames]
    if len(times) < 2:
        raise FogsimError("cannot tell the frame rate of a one-frame recording without scenario")
    return float((len(times) - 1) / (times[-1] - times[0]))


def _entry(name: str, recording: Any) -> SuiteEntry:
    if not recording.has_truth:
        raise FogsimError(
            f"recording {name!r} has no ground truth for every frame; tuning scores runs "
            "against the truth, so it needs simulated recordings"
        )
    return SuiteEntry(name=name, recording=recording, frame_rate_hz=_frame_rate_hz(recording))


def _suite_files(source: str | os.PathLike[str]) -> list[Path]:
    """Scenario files and recordings named by one suite argument."""
    from fogsim.config.scenario import load_scenario

    path = Path(source)
    if path.is_dir():
        files = sorted([*path.glob("*.toml"), *path.glob("*.npz")])
        if not files:
            raise FogsimError(f"suite directory {path} holds no *.toml or *.npz files")
        return files
    if path.is_file() and path.suffix in (".toml", ".npz"):
        return [path]
    if path.suffix == "" and not path.exists():
        scenario = load_scenario(str(source))  # a scenario name; ScenarioError lists the known
        return [scenario.source_path]
    raise FogsimError(
        f"suite {str(source)!r} must be a directory of scenario files (*.toml) and/or "
        "recordings (*.npz), one such file, or a scenario name"
    )


def load_suite(
    sources: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    cache_dir: str | os.PathLike[str],
    *,
    quick: bool = False,
) -> list[SuiteEntry]:
    """The recordings of a suite.

    Args:
        sources: Directories of scenario files and/or recordings, single files, or scenario
            names (``stage``).
        cache_dir: Where recordings made from scenario files are kept, as
            ``<name>-<scenario hash>[-<frames>f].npz``: made once, reused while the scenario
            is unchanged.
        quick: Only the suite's quick subset (:data:`fogsim.run.suite.QUICK_SCENARIOS`, cut after
            :data:`fogsim.run.suite.QUICK_MAX_FRAMES` frames), as ``fogsim suite --quick`` runs it.

    Raises:
        FogsimError: a source is missing or empty, no file is left, names repeat, or a
            recording has no ground truth.
    """
    from fogsim.config.scenario import load_scenario
    from fogsim.data.recording import load_recording
    from fogsim.run.suite import QUICK_MAX_FRAMES, QUICK_SCENARIOS

    if isinstance(sources, str | os.PathLike):
        sources = [sources]
    files = [f for source in sources for f in _suite_files(source)]
    max_frames = QUICK_MAX_FRAMES if quick else None
    entries = []
    for path in files:
        if path.suffix == ".npz":
            recording = load_recording(path)
            name = getattr(recording.scenario, "name", path.stem)
            if not quick or name in QUICK_SCENARIOS:
                entries.append(_entry(path.stem, _first_frames(recording, max_frames)))
            continue
        scenario = load_scenario(path)
        if quick and scenario.name not in QUICK_SCENARIOS:
            continue
        suffix = "" if max_frames is None else f"-{max_frames}f"
        cached = Path(cache_dir) / f"{scenario.name}-{scenario_hash(scenario)}{suffix}.npz"
        if not cached.is_file():
            print(f"fogsim tune: recording {scenario.name} once into {cached}", file=sys.stderr)
            _record_scenario(scenario, cached, max_frames)
        entries.append(_entry(scenario.name, load_recording(cached)))
    if not entries:
        raise FogsimError(f"the quick subset {list(QUICK_SCENARIOS)} is not in the suite")
    names = [e.name for e in entries]
    if len(set(names)) != len(names):
        raise FogsimError(f"suite names must be distinct, got {names}")
    return entries


def _suite_identity(suite: Sequence[SuiteEntry]) -> list[str]:
    """Names and frame counts of the recordings (stored with the study, checked on resume)."""
    return [f"{e.name}:{len(getattr(e.recording, 'frames', ()))}" for e in suite]


# ----------------------------------------------------------------------------- executors


def default_report_function() -> ReportFunction:
    """:func:`fogsim.run.runner.replay_report` (imported lazily)."""
    from fogsim.run.runner import replay_report

    return replay_report


Outcome = TrialScore | BaseException

_WORKER_STATE: tuple[Sequence[SuiteEntry], ObjectiveWeights, ReportFunction] | None = None


def _pool_init(
    suite: Sequence[SuiteEntry], weights: ObjectiveWeights, report: ReportFunction
) -> None:
    global _WORKER_STATE
    _WORKER_STATE = (suite, weights, report)


def _pool_score(overrides: Mapping[str, float]) -> TrialScore:
    assert _WORKER_STATE is not None, "worker not initialised"
    suite, weights, report = _WORKER_STATE
    return score_parameters(suite, overrides, weights, report)


class _InlineExecutor:
    """Scores in the driver process, one trial at a time."""

    def __init__(
        self, suite: Sequence[SuiteEntry], weights: ObjectiveWeights, report: ReportFunction
    ) -> None:
        self._args = (suite, weights, report)

    def run(self, batch: Sequence[tuple[int, dict[str, float]]]) -> Iterator[tuple[int, Outcome]]:
        suite, weights, report = self._args
        for number, overrides in batch:
            try:
                yield number, score_parameters(suite, overrides, weights, report)
            except Exception as exc:
                yield number, exc

    def close(self) -> None:
        """Nothing to release."""


class _PoolExecutor:
    """A local process pool; each worker receives the recordings once, at start."""

    def __init__(
        self,
        suite: Sequence[SuiteEntry],
        weights: ObjectiveWeights,
        report: ReportFunction,
        workers: int,
    ) -> None:
        method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
        self._pool = concurrent.futures.ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context(method),
            initializer=_pool_init,
            initargs=(suite, weights, report),
        )

    def run(self, batch: Sequence[tuple[int, dict[str, float]]]) -> Iterator[tuple[int, Outcome]]:
        futures = {self._pool.submit(_pool_score, o): n for n, o in batch}
        for future in concurrent.futures.as_completed(futures):
            exc = future.exception()
            yield futures[future], exc if exc is not None else future.result()

    def close(self) -> None:
        """Shut the pool down (waits for running tasks)."""
        self._pool.shutdown(wait=True, cancel_futures=True)


def _ray_score(
    suite: Sequence[SuiteEntry],
    overrides: Mapping[str, float],
    weights: ObjectiveWeights,
    report: ReportFunction,
) -> TrialScore:
    return score_parameters(suite, overrides, weights, report)


class _RayExecutor:
    """Ray tasks on a cluster; the recordings go to the object store once (``ray.put``)."""

    def __init__(
        self,
        suite: Sequence[SuiteEntry],
        weights: ObjectiveWeights,
        report: ReportFunction,
        address: str,
        workers: int,
    ) -> None:
        try:
            import ray
        except ImportError as exc:
            raise FogsimError(
                "--ray needs the optional dependency ray: pip install 'fogsim[ray]'"
            ) from exc
        self._ray = ray
        self._owns_ray = not ray.is_initialized()
        if self._owns_ray:
            if address == "local":
                ray.init(include_dashboard=False, log_to_driver=False)
            else:
                ray.init(address=address, log_to_driver=False)
        self._suite_ref = ray.put(list(suite))
        self._weights = weights
        self._report = report
        self._task = ray.remote(num_cpus=1, max_retries=2)(_ray_score)
        cluster_cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self.slots = workers if workers > 1 else cluster_cpus

    def run(self, batch: Sequence[tuple[int, dict[str, float]]]) -> Iterator[tuple[int, Outcome]]:
        ray = self._ray
        pending = {
            self._task.remote(self._suite_ref, o, self._weights, self._report): n for n, o in batch
        }
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            number = pending.pop(done[0])
            try:
                yield number, ray.get(done[0])
            except Exception as exc:
                yield number, exc

    def close(self) -> None:
        """Disconnect from Ray if this executor connected."""
        if self._owns_ray:
            self._ray.shutdown()


class _Heartbeat:
    """A thread recording heartbeats of the driver's running trials in the study database."""

    def __init__(self, storage: optuna.storages.RDBStorage, interval_s: float) -> None:
        self._storage = storage
        self._interval_s = interval_s
        self._ids: set[int] = set()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="tune-heartbeat", daemon=True)
        self._thread.start()

    def add(self, trial_id: int) -> None:
        with self._lock:
            self._ids.add(trial_id)
        self._storage.record_heartbeat(trial_id)

    def remove(self, trial_id: int) -> None:
        with self._lock:
            self._ids.discard(trial_id)

    def _loop(self) -> None:
        while not self._stop.wait(self._interval_s):
            with self._lock:
                ids = sorted(self._ids)
            for trial_id in ids:
                self._storage.record_heartbeat(trial_id)

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


# ----------------------------------------------------------------------------- the study


def _storage(config: TuneConfig) -> optuna.storages.RDBStorage:
    import optuna

    config.out_dir.mkdir(parents=True, exist_ok=True)
    return optuna.storages.RDBStorage(
        f"sqlite:///{config.study_path.resolve()}",
        engine_kwargs={"connect_args": {"timeout": 60}},
        heartbeat_interval=config.heartbeat_s,
        grace_period=config.grace_s,
        heartbeat_stale_trial_callback=optuna.storages.RetryHeartbeatStaleTrialCallback(),
    )


def _sampler(config: TuneConfig) -> optuna.samplers.BaseSampler:
    import optuna

    if config.sampler is SamplerKind.TPE:
        return optuna.samplers.TPESampler(seed=config.seed, multivariate=True)
    # Random, and the grid (whose points are queued as fixed trials; see _queue_first_trials).
    return optuna.samplers.RandomSampler(seed=config.seed)


def _study_config(config: TuneConfig, suite: Sequence[SuiteEntry]) -> dict[str, Any]:
    return {
        "params": [p.to_text() for p in config.params],
        "weights": config.weights.to_dict(),
        "suite": _suite_identity(suite),
        "sampler": str(config.sampler),
        "grid_points": config.grid_points if config.sampler is SamplerKind.GRID else None,
    }


def _grid_points(config: TuneConfig, defaults: Mapping[str, float]) -> list[dict[str, Any]]:
    """The grid's parameter sets, the defaults' values added to each axis, in a seeded order."""
    axes = []
    for spec in config.params:
        values = set(spec.grid(config.grid_points))
        values.add(int(defaults[spec.name]) if spec.integer else float(defaults[spec.name]))
        axes.append(sorted(values))
    points = [
        dict(zip([p.name for p in config.params], combo, strict=True))
        for combo in itertools.product(*axes)
    ]
    order = np.random.default_rng(config.seed).permutation(len(points))
    return [points[i] for i in order]


def _open_study(
    config: TuneConfig, suite: Sequence[SuiteEntry], defaults: Mapping[str, float]
) -> tuple[optuna.Study, optuna.storages.RDBStorage, int]:
    """Create or resume the study; returns it, its storage and the number of trials to reach."""
    import optuna

    storage = _storage(config)
    study = optuna.create_study(
        storage=storage,
        sampler=_sampler(config),
        study_name=config.study_name,
        direction="minimize",
        load_if_exists=True,
    )
    wanted = _study_config(config, suite)
    stored = study.user_attrs.get(_CONFIG_ATTR)
    grid = _grid_points(config, defaults) if config.sampler is SamplerKind.GRID else None
    if stored is None:
        study.set_user_attr(_CONFIG_ATTR, wanted)
        first = {n: defaults[n] for n in (p.name for p in config.params)}
        study.enqueue_trial(first, user_attrs={"defaults": True})
        for point in grid or []:
            if point != first:
                study.enqueue_trial(point)
    elif stored != wanted:
        differing = sorted(k for k in wanted if stored.get(k) != wanted[k])
        raise FogsimError(
            f"study {config.study_name!r} in {config.study_path} was made with other "
            f"{', '.join(differing)} ({ {k: stored.get(k) for k in differing} }); use another "
            "--out or --study-name to start a new study"
        )
    target = config.trials if grid is None else min(config.trials, len(grid))
    return study, storage, target


def _fail_dead_trials(
    study: optuna.Study, storage: optuna.storages.RDBStorage, grace_s: float
) -> None:
    """Fail the trials of dead runs and queue their parameters again.

    Stale trials (heartbeat older than ``grace_s``) are Optuna's. A run killed between creating
    a trial and its first heartbeat leaves a RUNNING trial without any heartbeat, which Optuna
    never calls stale; such a trial older than ``grace_s`` is failed and retried here too (a
    live run heartbeats its trials milliseconds after creating them).
    """
    import optuna
    import sqlalchemy
    from optuna.trial import TrialState

    optuna.storages.fail_stale_trials(study)
    now = datetime.datetime.now()  # Optuna stamps datetime_start with local naive time
    old = [
        t
        for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
        if t.datetime_start is not None and (now - t.datetime_start).total_seconds() > grace_s
    ]
    if not old:
        return
    with storage.engine.connect() as connection:
        beating = {row[0] for row in connection.execute(sqlalchemy.text(_HEARTBEAT_TRIALS_SQL))}
    retry = optuna.storages.RetryHeartbeatStaleTrialCallback()
    for trial in old:
        if trial._trial_id in beating:
            continue
        try:
            storage.set_trial_state_values(trial._trial_id, state=TrialState.FAIL)
        except optuna.exceptions.UpdateFinishedTrialError:
            continue  # another run got there first
        retry(study, storage.get_trial(trial._trial_id))


def _finished(study: optuna.Study) -> int:
    """Scored trials: complete, or failed because scoring raised (not stale ones)."""
    from optuna.trial import TrialState

    trials = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.FAIL))
    return sum(t.state == TrialState.COMPLETE or "error" in t.user_attrs for t in trials)


def _tell(study: optuna.Study, trial: optuna.Trial, outcome: Outcome) -> None:
    from optuna.trial import TrialState

    if isinstance(outcome, BaseException):
        trial.set_user_attr("error", f"{type(outcome).__name__}: {outcome}")
        study.tell(trial, state=TrialState.FAIL)
        return
    trial.set_user_attr("terms", outcome.terms)
    trial.set_user_attr("report_s", outcome.report_s)
    trial.set_user_attr("objective_s", outcome.objective_s)
    study.tell(trial, outcome.objective)


def _make_executor(
    config: TuneConfig, suite: Sequence[SuiteEntry], report: ReportFunction
) -> _InlineExecutor | _PoolExecutor | _RayExecutor:
    if config.ray_address is not None:
        return _RayExecutor(suite, config.weights, report, config.ray_address, config.workers)
    if config.workers == 1:
        return _InlineExecutor(suite, config.weights, report)
    return _PoolExecutor(suite, config.weights, report, config.workers)


@dataclass(frozen=True)
class TuneResult:
    """The outcome of a tune.

    Attributes:
        best_params: Best parameter values by name.
        best_value: Its objective.
        defaults_value: Objective of the defaults trial (None if it failed).
        trials: Scored trials in the study (complete + failed in scoring).
        complete: Completed trials.
        out_dir: Where the results were written.
    """

    best_params: dict[str, float]
    best_value: float
    defaults_value: float | None
    trials: int
    complete: int
    out_dir: Path


def tune(
    config: TuneConfig,
    suite: Sequence[SuiteEntry],
    *,
    report_function: ReportFunction | None = None,
    defaults: Mapping[str, float] | None = None,
) -> TuneResult:
    """Run (or resume) a tune until the study holds ``config.trials`` scored trials.

    Args:
        config: What to tune and how.
        suite: The recordings every trial replays (:func:`load_suite`).
        report_function: ``(recording, overrides) -> report``; default
            :func:`fogsim.run.runner.replay_report`. Must be picklable for workers/Ray.
        defaults: Values of the first trial; default :func:`parameter_defaults`.

    Returns:
        The best parameters; the result files are written to ``config.out_dir``.

    Raises:
        FogsimError: invalid setup, a study made with other settings, or no trial scored.
    """
    import optuna

    if not suite:
        raise FogsimError("the suite is empty")
    report = report_function or default_report_function()
    names = [p.name for p in config.params]
    first = dict(defaults) if defaults is not None else parameter_defaults(names)
    missing = [n for n in names if n not in first]
    if missing:
        raise FogsimError(f"defaults lack values for {missing}")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    with warnings.catch_warnings():
        # Heartbeats are experimental in Optuna and meant for Study.optimize; we drive them.
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        warnings.filterwarnings("ignore", message="Heartbeat of storage", category=UserWarning)
        return _tune(config, suite, report, first)


def _tune(
    config: TuneConfig,
    suite: Sequence[SuiteEntry],
    report: ReportFunction,
    first: Mapping[str, float],
) -> TuneResult:
    study, storage, target = _open_study(config, suite, first)
    executor = _make_executor(config, suite, report)
    slots = getattr(executor, "slots", config.batch_size)
    heartbeat = _Heartbeat(storage, config.heartbeat_s)
    progress = None
    try:
        done = _finished(study)
        if config.progress:
            from tqdm import tqdm

            progress = tqdm(total=target, initial=min(done, target), desc="tune", unit="trial")
        failures: list[str] = []
        scored = 0
        while done < target:
            _fail_dead_trials(study, storage, config.grace_s)
            batch = {}
            for _ in range(min(slots, target - done)):
                trial = study.ask()
                heartbeat.add(trial._trial_id)  # at once: a trial without heartbeat never stales
                overrides = {p.name: p.suggest(trial) for p in config.params}
                batch[trial.number] = (trial, overrides)
            for number, outcome in executor.run([(n, o) for n, (_, o) in batch.items()]):
                trial = batch[number][0]
                _tell(study, trial, outcome)
                heartbeat.remove(trial._trial_id)
                if progress is not None:
                    progress.update(1)
                if isinstance(outcome, BaseException):
                    failures.append(f"trial {number}: {type(outcome).__name__}: {outcome}")
                else:
                    scored += 1
            if not scored and len(failures) >= _ABORT_AFTER_FAILURES:
                raise FogsimError(
                    f"the first {len(failures)} trials of this run all failed, stopping; "
                    f"first error: {failures[0]}"
                )
            done = _finished(study)
    finally:
        heartbeat.close()
        executor.close()
        if progress is not None:
            progress.close()
    return write_results(study, config)


# ----------------------------------------------------------------------------- results


def _mean_terms(trial: FrozenTrial) -> dict[str, float | None]:
    """Mean of each objective term over the trial's recordings (None where no recording has it)."""
    per_recording = trial.user_attrs.get("terms", {})
    out: dict[str, float | None] = {}
    for key in TERM_COLUMNS:
        values = [t[key] for t in per_recording.values() if t.get(key) is not None]
        out[key] = float(statistics.fmean(values)) if values else None
    return out


def _format_value(value: float, integer: bool) -> str:
    return str(int(value)) if integer else f"{value:.6g}"


def best_params_toml(params: Mapping[str, float], specs: Sequence[ParamSpec], comment: str) -> str:
    """``[mapper]`` (and ``[segmentation]``) TOML blocks of the given values, to paste."""
    integer = {s.name: s.integer for s in specs}
    mapper_lines = []
    seg_lines = []
    for name, value in params.items():
        text = str(int(value)) if integer.get(name) else repr(float(value))
        if name.startswith(SEGMENTATION_PREFIX):
            seg_lines.append(f"{name[len(SEGMENTATION_PREFIX) :]} = {text}")
        else:
            mapper_lines.append(f"{name} = {text}")
    blocks = [f"# {line}" for line in comment.splitlines()]
    if mapper_lines:
        blocks += ["[mapper]", *mapper_lines]
    if seg_lines:
        blocks += (["", "[segmentation]"] if mapper_lines else ["[segmentation]"]) + seg_lines
    return "\n".join(blocks) + "\n"


def _cell(value: float | None) -> str:
    return "–" if value is None else f"{value:.3f}"


def top_trials_markdown(trials: Sequence[FrozenTrial], specs: Sequence[ParamSpec]) -> str:
    """A Markdown table of trials (best first): objective, mean terms, parameters."""
    header = ["rank", "trial", "objective", "table1 mm", "wrong cells %", "unknown %"]
    header += ["clearing s"]
    header += [s.name for s in specs]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for rank, trial in enumerate(trials, start=1):
        terms = _mean_terms(trial)
        label = (
            f"{trial.number} (defaults)" if trial.user_attrs.get("defaults") else str(trial.number)
        )
        row = [str(rank), label, f"{trial.value:.4f}"]
        row += [_cell(terms[k]) for k in TERM_COLUMNS]
        row += [_format_value(trial.params[s.name], s.integer) for s in specs]
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def plot_parameter(
    trials: Sequence[FrozenTrial], spec: ParamSpec, path: Path, best: FrozenTrial
) -> Path:
    """Scatter of the objective against one parameter's value (defaults and best marked).

    Uses matplotlib's object API with the Agg canvas (no pyplot state, no display needed).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(5.0, 3.6), dpi=100)
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    x = [t.params[spec.name] for t in trials]
    y = [t.value for t in trials]
    dots = axes.scatter(x, y, s=14, c=[t.number for t in trials], cmap="viridis", label="trials")
    figure.colorbar(dots, ax=axes, label="trial number")
    for trial in trials:
        if trial.user_attrs.get("defaults"):
            axes.scatter(
                [trial.params[spec.name]], [trial.value], marker="s", s=60,
                facecolors="none", edgecolors="tab:red", label="defaults",
            )  # fmt: skip
    axes.scatter(
        [best.params[spec.name]], [best.value], marker="*", s=140, c="tab:orange",
        edgecolors="black", label="best",
    )  # fmt: skip
    if spec.log:
        axes.set_xscale("log")
    # Keep the interesting range readable: trials far worse than most are left off the top.
    q1, q3 = np.quantile(y, [0.25, 0.75])
    top = q3 + 3.0 * max(q3 - q1, 1e-9 * max(abs(q3), 1.0))
    off_top = sum(value > top for value in y)
    title = f"objective vs {spec.name} ({len(trials)} trials"
    if off_top:
        low = min(y)
        axes.set_ylim(low - 0.05 * (top - low), top + 0.05 * (top - low))
        title += f", {off_top} above the plot"
    axes.set_xlabel(spec.name)
    axes.set_ylabel("objective (lower is better)")
    axes.set_title(title + ")", fontsize=10)
    axes.legend(fontsize=7, loc="best")
    figure.tight_layout()
    return write_atomic(path, lambda handle: figure.savefig(handle, format="png"))


def _median_attr(trials: Sequence[FrozenTrial], key: str) -> float | None:
    values = [t.user_attrs[key] for t in trials if key in t.user_attrs]
    return float(statistics.median(values)) if values else None


def write_results(study: optuna.Study, config: TuneConfig) -> TuneResult:
    """Write best_params.toml, trials.md, summary.json and the per-parameter plots.

    Raises:
        FogsimError: no trial completed (the message quotes the first scoring error).
    """
    from optuna.trial import TrialState

    trials = study.get_trials(deepcopy=False)
    complete = sorted(
        (t for t in trials if t.state == TrialState.COMPLETE), key=lambda t: (t.value, t.number)
    )
    errors = [t for t in trials if t.state == TrialState.FAIL and "error" in t.user_attrs]
    if not complete:
        first_error = errors[0].user_attrs["error"] if errors else "no trial was run"
        raise FogsimError(f"no trial completed; first error: {first_error}")
    best = complete[0]
    defaults = next((t for t in complete if t.user_attrs.get("defaults")), None)
    defaults_value = None if defaults is None else float(defaults.value)
    out = config.out_dir
    comment = (
        f"fogsim tune: best of {len(complete)} trials (trial {best.number}), objective "
        f"{best.value:.6g}" + ("" if defaults is None else f"; defaults {defaults.value:.6g}")
    )
    specs = config.params
    write_text_atomic(out / "best_params.toml", best_params_toml(best.params, specs, comment))
    table = top_trials_markdown(complete[: config.top], specs)
    title = f"# fogsim tune: top {min(config.top, len(complete))} of {len(complete)} trials\n\n"
    write_text_atomic(out / "trials.md", title + table)
    if config.pictures:
        for spec in specs:
            plot_parameter(complete, spec, out / f"objective_{spec.name}.png", best)
    summary = {
        "study": config.study_name,
        "best": {"trial": best.number, "objective": best.value, "params": best.params},
        "defaults": None
        if defaults is None
        else {"trial": defaults.number, "objective": defaults.value, "params": defaults.params},
        "best_terms": best.user_attrs.get("terms"),
        "trials": {"complete": len(complete), "failed": len(errors)},
        "timing": {
            "median_report_s": _median_attr(complete, "report_s"),
            "median_objective_s": _median_attr(complete, "objective_s"),
        },
        "config": {
            "params": [p.to_text() for p in specs],
            "sampler": str(config.sampler),
            "seed": config.seed,
            "workers": config.workers,
            "ray": config.ray_address,
            "weights": config.weights.to_dict(),
        },
    }
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=2) + "\n")
    return TuneResult(
        best_params=dict(best.params),
        best_value=float(best.value),
        defaults_value=defaults_value,
        trials=len(complete) + len(errors),
        complete=len(complete),
        out_dir=out,
    )


# ----------------------------------------------------------------------------- command line


def add_tune_arguments(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``tune`` subcommand to an argparse subparsers object; returns its parser."""
    parser = subparsers.add_parser(
        "tune",
        help="tune mapper/segmentation thresholds over a suite of recordings",
        description="Search mapper and segmentation thresholds (Optuna TPE, random or grid) "
        "by replaying a suite's recordings; results and the study database go to --out, and "
        "running the same command again resumes the study.",
        epilog="example: fogsim tune scenarios --quick --param p_occ=0.55:0.95 "
        "--param eps_m=0.005:0.05:log --trials 40 --workers 2 --out runs/tune",
    )
    parser.add_argument(
        "suite",
        nargs="+",
        help="directories of scenarios (*.toml) / recordings (*.npz), such files, or "
        "scenario names",
    )
    parser.add_argument(
        "--quick", action="store_true", help="only the suite's quick subset, cut short"
    )
    parser.add_argument(
        "--param",
        action="append",
        required=True,
        metavar="NAME=LO:HI[:log]",
        help="a tuned parameter and its range, e.g. p_occ=0.55:0.95 or seg.<name>=1:9",
    )
    parser.add_argument("--trials", type=int, default=50, help="total scored trials (default 50)")
    parser.add_argument(
        "--sampler", choices=[s.value for s in SamplerKind], default=SamplerKind.TPE.value
    )
    parser.add_argument("--grid-points", type=int, default=5, help="values per axis (grid)")
    parser.add_argument("--seed", type=int, default=0, help="sampler seed (default 0)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, default=1, help="local scoring processes")
    where.add_argument(
        "--ray",
        metavar="ADDRESS",
        default=None,
        help="run trials on a Ray cluster (auto, HOST:PORT, or local)",
    )
    parser.add_argument(
        "--weight",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="objective weight (repeatable): table1_mm, cell_error_pct, unknown_pct, "
        "clearing_s, missing_row_mm, never_cleared_s; see fogsim.tune.objective",
    )
    parser.add_argument("--out", required=True, type=Path, help="output directory")
    parser.add_argument("--study-name", default="fogsim-tune")
    parser.add_argument("--top", type=int, default=10, help="rows of the top-trials table")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--no-pictures", action="store_true", help="no per-parameter PNGs")
    parser.set_defaults(func=run_tune)
    return parser


def run_tune(args: argparse.Namespace) -> int:
    """Run ``fogsim tune`` from parsed arguments; prints the best block and the top table."""
    params = tuple(ParamSpec.parse(text) for text in args.param)
    config = TuneConfig(
        params=params,
        trials=args.trials,
        out_dir=args.out,
        sampler=SamplerKind(args.sampler),
        seed=args.seed,
        workers=args.workers,
        ray_address=args.ray,
        weights=ObjectiveWeights.from_assignments(args.weight),
        grid_points=args.grid_points,
        study_name=args.study_name,
        top=args.top,
        progress=not args.no_progress,
        pictures=not args.no_pictures,
    )
    suite = load_suite(args.suite, config.out_dir / RECORDINGS_DIR, quick=args.quick)
    result = tune(config, suite)
    print((result.out_dir / "best_params.toml").read_text(encoding="utf-8"))
    print((result.out_dir / "trials.md").read_text(encoding="utf-8"))
    return 0


def tune_main(argv: Sequence[str] | None = None) -> int:
    """``python -m fogsim.tune.study ...``: the ``tune`` subcommand on its own."""
    parser = argparse.ArgumentParser(prog="fogsim")
    add_tune_arguments(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["tune", *(sys.argv[1:] if argv is None else argv)])
    try:
        return args.func(args)
    except FogsimError as exc:
        print(f"fogsim tune: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(tune_main())
