"""Where trials are scored: in the driver, in a local process pool, or as Ray tasks.

An executor takes a batch of :class:`TrialRequest` and yields one :class:`TrialOutcome` per
request as it finishes (in any order). It never talks to the study: only the driver does.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from fogsim.errors import TuneError
from fogsim.tune.config import TuneConfig
from fogsim.tune.objective import (
    ObjectiveWeights,
    ReportFunction,
    SuiteEntry,
    TrialScore,
    score_parameters,
)


@dataclass(frozen=True)
class TrialRequest:
    """One trial to score.

    Attributes:
        number: The Optuna trial number.
        overrides: Parameter values by override key (``p_occ``, ``seg.<field>``).
    """

    number: int
    overrides: Mapping[str, float]


@dataclass(frozen=True)
class TrialOutcome:
    """A scored trial, or the error its scoring raised.

    Attributes:
        number: The Optuna trial number.
        result: The score, or the exception scoring raised.
    """

    number: int
    result: TrialScore | BaseException


class Executor(Protocol):
    """What the study loop needs of an executor."""

    slots: int
    """Trials scored at once; the driver asks this many trials per batch."""

    def run(self, batch: Sequence[TrialRequest]) -> Iterator[TrialOutcome]:
        """Score a batch; yields each outcome as it finishes."""
        ...

    def close(self) -> None:
        """Release workers and connections."""
        ...


class InlineExecutor:
    """Scores in the driver process, one trial at a time."""

    slots = 1

    def __init__(
        self, suite: Sequence[SuiteEntry], weights: ObjectiveWeights, report: ReportFunction
    ) -> None:
        self._suite = suite
        self._weights = weights
        self._report = report

    def run(self, batch: Sequence[TrialRequest]) -> Iterator[TrialOutcome]:
        """Score the trials one after the other."""
        for request in batch:
            result: TrialScore | BaseException
            try:
                result = score_parameters(
                    self._suite, request.overrides, self._weights, self._report
                )
            except Exception as exc:
                result = exc
            yield TrialOutcome(request.number, result)

    def close(self) -> None:
        """Nothing to release."""


_WORKER_STATE: tuple[Sequence[SuiteEntry], ObjectiveWeights, ReportFunction] | None = None
"""A pool worker's suite, weights and report function, set once by :func:`_pool_init`."""


def _pool_init(
    suite: Sequence[SuiteEntry], weights: ObjectiveWeights, report: ReportFunction
) -> None:
    global _WORKER_STATE
    _WORKER_STATE = (suite, weights, report)


def _pool_score(overrides: Mapping[str, float]) -> TrialScore:
    if _WORKER_STATE is None:
        raise TuneError("tune pool worker used before its initializer ran")
    suite, weights, report = _WORKER_STATE
    return score_parameters(suite, overrides, weights, report)


class PoolExecutor:
    """A local process pool; each worker receives the recordings once, at start."""

    def __init__(
        self,
        suite: Sequence[SuiteEntry],
        weights: ObjectiveWeights,
        report: ReportFunction,
        workers: int,
    ) -> None:
        method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
        self.slots = workers
        self._pool = concurrent.futures.ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context(method),
            initializer=_pool_init,
            initargs=(suite, weights, report),
        )

    def run(self, batch: Sequence[TrialRequest]) -> Iterator[TrialOutcome]:
        """Submit the whole batch; yield outcomes in the order they finish."""
        futures = {self._pool.submit(_pool_score, r.overrides): r.number for r in batch}
        for future in concurrent.futures.as_completed(futures):
            exc = future.exception()
            yield TrialOutcome(futures[future], exc if exc is not None else future.result())

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


class RayExecutor:
    """Ray tasks on a cluster; the recordings go to the object store once (``ray.put``)."""

    def __init__(
        self,
        suite: Sequence[SuiteEntry],
        weights: ObjectiveWeights,
        report: ReportFunction,
        address: str,
        workers: int,
    ) -> None:
        # Ray is an optional extra (``fogsim[ray]``): imported only when --ray asks for it.
        try:
            import ray
        except ImportError as exc:
            raise TuneError(
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

    def run(self, batch: Sequence[TrialRequest]) -> Iterator[TrialOutcome]:
        """Start one task per trial; yield outcomes in the order they finish."""
        ray = self._ray
        pending = {
            self._task.remote(self._suite_ref, r.overrides, self._weights, self._report): r.number
            for r in batch
        }
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            number = pending.pop(done[0])
            result: TrialScore | BaseException
            try:
                result = ray.get(done[0])
            except Exception as exc:
                result = exc
            yield TrialOutcome(number, result)

    def close(self) -> None:
        """Disconnect from Ray if this executor connected."""
        if self._owns_ray:
            self._ray.shutdown()


def make_executor(
    config: TuneConfig, suite: Sequence[SuiteEntry], report: ReportFunction
) -> Executor:
    """The executor ``config`` asks for: Ray if an address is given, else inline or a pool."""
    if config.ray_address is not None:
        return RayExecutor(suite, config.weights, report, config.ray_address, config.workers)
    if config.workers == 1:
        return InlineExecutor(suite, config.weights, report)
    return PoolExecutor(suite, config.weights, report, config.workers)
