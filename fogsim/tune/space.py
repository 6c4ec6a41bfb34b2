"""The search space: which parameters can be tuned, their defaults, and one tuned range.

A tuned parameter is named by its override key, as ``fogsim run --set`` and
:func:`fogsim.config.params.resolve_params` take it: a bare :class:`mapper.MapperParams` field
(``p_occ``) or ``seg.`` + a :class:`mapper.segmentation.SegmentationParams` field
(``seg.min_plane_pixels``). Only numeric fields are tunable; booleans are switches, not ranges.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from fogsim.config import RunParams, override_key, replace_params, split_override_key
from fogsim.errors import ParameterError

if TYPE_CHECKING:
    import optuna

TUNED_TABLES = ("mapper", "segmentation")
"""The :class:`~fogsim.config.params.RunParams` groups (scenario tables) tuning may change."""


def _tunable_defaults() -> dict[str, int | float]:
    """Library default of every numeric (not bool) field of the tuned tables, by override key."""
    tables = RunParams().to_dict()
    return {
        override_key(table, name): value
        for table in TUNED_TABLES
        for name, value in tables[table].items()
        if isinstance(value, int | float) and not isinstance(value, bool)
    }


def tunable_parameter_names() -> tuple[str, ...]:
    """Every name ``--param`` accepts (keys of a scenario's ``[mapper]``/``[segmentation]``).

    Numeric MapperParams fields, and ``seg.`` + numeric SegmentationParams fields.
    """
    return tuple(_tunable_defaults())


def parameter_defaults(names: Sequence[str]) -> dict[str, int | float]:
    """Library defaults (``MapperParams()``, ``SegmentationParams()``) of the named parameters.

    Raises:
        ParameterError: a name is not a tunable parameter (the message lists the allowed ones).
    """
    defaults = _tunable_defaults()
    unknown = [n for n in names if n not in defaults]
    if unknown:
        raise ParameterError(f"not tunable parameters: {unknown}; tunable: {', '.join(defaults)}")
    return {n: defaults[n] for n in names}


def _parse_bound(text: str, what: str, spec: str) -> int | float:
    """One bound of a ``--param`` range: an int if written as one, else a finite float."""
    text = text.strip()
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise ParameterError(f"--param {spec!r}: {what} bound {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ParameterError(f"--param {spec!r}: {what} bound must be finite, got {text!r}")
    return value


@dataclass(frozen=True)
class ParamSpec:
    """One tuned parameter and its range.

    Attributes:
        name: A MapperParams field (``p_occ``) or ``seg.`` + a SegmentationParams field.
        low: Lower bound (inclusive), in the parameter's own unit.
        high: Upper bound (inclusive), > low.
        log: Sample on a log scale (needs low > 0).
        integer: Integer parameter (both bounds were written as integers).
    """

    name: str
    low: float
    high: float
    log: bool = False
    integer: bool = False

    def __post_init__(self) -> None:
        if not self.name:
            raise ParameterError("a tuned parameter needs a name")
        if not (math.isfinite(self.low) and math.isfinite(self.high)) or self.low >= self.high:
            raise ParameterError(
                f"parameter {self.name}: range must be finite with low < high, "
                f"got {self.low}:{self.high}"
            )
        if self.log and self.low <= 0:
            raise ParameterError(
                f"parameter {self.name}: a log range needs low > 0, got {self.low}"
            )
        if self.integer and (self.low != int(self.low) or self.high != int(self.high)):
            raise ParameterError(f"parameter {self.name}: integer bounds must be whole numbers")

    @classmethod
    def parse(cls, text: str, allowed: Sequence[str] | None = None) -> ParamSpec:
        """Parse ``name=lo:hi`` or ``name=lo:hi:log`` (integer if both bounds are integers).

        Args:
            text: The ``--param`` value.
            allowed: Valid names; None = :func:`tunable_parameter_names`.

        Raises:
            ParameterError: naming what is wrong and what is allowed.
        """
        name, sep, rest = text.partition("=")
        name = name.strip()
        parts = rest.split(":")
        if not sep or len(parts) not in (2, 3) or (len(parts) == 3 and parts[2].strip() != "log"):
            raise ParameterError(
                f"--param {text!r} must look like name=lo:hi or name=lo:hi:log "
                "(e.g. p_occ=0.55:0.95, eps_m=0.005:0.05:log)"
            )
        names = tunable_parameter_names() if allowed is None else tuple(allowed)
        if name not in names:
            raise ParameterError(f"--param {text!r}: unknown parameter {name!r}; tunable: {names}")
        low = _parse_bound(parts[0], "lower", text)
        high = _parse_bound(parts[1], "upper", text)
        integer = isinstance(low, int) and isinstance(high, int)
        return cls(name, float(low), float(high), log=len(parts) == 3, integer=integer)

    def suggest(self, trial: optuna.Trial) -> int | float:
        """Ask a trial for a value of this parameter."""
        if self.integer:
            return trial.suggest_int(self.name, int(self.low), int(self.high), log=self.log)
        return trial.suggest_float(self.name, self.low, self.high, log=self.log)

    def grid(self, points: int) -> list[int | float]:
        """``points`` values spread over the range (geometrically if ``log``), ends included."""
        if points < 2:
            raise ParameterError(f"grid points must be >= 2, got {points}")
        spread = np.geomspace if self.log else np.linspace
        values = spread(self.low, self.high, points)
        if self.integer:
            return sorted({int(v) for v in np.rint(values)})
        return [float(v) for v in values]

    def to_text(self) -> str:
        """The ``--param`` form of this spec."""
        fmt = (lambda v: str(int(v))) if self.integer else repr
        return f"{self.name}={fmt(self.low)}:{fmt(self.high)}" + (":log" if self.log else "")


def check_ranges(specs: Sequence[ParamSpec]) -> None:
    """Refuse ranges the parameters do not allow, before any trial runs.

    Each bound goes through the parameter class's own validation (:func:`fogsim.config.
    replace_params` on the library defaults, so the message says what is allowed), and an
    integer parameter needs bounds written as integers. A range passing both ends holds only
    allowed values: every parameter's allowed set is an interval. (A value may still be refused
    together with other tuned values, e.g. ``p_occ`` above a tuned ``p_max``: that trial fails.)

    Raises:
        ParameterError: ``--param <range>: ...`` naming the parameter, the bound and what is
            allowed.
    """
    defaults = RunParams()
    for spec in specs:
        group, name = split_override_key(spec.name)
        params = getattr(defaults, group)
        if isinstance(getattr(params, name), int) and not spec.integer:
            raise ParameterError(
                f"--param {spec.to_text()}: {spec.name} is an integer parameter; write both "
                f"bounds as integers (e.g. {spec.name}={math.ceil(spec.low)}:"
                f"{math.floor(spec.high)})"
            )
        for which, bound in (("lower", spec.low), ("upper", spec.high)):
            value = int(bound) if spec.integer else bound
            try:
                replace_params(params, {name: value}, group)
            except ParameterError as exc:
                raise ParameterError(
                    f"--param {spec.to_text()}: the {which} bound {value} is not allowed: {exc}"
                ) from None
