"""How the report writes numbers: mm to 0.01 mm, fractions to 5 digits, NaN as None.

Never a negative zero: a median of -20 and +20 mm is written 0.0, not -0.0.
"""

from __future__ import annotations

import math


def rounded(value: float, digits: int) -> float | None:
    """``value`` rounded to ``digits`` decimals; None for NaN or infinity (JSON null)."""
    number = round(float(value), digits) + 0.0  # + 0.0: no negative zero in the report
    return number if math.isfinite(number) else None


def mm(value_m: float) -> float | None:
    """Metres → millimetres rounded to 0.01 mm; None for NaN or infinity (JSON null)."""
    value = float(value_m)
    return None if not math.isfinite(value) else round(value * 1000.0, 2) + 0.0


def fraction(num: int, den: int) -> float | None:
    """``num / den`` rounded to 5 digits; None when ``den`` is 0."""
    return None if den == 0 else round(num / den, 5)
