"""What to tune and how: :class:`TuneConfig` and the search strategies."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

from fogsim.errors import TuneError
from fogsim.run.ray_cluster import RAY_CONNECT_TIMEOUT_S, parse_ray_address
from fogsim.tune.objective import ObjectiveWeights
from fogsim.tune.space import ParamSpec

STUDY_FILE = "tune.db"
"""The study's SQLite database in the output directory."""
RECORDINGS_DIR = "recordings"
"""The recording cache in the output directory (:func:`fogsim.tune.suite.load_suite`)."""


class SamplerKind(StrEnum):
    """Search strategies."""

    TPE = "tpe"
    RANDOM = "random"
    GRID = "grid"


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
        ray_address: Ray cluster address (``auto``, ``HOST:PORT``, ``local``; checked by
            :func:`parse_ray_address`); None = no Ray.
        weights: Objective weights.
        grid_points: Values per parameter for the grid sampler. 5: both ends, the middle and
            the quarter points; 25 points for two parameters, 125 for three.
        study_name: Name of the Optuna study in the database.
        top: Rows of the top-trials table (10: the best fit on one screen).
        heartbeat_s: Heartbeat interval of running trials [s]. 10 s: one small write per
            running trial every 10 s, negligible beside a trial's replay (seconds).
        grace_s: A running trial without heartbeat for this long is stale (its run died) [s].
            30 s: three missed heartbeats, so a busy machine does not fail live trials.
        ray_connect_s: Seconds to join a Ray cluster (:data:`RAY_CONNECT_TIMEOUT_S`).
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
    ray_connect_s: float = RAY_CONNECT_TIMEOUT_S
    progress: bool = True
    pictures: bool = True

    def __post_init__(self) -> None:
        if not self.params:
            raise TuneError("tune needs at least one --param name=lo:hi")
        names = [p.name for p in self.params]
        duplicates = sorted({n for n in names if names.count(n) > 1})
        if duplicates:
            raise TuneError(f"parameters given more than once: {duplicates}")
        if self.trials < 1:
            raise TuneError(f"trials must be >= 1, got {self.trials}")
        if self.workers < 1:
            raise TuneError(f"workers must be >= 1, got {self.workers}")
        if self.grid_points < 2:
            raise TuneError(f"grid_points must be >= 2, got {self.grid_points}")
        if self.top < 1:
            raise TuneError(f"top must be >= 1, got {self.top}")
        if self.heartbeat_s < 1 or self.grace_s <= self.heartbeat_s:
            raise TuneError(
                f"need heartbeat_s >= 1 and grace_s > heartbeat_s, got {self.heartbeat_s}, "
                f"{self.grace_s}"
            )
        if self.ray_address is not None:
            parse_ray_address(self.ray_address)
        if not self.ray_connect_s > 0:
            raise TuneError(f"ray_connect_s must be > 0 s, got {self.ray_connect_s}")
        object.__setattr__(self, "sampler", SamplerKind(self.sampler))
        object.__setattr__(self, "out_dir", Path(self.out_dir))

    @property
    def study_path(self) -> Path:
        """The SQLite database of the study."""
        return self.out_dir / STUDY_FILE
