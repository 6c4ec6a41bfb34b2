"""Jobs as Ray tasks on an existing cluster: the ``--ray ADDRESS`` of run, suite, compare and tune.

:func:`parse_ray_address` and :func:`check_ray_address` refuse a bad ``--ray`` value or an
unreachable head by name before any work; :class:`RayCluster` joins the cluster (or starts a
private instance on the loopback address), puts large inputs into the object store once
(:meth:`RayCluster.put`) and runs a function over jobs as tasks (:meth:`RayCluster.map`),
results in the jobs' order. Ray is an optional extra (``fogsim[ray]``), imported only here and
only when ``--ray`` asks for it.
"""

from __future__ import annotations

import ipaddress
import os
import re
import socket
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType, TracebackType
from typing import Any, TypeVar

from fogsim.errors import FogsimError

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
otherwise hang the command for as long as Ray keeps retrying."""
RAY_ADDRESS_HELP = (
    "run the jobs as tasks on a Ray cluster: auto (this machine's), HOST:PORT (a head), or "
    "local (a private instance on 127.0.0.1); needs fogsim[ray]"
)
"""The ``--ray`` option's help text, the same in every command."""

LOOPBACK = "127.0.0.1"
"""The only address a ``--ray local`` instance listens on."""
RAY_CLUSTER_SWITCH = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
"""Ray's switch for multi-node clusters; ``--ray local`` turns it off (see :class:`RayCluster`)."""
TASK_RETRIES = 2
"""Times Ray restarts a task whose worker process died (not one that raised): a node lost to
the cluster's scaling or memory pressure; jobs are deterministic, so a rerun gives the same
result."""

_HOST_PORT = re.compile(
    r"(?:\[(?P<ipv6>[0-9A-Fa-f:.]+)\]|(?P<host>[A-Za-z0-9._-]+)):(?P<port>\d{1,5})"
)
"""``HOST:PORT`` with a host name, an IPv4 address or an IPv6 address in brackets."""

Result = TypeVar("Result")


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
        FogsimError: anything else (the message names the value and what is allowed).
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
        raise FogsimError(
            f"--ray {address!r}: must be auto, local or HOST:PORT with a port in 1..65535 "
            "(e.g. 10.0.0.5:6379 or [::1]:6379)"
        )
    return RayEndpoint(match["ipv6"] or match["host"], port)


def check_ray_address(address: str) -> None:
    """Refuse an invalid ``--ray`` value, or a ``HOST:PORT`` head that is not reachable.

    The head must accept a TCP connection within :data:`RAY_REACH_TIMEOUT_S` (``auto`` and
    ``local`` are only checked when Ray joins them).

    Raises:
        FogsimError: naming the address, what is allowed, or the timeout and the socket's error.
    """
    endpoint = parse_ray_address(address)
    if endpoint is None:
        return
    try:
        with socket.create_connection((endpoint.host, endpoint.port), timeout=RAY_REACH_TIMEOUT_S):
            pass
    except OSError as exc:
        raise FogsimError(
            f"--ray {address}: cannot reach a Ray head there within {RAY_REACH_TIMEOUT_S:g} s "
            f"({exc}); start one with `ray start --head --port={endpoint.port}` or check the "
            "address"
        ) from None


