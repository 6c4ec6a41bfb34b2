"""What to tune and how: :class:`TuneConfig` and the search strategies."""

from __future__ import annotations

import ipaddress
import re
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path

from fogsim.errors import TuneError
from fogsim.tune.objective import ObjectiveWeights
from fogsim.tune.space import ParamSpec

STUDY_FILE = "tune.db"
"""The study's SQLite database in the output directory."""
RECORDINGS_DIR = "recordings"
"""The recording cache in the output directory (:func:`fogsim.tune.suite.load_suite`)."""

RAY_KEYWORDS = ("auto", "local")
"""``--ray`` values other than ``HOST:PORT``: the cluster of this machine, a private instance."""
RAY_REACH_TIMEOUT_S = 10.0
"""Seconds to open a TCP connection to a ``--ray HOST:PORT`` head before giving up. A handshake
on any network a Ray cluster runs on takes well under a second; 10 s leaves room for the SYN
retransmissions of a lossy link (after 1 s and 3 s). Without it an unreachable or firewalled
head makes Ray retry for many minutes."""
RAY_CONNECT_TIMEOUT_S = 60.0
"""Seconds for Ray to join a reachable cluster (``auto``, ``HOST:PORT``). A running head answers
in one or two seconds and Ray waits up to 20 s for one that is still starting; 60 s covers both
on a busy machine. Something else listening on the port, or a head that never answers, would
otherwise hang the tune for as long as Ray keeps retrying."""

_HOST_PORT = re.compile(
    r"(?:\[(?P<ipv6>[0-9A-Fa-f:.]+)\]|(?P<host>[A-Za-z0-9._-]+)):(?P<port>\d{1,5})"
)
"""``HOST:PORT`` with a host name, an IPv4 address or an IPv6 address in brackets."""


@dataclass(frozen=True)
class RayEndpoint:
    """The head of a Ray cluster named by ``--ray HOST:PORT``.

    Attributes:
        host: Host name or IP address (IPv6 without brackets).
        port: TCP port of the head's GCS, in 1..65535.
    """

    host: str
    port: int


def parse_ray_address(address: str) -> RayEndpoint | None:
    """Check a ``--ray`` value: ``auto``, ``local`` (None is returned) or ``HOST:PORT``.

    Raises:
        TuneError: anything else (the message names the value and what is allowed).
    """
    if address in RAY_KEYWORDS:
        return None
    match = _HOST_PORT.fullmatch(address)
    port = int(match["port"]) if match else 0
    if match and match["ipv6"] is not None:
        try:
            ipaddress.IPv6Address(match["ipv6"])
        except ValueError:
            match = None
    if match is None or not 1 <= port <= 65535:
        raise TuneError(
            f"--ray {address!r}: must be auto, local or HOST:PORT with a port in 1..65535 "
            "(e.g. 10.0.0.5:6379 or [::1]:6379)"
        )
    return RayEndpoint(match["ipv6"] or match["host"], port)


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
