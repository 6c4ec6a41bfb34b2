"""Where trials are scored: in the driver, in a local process pool, or as Ray tasks.

An executor takes a batch of :class:`TrialRequest` and yields one :class:`TrialOutcome` per
request as it finishes (in any order). It never talks to the study: only the driver does.
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from fogsim.errors import TuneError
from fogsim.run.orphans import watch_driver
from fogsim.run.ray_cluster import (
    RAY_CONNECT_TIMEOUT_S,
    TASK_RETRIES,
    RayCluster,
    check_ray_address,
)
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
    driver_pid: int, suite: Sequence[SuiteEntry], weights: ObjectiveWeights, report: ReportFunction
) -> None:
    """Set up a pool worker: its state, and a thread ending it when the driver dies.

    :func:`fogsim.run.orphans.watch_driver`: a killed driver's workers end within
    :data:`~fogsim.run.orphans.PARENT_POLL_S` instead of finishing trials nobody will read.
    """
    global _WORKER_STATE
    _WORKER_STATE = (suite, weights, report)
    watch_driver(driver_pid)


def _pool_score(overrides: Mapping[str, float]) -> TrialScore:
    if _WORKER_STATE is None:
        raise TuneError("tune pool worker used before its initializer ran")
    suite, weights, report = _WORKER_STATE
    return score_parameters(suite, overrides, weights, report)


class PoolExecutor:
    """A local process pool; each worker receives the recordings once, at start.

    Workers end themselves within :data:`~fogsim.run.orphans.PARENT_POLL_S` when the driver
    is killed (see :func:`_pool_init`), so a killed tune leaves no process behind.
    """

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
            initargs=(os.getpid(), suite, weights, report),
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
    """Ray tasks on a cluster; the recordings go to the object store once (``ray.put``).

    The connection (bounded joining, ``local`` on 127.0.0.1 only) is
    :class:`fogsim.run.ray_cluster.RayCluster`, shared with run, suite and compare.

    Args:
        suite: The recordings every trial replays.
        weights: Objective weights.
        report: ``(recording, overrides) -> report``.
        address: ``auto``, ``local`` or ``HOST:PORT``
            (:func:`~fogsim.run.ray_cluster.parse_ray_address`).
        workers: Trials at once; 1 = as many as the cluster has CPUs.
        connect_s: Seconds to join the cluster.

    Raises:
        FogsimError: an invalid or unreachable address, Ray not installed, or a ``local``
            instance that could not be kept on the loopback address.
    """

    def __init__(
        self,
        suite: Sequence[SuiteEntry],
        weights: ObjectiveWeights,
        report: ReportFunction,
        address: str,
        workers: int,
        connect_s: float = RAY_CONNECT_TIMEOUT_S,
    ) -> None:
        check_ray_address(address)
        self._cluster = RayCluster(address, connect_s)
        self._ray = self._cluster.ray
        self._suite_ref = self._cluster.put(list(suite))
        self._weights = weights
        self._report = report
        self._task = self._ray.remote(num_cpus=1, max_retries=TASK_RETRIES)(_ray_score)
        self.slots = workers if workers > 1 else self._cluster.cpus()

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
        self._cluster.close()


def make_executor(
    config: TuneConfig, suite: Sequence[SuiteEntry], report: ReportFunction
) -> Executor:
    """The executor ``config`` asks for: Ray if an address is given, else inline or a pool."""
    if config.ray_address is not None:
        return RayExecutor(
            suite,
            config.weights,
            report,
            config.ray_address,
            config.workers,
            config.ray_connect_s,
        )
    if config.workers == 1:
        return InlineExecutor(suite, config.weights, report)
    return PoolExecutor(suite, config.weights, report, config.workers)
