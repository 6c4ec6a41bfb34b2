"""The tf tree of a bag (``/tf`` and ``/tf_static``), looked up at many stamps at once.

A ``geometry_msgs/TransformStamped`` with ``header.frame_id`` P and ``child_frame_id`` C gives
C's pose in P: the 4×4 transform ``T_P_C`` mapping points of C into P. Every frame has at most
one parent (tf's rule); a lookup of ``T_A_B`` walks from both frames up to their lowest common
ancestor and multiplies the edges' transforms.

Time: a static edge holds at every stamp. A moving edge is interpolated between its samples
around the stamp (translation linearly, rotation by spherical linear interpolation, both exact
for constant velocity and constant turn rate); before its first sample or after its last, the
nearest sample is held. Either way the nearest sample must lie within the tolerance, else the
pose is unknown there and :class:`BagError` names the edge, the stamp and the gap. Frame names
are compared without a leading ``/`` (ROS 1's ``/odom`` is ``odom``), as tf2 does.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from fogsim.bags.topics import BagError

SLERP_LINEAR_BELOW = 1e-6
"""Angle [rad] between two samples' rotations below which they are interpolated linearly (and
normalised): slerp's weights divide by sin(angle), which loses all precision near 0, while the
linear blend is exact to ~angle² = 1e-12 there."""


@dataclass(frozen=True)
class TransformSample:
    """One transform of a tf message.

    Attributes:
        stamp_ns: ``header.stamp`` [ns].
        parent: ``header.frame_id`` (leading ``/`` removed).
        child: ``child_frame_id`` (leading ``/`` removed).
        translation_m: (x, y, z) of the child's origin in the parent [m].
        rotation_xyzw: The child's orientation in the parent, a quaternion (x, y, z, w).
    """

    stamp_ns: int
    parent: str
    child: str
    translation_m: tuple[float, float, float]
    rotation_xyzw: tuple[float, float, float, float]


@dataclass(frozen=True)
class _Edge:
    """All samples of one parent → child edge, by increasing stamp (one sample if static)."""

    parent: str
    child: str
    static: bool
    stamps_ns: NDArray[np.int64]
    translations_m: NDArray[np.float64]
    rotations_xyzw: NDArray[np.float64]


def frame_name(name: str) -> str:
    """A tf frame name as tf2 compares it (without a leading ``/``)."""
    return name.lstrip("/")


def quaternion_to_matrix(rotations_xyzw: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3, 3) rotation matrices of (N, 4) quaternions (x, y, z, w), normalised first."""
    q = rotations_xyzw / np.linalg.norm(rotations_xyzw, axis=-1, keepdims=True)
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def _slerp(
    q0: NDArray[np.float64], q1: NDArray[np.float64], u: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(N, 4) spherical linear interpolation from ``q0`` to ``q1`` at fractions ``u`` (N,)."""
    q0 = q0 / np.linalg.norm(q0, axis=-1, keepdims=True)
    q1 = q1 / np.linalg.norm(q1, axis=-1, keepdims=True)
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where(dot[:, None] < 0.0, -q1, q1)  # the shorter way round
    dot = np.clip(np.abs(dot), 0.0, 1.0)
    angle = np.arccos(dot)
    small = angle < SLERP_LINEAR_BELOW
    sin = np.where(small, 1.0, np.sin(angle))
    w0 = np.where(small, 1.0 - u, np.sin((1.0 - u) * angle) / sin)
    w1 = np.where(small, u, np.sin(u * angle) / sin)
    q = w0[:, None] * q0 + w1[:, None] * q1
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _transforms(
    translations_m: NDArray[np.float64], rotations_xyzw: NDArray[np.float64]
) -> NDArray[np.float64]:
    """(N, 4, 4) homogeneous transforms."""
    out = np.zeros((len(translations_m), 4, 4))
    out[:, :3, :3] = quaternion_to_matrix(rotations_xyzw)
    out[:, :3, 3] = translations_m
    out[:, 3, 3] = 1.0
    return out


def last_per_stamp(stamps_ns: NDArray[np.int64]) -> NDArray[np.intp]:
    """Indices of the samples to keep, by increasing stamp: a stamp given twice keeps its last."""
    order = np.argsort(stamps_ns, kind="stable")
    return order[np.append(stamps_ns[order][1:] != stamps_ns[order][:-1], True)]


def _build_edge(samples: Sequence[TransformSample], static: bool) -> _Edge:
    """One edge from its samples in bag order; a stamp given twice keeps its last sample."""
    stamps = np.array([s.stamp_ns for s in samples], dtype=np.int64)
    translations = np.array([s.translation_m for s in samples], dtype=np.float64)
    rotations = np.array([s.rotation_xyzw for s in samples], dtype=np.float64)
    # A static transform holds always: republished, the last one counts.
    keep = np.array([len(samples) - 1]) if static else last_per_stamp(stamps)
    bad = ~np.all(np.isfinite(translations[keep]), axis=1) | ~np.all(
        np.isfinite(rotations[keep]), axis=1
    )
    bad |= ~(np.linalg.norm(rotations[keep], axis=1) > 0.5)
    if bad.any():
        i = int(keep[np.flatnonzero(bad)[0]])
        raise BagError(
            f"tf {samples[i].parent} -> {samples[i].child} at stamp {stamps[i]} ns: translation "
            f"{samples[i].translation_m} or rotation {samples[i].rotation_xyzw} is not a finite "
            "transform with a unit quaternion"
        )
    return _Edge(
        samples[0].parent,
        samples[0].child,
        static,
        stamps[keep],
        translations[keep],
        rotations[keep],
    )


def bracket(
    samples_ns: NDArray[np.int64], stamps_ns: NDArray[np.int64], max_dt_ns: int, what: str
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
    """The samples around each stamp and the fraction between them (see the module doc).

    Args:
        samples_ns: (M,) sample stamps, strictly increasing.
        stamps_ns: (N,) stamps to interpolate at.
        max_dt_ns: The nearest sample must be at most this far from each stamp.
        what: Names the samples in errors (``tf odom -> base_footprint``).

    Returns:
        (lo, hi, u): indices of the samples before and after each stamp (equal before the first
        or after the last sample) and the fraction in [0, 1] from ``lo`` to ``hi``.

    Raises:
        BagError: A stamp farther than ``max_dt_ns`` from every sample (naming the stamp).
    """
    after = np.searchsorted(samples_ns, stamps_ns, side="left")  # first sample >= stamp
    lo = np.clip(after - 1, 0, len(samples_ns) - 1)
    hi = np.clip(after, 0, len(samples_ns) - 1)
    gap_ns = np.minimum(np.abs(stamps_ns - samples_ns[lo]), np.abs(samples_ns[hi] - stamps_ns))
    late = np.flatnonzero(gap_ns > max_dt_ns)
    if late.size:
        i = int(late[0])
        raise BagError(
            f"{what}: no sample within {max_dt_ns / 1e6:g} ms of stamp {int(stamps_ns[i])} ns "
            f"(the nearest is {gap_ns[i] / 1e6:.6g} ms away; samples from {int(samples_ns[0])} "
            f"to {int(samples_ns[-1])} ns); raise --max-dt-ms or cut the bag to where they are "
            "published"
        )
    span = (samples_ns[hi] - samples_ns[lo]).astype(np.float64)
    u = np.where(span > 0, (stamps_ns - samples_ns[lo]) / np.where(span > 0, span, 1.0), 0.0)
    return lo, hi, np.clip(u, 0.0, 1.0)


class TfTree:
    """The frames of a bag's ``/tf`` and ``/tf_static`` and their transforms over time."""

    def __init__(
        self, moving: Iterable[TransformSample], static: Iterable[TransformSample]
    ) -> None:
        """Build the tree.

        Args:
            moving: Samples of ``/tf``, in bag order.
            static: Samples of ``/tf_static``, in bag order.

        Raises:
            BagError: A frame with two parents, an edge both static and moving, a transform
                that is not finite.
        """
        grouped: dict[tuple[str, bool], list[TransformSample]] = {}
        for is_static, samples in ((False, moving), (True, static)):
            for sample in samples:
                grouped.setdefault((sample.child, is_static), []).append(sample)
        self._edges: dict[str, _Edge] = {}
        for (child, is_static), samples in grouped.items():
            parents = sorted({s.parent for s in samples})
            if len(parents) > 1:
                raise BagError(
                    f"tf frame {child!r} has several parents {parents}; tf allows one per frame"
                )
            if child in self._edges:
                raise BagError(
                    f"tf frame {child!r} is published on both /tf and /tf_static; it must be "
                    "either moving or static"
                )
            self._edges[child] = _build_edge(samples, is_static)
        for edge in self._edges.values():
            self._path_to_root(edge.child)  # refuses a cycle now

    @property
    def frames(self) -> list[str]:
        """Every frame named in the tree, sorted."""
        names = set(self._edges) | {e.parent for e in self._edges.values()}
        return sorted(names)

    def _path_to_root(self, frame: str) -> list[str]:
        """``frame``, its parent, its parent's parent, ... up to the root."""
        path = [frame]
        while path[-1] in self._edges:
            parent = self._edges[path[-1]].parent
            if parent in path:
                raise BagError(f"tf frames {path} form a cycle through {parent!r}")
            path.append(parent)
        return path

    def _edge_at(self, edge: _Edge, stamps_ns: NDArray[np.int64], max_dt_ns: int) -> NDArray:
        """(N, 4, 4) ``T_parent_child`` of one edge at the stamps."""
        if edge.static:
            return np.broadcast_to(
                _transforms(edge.translations_m, edge.rotations_xyzw), (len(stamps_ns), 4, 4)
            )
        lo, hi, u = bracket(
            edge.stamps_ns, stamps_ns, max_dt_ns, f"tf {edge.parent} -> {edge.child}"
        )
        translations = (1.0 - u[:, None]) * edge.translations_m[lo] + u[
            :, None
        ] * edge.translations_m[hi]
        rotations = _slerp(edge.rotations_xyzw[lo], edge.rotations_xyzw[hi], u)
        return _transforms(translations, rotations)

    def _down_from(
        self, ancestor: str, path: list[str], stamps_ns: NDArray[np.int64], max_dt_ns: int
    ) -> NDArray[np.float64]:
        """(N, 4, 4) ``T_ancestor_frame`` along ``path`` (frame first, up to ``ancestor``)."""
        result = np.broadcast_to(np.eye(4), (len(stamps_ns), 4, 4))
        for frame in path[: path.index(ancestor)]:
            result = self._edge_at(self._edges[frame], stamps_ns, max_dt_ns) @ result
        return np.array(result)

    def lookup(
        self, target: str, source: str, stamps_ns: NDArray[np.int64], max_dt_ns: int
    ) -> NDArray[np.float64]:
        """(N, 4, 4) ``T_target_source`` (points of ``source`` into ``target``) at each stamp.

        Raises:
            BagError: A frame not in the tree, frames not connected, or a moving edge without
                a sample within ``max_dt_ns`` of a stamp.
        """
        target, source = frame_name(target), frame_name(source)
        known = self.frames
        for frame in (target, source):
            if frame not in known:
                raise BagError(
                    f"tf frame {frame!r} is not in /tf or /tf_static; the bag's frames: {known}"
                )
        source_path = self._path_to_root(source)
        target_path = self._path_to_root(target)
        common = [frame for frame in source_path if frame in target_path]
        if not common:
            raise BagError(
                f"tf frames {target!r} and {source!r} are not connected (their roots are "
                f"{target_path[-1]!r} and {source_path[-1]!r})"
            )
        stamps = np.asarray(stamps_ns, dtype=np.int64)
        ancestor_to_source = self._down_from(common[0], source_path, stamps, max_dt_ns)
        ancestor_to_target = self._down_from(common[0], target_path, stamps, max_dt_ns)
        return rigid_inverse(ancestor_to_target) @ ancestor_to_source


def rigid_inverse(transforms: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 4, 4) inverses of rigid transforms: ``[Rᵀ, -Rᵀ t]`` (a general inverse rounds)."""
    rotation_t = np.swapaxes(transforms[:, :3, :3], 1, 2)
    out = np.zeros_like(transforms)
    out[:, :3, :3] = rotation_t
    out[:, :3, 3] = -np.einsum("nij,nj->ni", rotation_t, transforms[:, :3, 3])
    out[:, 3, 3] = 1.0
    return out
