"""The tune loop: ask a batch of trials, score it, tell the results, until enough are scored.

Each trial scores one parameter set by replaying every recording of the suite with it
(:func:`fogsim.run.runner.replay_report`, no rendering) and reducing the reports to one objective
(:mod:`fogsim.tune.objective`). The search is Optuna's: TPE (default), random, or a grid.

Storage and resuming: trials live in an Optuna SQLite database ``OUT/tune.db``. Only the driver
process talks to it (ask, tell, heartbeats); workers only score. Every trial is stored the moment
it finishes. A running trial carries a heartbeat; when a run is killed, the next run over the
same ``OUT`` fails its stale trials and queues their parameters again
(:mod:`fogsim.tune.recovery`), so a resumed run continues the trial count where the killed one
stopped (a run restarted within the grace period waits, before it ends, for the killed run's
trials to go stale). ``--trials N`` is the total number of scored trials the study should hold,
not the number to add. SQLite transactions keep two runs on one database from corrupting each
other; a run whose search space, weights or suite differ from the stored study is refused.

Determinism: the driver asks a batch of as many trials as the executor scores at once, waits for
the whole batch and only then asks again, so with the same seed, suite and worker count the same
parameters are tried in the same order, whatever the workers' timing.

Parallelism (:mod:`fogsim.tune.executors`): ``workers=1`` scores in the driver process,
``workers>1`` in a local process pool (the recordings are handed to each worker once, at start),
``ray_address`` on a Ray cluster (``ray start --head`` on one machine,
``ray start --address=HEAD:6379`` on the others; pass ``auto`` or the head's address, or
``local`` for a fresh local instance). With Ray the recordings travel to the workers through
Ray's object store (``ray.put`` once), not a shared disk; the cluster's Python environments need
``fogsim`` importable.

Outputs in ``OUT`` (:mod:`fogsim.tune.writers`): ``best_params.toml`` (``[mapper]``/
``[segmentation]`` blocks ready to paste into a scenario), ``trials.md`` (the top trials),
``summary.json``, one ``objective_<parameter>.png`` per tuned parameter, and ``recordings/``
(recordings made from scenario files, keyed by the scenario's hash).
"""

from __future__ import annotations

import itertools
import sys
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import optuna
from optuna.trial import TrialState
from tqdm import tqdm

from fogsim.errors import TuneError
from fogsim.tune.config import SamplerKind, TuneConfig
from fogsim.tune.executors import TrialOutcome, TrialRequest, make_executor
from fogsim.tune.objective import ReportFunction, SuiteEntry
from fogsim.tune.recovery import (
    TrialHeartbeat,
    fail_dead_trials,
    fail_dead_trials_before_exit,
    open_storage,
)
from fogsim.tune.space import check_ranges, parameter_defaults
from fogsim.tune.writers import TuneResult, write_results

_CONFIG_ATTR = "fogsim_config"
"""The study user attribute holding the settings it was made with (checked on resume)."""
_ABORT_AFTER_FAILURES = 4
"""A run stops when this many trials failed before any trial of it was scored."""


def _sampler(config: TuneConfig) -> optuna.samplers.BaseSampler:
    if config.sampler is SamplerKind.TPE:
        return optuna.samplers.TPESampler(seed=config.seed, multivariate=True)
    # Random, and the grid (whose points are queued as fixed trials; see _open_study).
    return optuna.samplers.RandomSampler(seed=config.seed)


def suite_identity(suite: Sequence[SuiteEntry]) -> list[str]:
    """Names and frame counts of the recordings (stored with the study, checked on resume)."""
    return [f"{e.name}:{len(e.recording.frames)}" for e in suite]


def _study_config(config: TuneConfig, suite: Sequence[SuiteEntry]) -> dict[str, Any]:
    """The settings a study is made with; a resumed run must have the same."""
    return {
        "params": [p.to_text() for p in config.params],
        "weights": config.weights.to_dict(),
        "suite": suite_identity(suite),
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
    storage = open_storage(config)
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
        raise TuneError(
            f"study {config.study_name!r} in {config.study_path} was made with other "
            f"{', '.join(differing)} ({ {k: stored.get(k) for k in differing} }); use another "
            "--out or --study-name to start a new study"
        )
    target = config.trials if grid is None else min(config.trials, len(grid))
    return study, storage, target


def _finished(study: optuna.Study) -> int:
    """Scored trials: complete, or failed because scoring raised (not stale ones)."""
    trials = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE, TrialState.FAIL))
    return sum(t.state == TrialState.COMPLETE or "error" in t.user_attrs for t in trials)


