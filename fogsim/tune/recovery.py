"""Surviving killed runs: heartbeats of running trials, and the retry of a dead run's trials.

Optuna's heartbeat does the work: :class:`optuna.storages.RDBStorage` with
``heartbeat_interval``, ``grace_period`` and
:class:`~optuna.storages.RetryHeartbeatStaleTrialCallback`, and
:func:`optuna.storages.fail_stale_trials`. The driver records the heartbeats itself
(:class:`TrialHeartbeat`), because it runs trials through ask and tell, not ``Study.optimize``.

One gap is closed here: a run killed between creating a trial (``study.ask``) and its first
heartbeat leaves a RUNNING trial that has no heartbeat, which Optuna never calls stale. The
driver suggests a trial's parameters right after its first heartbeat, so a RUNNING trial without
parameters that started more than ``grace_s`` ago belongs to a dead run:
:func:`fail_dead_trials` fails and retries it as Optuna would a stale one. (Not covered: a
retried trial, which carries its parameters from the start, killed in that same gap stays
RUNNING; it is not counted as scored, so the trial count is still reached.)

A second gap: a run restarted less than ``grace_s`` after one was killed finds the dead run's
trials not yet stale, and may reach its trial count before they are. Before it ends, a run
therefore waits for the trials it did not start to go stale and fails them
(:func:`fail_dead_trials_before_exit`), so none stays RUNNING after it; trials of a live run
keep beating and are left alone.
"""

from __future__ import annotations

import datetime
import threading
import time

import optuna
from optuna.exceptions import UpdateFinishedTrialError
from optuna.trial import TrialState

from fogsim.tune.config import TuneConfig

SETTLE_POLL_S = 1.0
"""Seconds between two looks for stale trials while a run waits to end (Optuna stores
heartbeats to the second)."""


def open_storage(config: TuneConfig) -> optuna.storages.RDBStorage:
    """The study's SQLite storage in ``config.out_dir``, with heartbeats and stale-trial retry.

    A 60 s SQLite busy timeout lets two runs on one database wait for each other's writes. A
    stale trial is failed and its parameters queued again (the copy marked ``failed_trial``).
    """
    config.out_dir.mkdir(parents=True, exist_ok=True)
    return optuna.storages.RDBStorage(
        f"sqlite:///{config.study_path.resolve()}",
        engine_kwargs={"connect_args": {"timeout": 60}},
        heartbeat_interval=config.heartbeat_s,
        grace_period=config.grace_s,
        heartbeat_stale_trial_callback=optuna.storages.RetryHeartbeatStaleTrialCallback(),
    )


class TrialHeartbeat:
    """A thread recording the heartbeats of the driver's running trials in the study database.

    Args:
        storage: The study's storage (:func:`open_storage`).
        study_name: The study whose trials beat.
        interval_s: Seconds between two heartbeats of a running trial.
    """

    def __init__(
        self, storage: optuna.storages.RDBStorage, study_name: str, interval_s: float
    ) -> None:
        self._storage = storage
        self._study_id = storage.get_study_id_from_name(study_name)
        self._interval_s = interval_s
        self._trial_ids: dict[int, int] = {}  # trial number -> storage trial id
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="tune-heartbeat", daemon=True)
        self._thread.start()

    def add(self, number: int) -> None:
        """Record a heartbeat of trial ``number`` now, and then every ``interval_s``."""
        trial_id = self._storage.get_trial_id_from_study_id_trial_number(self._study_id, number)
        with self._lock:
            self._trial_ids[number] = trial_id
        self._storage.record_heartbeat(trial_id)

    def remove(self, number: int) -> None:
        """Stop the heartbeats of trial ``number`` (it is finished)."""
        with self._lock:
            self._trial_ids.pop(number, None)

    def _loop(self) -> None:
        while not self._stop.wait(self._interval_s):
            with self._lock:
                trial_ids = sorted(self._trial_ids.values())
            for trial_id in trial_ids:
                self._storage.record_heartbeat(trial_id)

    def close(self) -> None:
        """Stop the thread."""
        self._stop.set()
        self._thread.join()


def fail_dead_trials(
    study: optuna.Study, storage: optuna.storages.RDBStorage, grace_s: float
) -> None:
    """Fail the trials of dead runs and queue their parameters again (see the module doc).

    Args:
        study: The study.
        storage: Its storage (:func:`open_storage`), whose stale-trial callback retries.
        grace_s: A trial older than this without heartbeat (or without a fresh one) is dead [s].
    """
    retry = storage.get_heartbeat_stale_trial_callback()
    optuna.storages.fail_stale_trials(study)
    now = datetime.datetime.now()  # Optuna stamps datetime_start with local naive time
    for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        started = trial.datetime_start
        if trial.params or started is None or (now - started).total_seconds() <= grace_s:
            continue
        try:
            failed = study.tell(trial.number, state=TrialState.FAIL)
        except (ValueError, UpdateFinishedTrialError):
            continue  # another run finished it first ("Cannot tell a FAIL trial")
        if retry is not None:
            retry(study, failed)


def fail_dead_trials_before_exit(
    study: optuna.Study, storage: optuna.storages.RDBStorage, config: TuneConfig
) -> int:
    """Wait for the RUNNING trials of killed runs to go stale, failing and retrying them.

    Called when a run has told all of its own trials, so every RUNNING trial belongs to another
    run. A killed run's last heartbeat is older than now, so its trials are stale within
    ``grace_s`` (plus one heartbeat interval for Optuna's whole-second timestamps): that bounds
    the wait. Their parameters are queued again (WAITING) for the next run.

    Args:
        study: The study.
        storage: Its storage (:func:`open_storage`).
        config: The run's settings (``grace_s``, ``heartbeat_s``).

    Returns:
        Trials still RUNNING at the end: those of runs that are alive (they keep beating).
    """
    deadline = time.monotonic() + config.grace_s + config.heartbeat_s
    while True:
        fail_dead_trials(study, storage, config.grace_s)
        running = study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
        if not running or time.monotonic() >= deadline:
            return len(running)
        time.sleep(SETTLE_POLL_S)
