"""MuJoCo models from MJCF (retried on a spurious parse error), meshes and height fields as files.

MuJoCo reads every numeric attribute with ``mujoco::user::StringToVector`` (``src/user/
user_util.cc``): it sets ``errno = 0``, reserves the vector (an allocation), parses with
``strtod``, then calls ``shrink_to_fit`` (another allocation and a free); the caller
(``mjXUtil::ReadAttrVec``, ``src/xml/xml_util.cc``) then reads ``errno``: ``ERANGE`` is "number
is too large", ``EINVAL`` "bad format", and any other non-zero value "unknown error in attribute
'…'". An allocation may leave ``errno`` set although it succeeded (C and POSIX allow it; glibc's
malloc can when a thread's arena has to grow), and the attribute — the same text that parses
everywhere else — is then rejected. The suite met it twice in one session (``untextured``,
two of eight seeds, ``XML Error: unknown error in attribute 'vertex'``, the scene compiled on a
worker's simulation thread); the same scene, seed and code compiled at once when run again.
Retrying did not cure it: in a later session a suite run (``untextured`` seed 3, 4–8 processes
on 2 cores) failed on all three attempts.

The cure at the cause: the attributes that needed large allocations were the meshes' ``vertex``
and ``face`` (the robot's, up to 650 000 characters), ``texcoord`` and the height fields'
``elevation`` (up to 71 000 characters). They are now written as MuJoCo's binary files instead
(:func:`mesh_file`, :func:`hfield_file`; the robot's beside its MJCF, :mod:`fogsim.robot.mjcf`,
the scene's as in-memory assets, :mod:`fogsim.sim.scene`), which MuJoCo copies in without a
number parser (no ``errno`` is read); the compiled model is the same to the bit
(``tests/test_scene.py``). What text remains is short (poses, sizes, colours; the longest, an
exported keyframe's ``qpos``, about 520 characters), so its vectors are small allocations;
whether these can still leave ``errno`` set is not known, so a parse that fails with exactly
that message is still tried again, up to `PARSE_ATTEMPTS` times in all: the text is the same, so
a real fault in it fails every time (and MuJoCo reports real faults in numbers as "bad format"
or "too large", which are raised at once).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "PARSE_ATTEMPTS",
    "SPURIOUS_PARSE_ERROR",
    "hfield_file",
    "mesh_file",
    "model_from_xml_path",
    "model_from_xml_string",
    "retry_spurious_parse_error",
]

SPURIOUS_PARSE_ERROR = "unknown error in attribute"
"""The part of MuJoCo's message for a numeric attribute whose parse left a stray ``errno``."""

PARSE_ATTEMPTS = 3
"""Parses of one MJCF before its error is raised. Chosen when the failure was met in 2 of
hundreds of compiles, on the long mesh attributes (a third attempt costs nothing on the good
path); those are files now, and no failure has been seen on the short attributes that remain."""


def retry_spurious_parse_error(load: Callable[[], mujoco.MjModel]) -> mujoco.MjModel:
    """``load()``, called again while it fails with MuJoCo's spurious parse error.

    Args:
        load: Parses and compiles one MJCF (the same text every call).

    Returns:
        The compiled model of the first attempt that succeeds.

    Raises:
        ValueError: MuJoCo's error: at once for any other error, after `PARSE_ATTEMPTS`
            attempts for the spurious one.
    """
    for _ in range(PARSE_ATTEMPTS - 1):
        try:
            return load()
        except ValueError as exc:
            if SPURIOUS_PARSE_ERROR not in str(exc):
                raise
    return load()  # the last attempt: any error is raised


def model_from_xml_string(xml: str, assets: Mapping[str, bytes] | None = None) -> mujoco.MjModel:
    """``mujoco.MjModel.from_xml_string(xml, assets)``, retried on the spurious parse error.

    Args:
        xml: The MJCF text.
        assets: File name → contents of the files it refers to (meshes, textures), or None.
    """
    return retry_spurious_parse_error(
        lambda: mujoco.MjModel.from_xml_string(xml, None if assets is None else dict(assets))
    )


def model_from_xml_path(path: str | Path) -> mujoco.MjModel:
    """``mujoco.MjModel.from_xml_path(path)``, retried on the spurious parse error."""
    return retry_spurious_parse_error(lambda: mujoco.MjModel.from_xml_path(str(path)))


# ---------------------------------------------------------------------- binary asset files


def mesh_file(vertices: ArrayLike, faces: ArrayLike, texcoords: ArrayLike | None = None) -> bytes:
    """A mesh as MuJoCo's binary ``.msh`` file (a ``<mesh file="….msh">`` asset).

    The format (MuJoCo's documentation of ``mesh/file``; ``src/user/user_mesh.cc``): four
    little-endian int32 counts (vertices, normals, texture coordinates, faces), then the
    vertices as float32 (x, y, z), the normals (none here: MuJoCo computes them as for the
    ``vertex`` attribute), the texture coordinates as float32 (u, v) and the faces as int32
    vertex indices. MuJoCo keeps vertices and texture coordinates as float32 whichever way they
    come, so rounding them here compiles to the same ``mesh_vert`` and ``mesh_texcoord`` as
    the same doubles written as text (``tests/test_mj_xml.py``, ``tests/test_scene.py``).

    Args:
        vertices: (N, 3) vertices [m].
        faces: (M, 3) vertex indices of the triangles (counter-clockwise seen from outside).
        texcoords: (N, 2) texture coordinates of the vertices, or None for none.

    Returns:
        The file's bytes.
    """
    vertex = np.ascontiguousarray(vertices, dtype="<f4").reshape(-1, 3)
    face = np.ascontiguousarray(faces, dtype="<i4").reshape(-1, 3)
    texcoord = np.ascontiguousarray(
        np.empty((0, 2)) if texcoords is None else texcoords, dtype="<f4"
    ).reshape(-1, 2)
    counts = np.array([len(vertex), 0, len(texcoord), len(face)], dtype="<i4")
    return b"".join(a.tobytes() for a in (counts, vertex, texcoord, face))


def hfield_file(elevation: ArrayLike) -> bytes:
    """A height field as MuJoCo's custom binary file (a ``<hfield file="….bin">`` asset).

    The format (MuJoCo's documentation of ``hfield/file``): little-endian int32 ``nrow`` and
    ``ncol``, then ``nrow × ncol`` float32 heights row by row. MuJoCo reverses the rows of
    the ``elevation`` attribute but not of a file, so the rows are written in reverse here:
    ``elevation`` is in the attribute's order and compiles to the same ``hfield_data``.

    Args:
        elevation: (nrow, ncol) heights in the order of MuJoCo's ``elevation`` attribute: row
            0 at the height field's +y edge, column 0 at its -x edge (MuJoCo scales them to
            [0, 1] either way).

    Returns:
        The file's bytes.
    """
    heights = np.ascontiguousarray(np.asarray(elevation)[::-1], dtype="<f4")
    if heights.ndim != 2:
        raise ValueError(f"elevation must be (nrow, ncol), got shape {heights.shape}")
    return np.array(heights.shape, dtype="<i4").tobytes() + heights.tobytes()