def _tell(study: optuna.Study, trial: optuna.Trial, outcome: TrialOutcome) -> None:
    """Store a trial's score (objective, terms, times) or its scoring error."""
    if isinstance(outcome.result, BaseException):
        trial.set_user_attr("error", f"{type(outcome.result).__name__}: {outcome.result}")
        study.tell(trial, state=TrialState.FAIL)
        return
    trial.set_user_attr("terms", outcome.result.terms)
    trial.set_user_attr("report_s", outcome.result.report_s)
    trial.set_user_attr("objective_s", outcome.result.objective_s)
    study.tell(trial, outcome.result.objective)


def tune(
    config: TuneConfig,
    suite: Sequence[SuiteEntry],
    *,
    report_function: ReportFunction,
    defaults: Mapping[str, float] | None = None,
) -> TuneResult:
    """Run (or resume) a tune until the study holds ``config.trials`` scored trials.

    Args:
        config: What to tune and how.
        suite: The recordings every trial replays (:func:`fogsim.tune.suite.load_suite`).
        report_function: ``(recording, overrides) -> report``, e.g.
            :func:`fogsim.run.runner.replay_report`. Must be picklable for workers/Ray.
        defaults: Values of the first trial; default
            :func:`fogsim.tune.space.parameter_defaults`.

    Returns:
        The best parameters; the result files are written to ``config.out_dir``.

    Raises:
        TuneError: invalid setup, a study made with other settings, or no trial scored.
        ParameterError: a range the parameter does not allow (with ``defaults`` None:
            :func:`fogsim.tune.space.check_ranges`).
    """
    if not suite:
        raise TuneError("the suite is empty")
    names = [p.name for p in config.params]
    if defaults is None:  # the library's parameters: their classes say which values are allowed
        check_ranges(config.params)
    first = dict(defaults) if defaults is not None else parameter_defaults(names)
    missing = [n for n in names if n not in first]
    if missing:
        raise TuneError(f"defaults lack values for {missing}")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    with warnings.catch_warnings():
        # Heartbeats are experimental in Optuna and meant for Study.optimize; we drive them.
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        warnings.filterwarnings("ignore", message="Heartbeat of storage", category=UserWarning)
        return _tune(config, suite, report_function, first)


def _tune(
    config: TuneConfig,
    suite: Sequence[SuiteEntry],
    report: ReportFunction,
    first: Mapping[str, float],
) -> TuneResult:
    study, storage, target = _open_study(config, suite, first)
    executor = make_executor(config, suite, report)
    heartbeat = TrialHeartbeat(storage, config.study_name, config.heartbeat_s)
    progress = None
    try:
        done = _finished(study)
        if config.progress:
            progress = tqdm(total=target, initial=min(done, target), desc="tune", unit="trial")
        failures: list[str] = []
        scored = 0
        while done < target:
            fail_dead_trials(study, storage, config.grace_s)
            asked: dict[int, optuna.Trial] = {}
            batch = []
            for _ in range(min(executor.slots, target - done)):
                trial = study.ask()
                heartbeat.add(trial.number)  # before the suggestions: see fogsim.tune.recovery
                asked[trial.number] = trial
                batch.append(
                    TrialRequest(trial.number, {p.name: p.suggest(trial) for p in config.params})
                )
            for outcome in executor.run(batch):
                _tell(study, asked[outcome.number], outcome)
                heartbeat.remove(outcome.number)
                if progress is not None:
                    progress.update(1)
                if isinstance(outcome.result, BaseException):
                    failures.append(
                        f"trial {outcome.number}: {type(outcome.result).__name__}: {outcome.result}"
                    )
                else:
                    scored += 1
            if not scored and len(failures) >= _ABORT_AFTER_FAILURES:
                raise TuneError(
                    f"the first {len(failures)} trials of this run all failed, stopping; "
                    f"first error: {failures[0]}"
                )
            done = _finished(study)
        _settle_other_runs(study, storage, config)
    finally:
        heartbeat.close()
        executor.close()
        if progress is not None:
            progress.close()
    return write_results(study, config)


def _settle_other_runs(
    study: optuna.Study, storage: optuna.storages.RDBStorage, config: TuneConfig
) -> None:
    """Fail the trials a killed run left RUNNING before this run ends (see recovery)."""
    others = len(study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)))
    if not others:
        return
    if config.progress:
        tqdm.write(
            f"waiting up to {config.grace_s + config.heartbeat_s} s for {others} running "
            "trial(s) of another run to go stale",
            file=sys.stderr,
        )
    fail_dead_trials_before_exit(study, storage, config)
