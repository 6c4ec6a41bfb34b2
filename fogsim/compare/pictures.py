"""Side-by-side pictures of the maps of one run: heights, and heights against the truth.

One column per map (its own read-out, the archive's last heights): on top the heights in one
shared colour scale, below ``height − true top`` (the highest true surface of the cell) in a
diverging scale of ±:data:`DIFFERENCE_RANGE_MM`; cells without a height grey.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from matplotlib.colors import Normalize

from fogsim.compare.replay import RunComparison
from fogsim.viz.style import (
    CMAP,
    UNKNOWN_RGB,
    colorbar,
    extent,
    height_norm,
    new_figure,
    save_png,
)

DIFFERENCE_RANGE_MM = 50.0
"""Half range of the difference colour scale [mm]: a cell (40 mm) and more saturates."""
DIFFERENCE_CMAP = "RdBu_r"
"""Diverging colour map of the difference: red above the truth, blue below."""


def draw_comparison(run: RunComparison, path: str | os.PathLike[str]) -> Path:
    """Write the run's side-by-side picture to ``path`` (PNG)."""
    names = list(run.maps)  # each map's own row: its own labels and read-out
    archives = [run.archives[row] for row in names]
    centers = archives[0].cell_centers_xy()
    box = extent(centers, archives[0].cell_m)
    norm = height_norm(*(a.fog_heights_m for a in archives))
    nx, ny = centers.shape[:2]
    panel_in = 3.5
    fig = new_figure(panel_in * len(names) + 1.5, 2.0 * panel_in * ny / nx + 1.2, constrained=True)
    axes = fig.subplots(2, len(names), squeeze=False, sharex=True, sharey=True)
    for k, (name, archive) in enumerate(zip(names, archives, strict=True)):
        heights_mm = 1000.0 * np.asarray(archive.fog_heights_m)
        difference_mm = heights_mm - 1000.0 * run.final_truth_top_m
        for ax, values, cmap, scale in (
            (axes[0, k], heights_mm, CMAP, norm),
            (axes[1, k], difference_mm, DIFFERENCE_CMAP, None),
        ):
            ax.set_facecolor(UNKNOWN_RGB)
            if scale is None:
                ax.imshow(
                    np.ma.masked_invalid(values).T,
                    origin="lower",
                    extent=box,
                    cmap=cmap,
                    vmin=-DIFFERENCE_RANGE_MM,
                    vmax=DIFFERENCE_RANGE_MM,
                )
            else:
                ax.imshow(
                    np.ma.masked_invalid(values).T,
                    origin="lower",
                    extent=box,
                    cmap=cmap,
                    norm=scale,
                )
        axes[0, k].set_title(name)
        axes[1, k].set_xlabel("x [m]")
    axes[0, 0].set_ylabel("heights\ny [m]")
    axes[1, 0].set_ylabel("height − true top\ny [m]")
    colorbar(fig, axes[0, :], norm)
    colorbar(
        fig,
        axes[1, :],
        Normalize(-DIFFERENCE_RANGE_MM, DIFFERENCE_RANGE_MM),
        label="difference [mm]",
        cmap=DIFFERENCE_CMAP,
        extend="both",
    )
    fig.suptitle(f"{run.name}: the maps side by side")
    return save_png(fig, path)
