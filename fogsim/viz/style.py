"""What every picture shares: the matplotlib backend, colours, extents, colour bars, saving.

Maps are arrays indexed ``[ix, iy]``; pictures draw them with x to the right and y up, world
metres on the axes (``imshow(array.T, origin="lower", extent=extent(...))``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # headless: pictures are files, never windows

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import Colormap, Normalize
from matplotlib.figure import Figure
from numpy.typing import NDArray

from fogsim.atomic import write_atomic

PICTURE_DPI = 110
"""Resolution of every PNG [dots per inch]; figures are made at it, so a point's pixel in the
file is its display position (tests read pixels at known cells)."""
CMAP = "viridis"
"""Colour map of heights."""
UNKNOWN_RGB = (0.62, 0.62, 0.62)
"""Cells a map has no value for."""
OBSTACLE_RGB = (0.0, 0.0, 0.0)
"""FOG obstacle cells."""


def extent(centers_xy: NDArray[np.float64], cell_m: float) -> tuple[float, float, float, float]:
    """``imshow`` extent (left, right, bottom, top) [m] of a grid of cell centres (nx, ny, 2)."""
    return (
        float(centers_xy[0, 0, 0] - cell_m / 2),
        float(centers_xy[-1, 0, 0] + cell_m / 2),
        float(centers_xy[0, 0, 1] - cell_m / 2),
        float(centers_xy[0, -1, 1] + cell_m / 2),
    )


def height_norm(*heights_m: NDArray[np.floating]) -> Normalize:
    """Colour scale [mm] over the finite heights [m] (at least 20 mm wide; 0–100 mm if none)."""
    values = np.concatenate([np.asarray(h, dtype=np.float64).ravel() for h in heights_m])
    values = values[np.isfinite(values)] * 1000.0
    if not values.size:
        return Normalize(0.0, 100.0)
    low, high = float(np.min(values)), float(np.max(values))
    return Normalize(low, max(high, low + 20.0))


def colorbar(
    fig: Figure,
    ax: Axes | Sequence[Axes],
    norm: Normalize,
    label: str = "height [mm]",
    cmap: str | Colormap = CMAP,
    extend: str = "neither",
) -> None:
    """A colour bar of ``cmap`` over ``norm`` beside ``ax``."""
    mappable = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(mappable, ax=ax, label=label, shrink=0.85, extend=extend)


def new_figure(width_in: float, height_in: float, *, constrained: bool = False) -> Figure:
    """An empty figure of the given size [inch] at :data:`PICTURE_DPI`.

    ``constrained``: matplotlib's constrained layout places titles, colour bars and legends
    outside the axes without overlap.
    """
    layout = "constrained" if constrained else None
    return plt.figure(figsize=(width_in, height_in), dpi=PICTURE_DPI, layout=layout)


def save_png(fig: Figure, path: str | os.PathLike[str]) -> Path:
    """Write the figure as a PNG atomically (complete or absent) and close it."""
    target = Path(path)
    write_atomic(target, lambda handle: fig.savefig(handle, format="png", dpi=PICTURE_DPI))
    plt.close(fig)
    return target
