"""MuJoCo models from MJCF, retried when MuJoCo's number parser reports an error that is not one.

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

So a parse that fails with exactly that message is tried again, up to `PARSE_ATTEMPTS` times in
all: the text is the same, so a real fault in it fails every time (and MuJoCo reports real faults
in numbers as "bad format" or "too large", which are raised at once).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import mujoco

__all__ = [
    "PARSE_ATTEMPTS",
    "SPURIOUS_PARSE_ERROR",
    "model_from_xml_path",
    "model_from_xml_string",
    "retry_spurious_parse_error",
]

SPURIOUS_PARSE_ERROR = "unknown error in attribute"
"""The part of MuJoCo's message for a numeric attribute whose parse left a stray ``errno``."""

PARSE_ATTEMPTS = 3
"""Parses of one MJCF before its error is raised: the failure is rare (2 of hundreds of
compiles), so a second attempt is all it takes; a third costs nothing on the good path."""


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