class RayCluster:
    """A connection to a Ray cluster for one command; closed by :meth:`close` or ``with``.

    Joining is bounded: Ray must join within ``connect_s``, else :class:`FogsimError` names the
    address. ``local`` starts a private instance whose servers (GCS, raylet, workers, agents)
    all listen on 127.0.0.1 only. If Ray is already initialised in this process (a test's or a
    notebook's ``ray.init``) that connection is used and left open.

    Args:
        address: ``auto``, ``local`` or ``HOST:PORT``, checked by :func:`check_ray_address`
            before any work (the caller does it, so it fails before its output is touched).
        connect_s: Seconds to join the cluster.

    Raises:
        FogsimError: Ray not installed, a cluster that does not join in time, or a ``local``
            instance that could not be kept on the loopback address.
    """

    def __init__(self, address: str, connect_s: float = RAY_CONNECT_TIMEOUT_S) -> None:
        if address == "local":
            # Read by Ray when it is imported (and by the processes it starts): off, Ray's node
            # address is the loopback one, and every server it starts listens there only. The
            # name says Windows and macOS, where it is off by default; Ray reads it everywhere.
            os.environ[RAY_CLUSTER_SWITCH] = "0"
        try:
            import ray
        except ImportError as exc:
            raise FogsimError(
                f"--ray {address} needs the optional dependency ray: pip install 'fogsim[ray]'"
            ) from exc
        self.ray: ModuleType = ray
        self._owns_ray = not ray.is_initialized()
        if self._owns_ray:
            if address == "local":
                _start_local_ray(ray)
            else:
                _join_ray(ray, address, connect_s)

    def cpus(self) -> int:
        """The cluster's CPUs (at least 1)."""
        return max(1, int(self.ray.cluster_resources().get("CPU", 1)))

    def put(self, value: object) -> Any:
        """``value`` into the object store once; pass the returned reference to tasks."""
        return self.ray.put(value)

    def map(
        self, function: Callable[..., Result], arguments: Sequence[tuple[Any, ...]]
    ) -> list[Result]:
        """``function(*args)`` for every ``args`` as a Ray task (1 CPU each), results in order.

        References from :meth:`put` among the arguments reach the task as their values. A task
        that raised re-raises its exception here (the original one, so a
        :class:`FogsimError` keeps its message and exit code).
        """
        task = self.ray.remote(num_cpus=1, max_retries=TASK_RETRIES)(function)
        pending = [task.remote(*args) for args in arguments]
        try:
            return [self.ray.get(ref) for ref in pending]
        except self.ray.exceptions.RayTaskError as exc:
            if exc.cause is not None:
                raise exc.cause from None
            raise FogsimError(f"a Ray task of {function.__name__} failed: {exc}") from None

    def close(self) -> None:
        """Disconnect from Ray if this connection joined it."""
        if self._owns_ray:
            self.ray.shutdown()
            self._owns_ray = False

    def __enter__(self) -> RayCluster:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


def _start_local_ray(ray: ModuleType) -> None:
    """Start a private Ray instance listening on 127.0.0.1 only (no dashboard)."""
    ray.init(include_dashboard=False, dashboard_host=LOOPBACK, log_to_driver=False)
    node_address = ray.util.get_node_ip_address()
    if node_address != LOOPBACK:
        ray.shutdown()
        raise FogsimError(
            f"--ray local: Ray listens on {node_address}, not {LOOPBACK}: it was imported "
            f"before fogsim could set {RAY_CLUSTER_SWITCH}=0; set it in the environment"
        )


def _join_ray(ray: ModuleType, address: str, connect_s: float) -> None:
    """``ray.init(address=...)``, given up after ``connect_s`` seconds.

    Ray retries an unresponsive head for many minutes; the join runs in a daemon thread so the
    wait can be bounded (a join given up on keeps trying in the background until the process
    exits). Ray then logs that it set no SIGTERM handler (it does so only in the main thread).

    Raises:
        FogsimError: Ray refused the address or did not join in time.
    """
    failure: list[Exception] = []

    def join() -> None:
        try:
            ray.init(address=address, log_to_driver=False)
        except Exception as exc:  # reported by the caller's thread
            failure.append(exc)

    thread = threading.Thread(target=join, name="ray-join", daemon=True)
    thread.start()
    thread.join(connect_s)
    if failure:
        raise FogsimError(f"--ray {address}: Ray cannot join: {failure[0]}") from failure[0]
    if thread.is_alive():
        raise FogsimError(
            f"--ray {address}: no Ray cluster answered within {connect_s:g} s "
            "(fogsim.run.ray_cluster.RAY_CONNECT_TIMEOUT_S); is `ray start --head` running there?"
        )
