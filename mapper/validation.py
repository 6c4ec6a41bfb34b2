"""Checks of what callers hand the library: parameter fields, arrays, coordinates, transforms.

Every check raises the library's own errors (`mapper.errors`) with a message naming the field or
argument, the value and what is allowed; none converts silently (a complex array would lose its
imaginary part, a bool would pass as 0 or 1, a string would fail later without a name).
"""

from __future__ import annotations

import numbers
import reprlib
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mapper.errors import InvalidInputError, InvalidParameterError
from mapper.limits import MAX_COORDINATE_M, RIGID_TOLERANCE

_KIND_TEXT = {
    bool: "a bool (true or false)",
    int: "an integer (not a bool)",
    float: "a real number (not a bool, not NaN)",
}
"""What each kind of parameter field takes, for messages."""
_REAL_KINDS = "iuf"
"""numpy dtype kinds of real numbers: signed and unsigned integers, floats."""


def check_field(
    owner: str,
    name: str,
    value: object,
    kind: type[bool] | type[int] | type[float],
    allowed: str,
    ok: Callable[[float], bool] = lambda _: True,
) -> None:
    """Refuse a parameter field of the wrong type or outside its range.

    Args:
        owner: The parameter class (``"MapperParams"``), first in the message.
        name: The field.
        value: Its value.
        kind: ``bool`` (only a bool), ``int`` (an integer, not a bool) or ``float`` (any real
            number but a bool, NaN never).
        allowed: What is allowed, for the message (``"in (0.5, 1)"``).
        ok: Range test, called only with a value of the right type.

    Raises:
        InvalidParameterError: ``"<owner>.<name> must be <allowed>, got <value!r>"``, or for a
            value of the wrong type ``"... must be <type>, got <value!r> of type <type>;
            allowed: <allowed>"``.
    """
    if kind is bool:
        typed = isinstance(value, bool)
    elif isinstance(value, bool):
        typed = False
    elif kind is int:
        typed = isinstance(value, numbers.Integral)
    else:
        typed = isinstance(value, numbers.Real) and value == value  # NaN != NaN
    shown = reprlib.repr(value)  # a 400-digit int or a long string stays readable
    if not typed:
        raise InvalidParameterError(
            f"{owner}.{name} must be {_KIND_TEXT[kind]}, got {shown} of type "
            f"{type(value).__name__}; allowed: {allowed}"
        )
    try:
        accepted = ok(value)  # type: ignore[arg-type]
    except OverflowError:  # an int too large for a float, e.g. 10**400
        accepted = False
    if not accepted:
        raise InvalidParameterError(f"{owner}.{name} must be {allowed}, got {shown}")


def real_array(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """``value`` as a float64 array, refusing anything that is not real numbers.

    Args:
        value: Array-like of integers or floats.
        name: The argument, for the message.

    Raises:
        InvalidInputError: complex, bool, string or object data (numpy would drop an imaginary
            part or turn True into 1.0 without a word).
    """
    if type(value) is np.ndarray and value.dtype == np.float64:
        return value  # what the conversions below return for it, without their calls
    array = np.asarray(value)
    if array.dtype.kind not in _REAL_KINDS:
        raise InvalidInputError(
            f"{name} must hold real numbers (integer or float), got dtype {array.dtype}"
        )
    return np.asarray(array, dtype=np.float64)


def real_scalar(value: object, name: str) -> float:
    """``value`` as a float, refusing anything but one real number (NaN and inf pass)."""
    array = real_array(value, name)  # type: ignore[arg-type]
    if array.shape != ():
        raise InvalidInputError(f"{name} must be one number, got shape {array.shape}")
    return float(array)


def coordinate_m(value: object, name: str) -> float:
    """A world coordinate [m]: a finite real number within ±`MAX_COORDINATE_M`.

    Raises:
        InvalidInputError: naming the argument, the value and the bound.
    """
    number = real_scalar(value, name)
    if not abs(number) <= MAX_COORDINATE_M:  # NaN fails too
        raise InvalidInputError(
            f"{name} must be a finite coordinate within ±{MAX_COORDINATE_M:g} m "
            f"(mapper.limits.MAX_COORDINATE_M), got {value!r}"
        )
    return number


def rigid_transform(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A 4×4 rigid transform: finite, rotation orthonormal and proper (det +1), last row 0 0 0 1.

    Orthonormality is checked within `mapper.limits.RIGID_TOLERANCE`; a reflection (det −1)
    passes that test, so the determinant is checked too.

    Raises:
        InvalidInputError: naming the argument and what is wrong.
    """
    t = real_array(value, name)
    if t.shape != (4, 4) or not np.all(np.isfinite(t)):
        raise InvalidInputError(f"{name} must be a finite 4×4 matrix, got shape {t.shape}")
    rotation = t[:3, :3]
    deviation = float(np.abs(rotation @ rotation.T - np.eye(3)).max())
    determinant = float(np.linalg.det(rotation))
    last_row = float(np.abs(t[3] - (0.0, 0.0, 0.0, 1.0)).max())
    if deviation > RIGID_TOLERANCE or determinant <= 0.0 or last_row > 1e-12:
        raise InvalidInputError(
            f"{name} must be a rigid transform (rotation orthonormal within "
            f"{RIGID_TOLERANCE:g} with det +1, not a reflection; last row 0 0 0 1), got "
            f"max |R·Rᵀ − I| = {deviation:.3g}, det R = {determinant:.6g}, last row "
            f"{t[3].tolist()}"
        )
    return t
