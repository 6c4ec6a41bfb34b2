"""``difference.png``: where the run's FOG differs from the truth, over the whole archive.

Every archive cell (:class:`fogsim.eval.maps.RunMaps`, the truth at the run's last frame) is
coloured by what the FOG made of it:

* a true floor labelled floor: its height error, FOG − truth [mm], on a diverging colour bar of
  ±:data:`ERROR_LIMIT_MM` (larger errors take the end colours);
* **obstacle → floor** (a true obstacle labelled floor: a robot would step onto it):
  :data:`OBSTACLE_TO_FLOOR_RGB`, red;
* **floor → obstacle** (a true floor labelled obstacle: a floor the robot would avoid):
  :data:`FLOOR_TO_OBSTACLE_RGB`, blue;
* obstacle → obstacle: dark grey; a cell the FOG never labelled: light grey.

Objects none of whose cells (the truth's ``object_id``) the FOG labelled are outlined in black
along their cells' edges and named. The legend gives each class's cell count.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from numpy.typing import NDArray

from fogsim.errors import ReportError
from fogsim.eval.maps import RunMaps, TruthMaps
from fogsim.viz.style import UNKNOWN_RGB, colorbar, extent, new_figure, save_png
from mapper import CellType

ERROR_CMAP = "BrBG"
"""Diverging colour map of floor height errors: brown too low, white right, teal too high."""
ERROR_LIMIT_MM = 50.0
"""Half the colour bar's range [mm]: 2.5 × the safety figure's 20 mm tolerance, so errors
that matter stand out and the few larger ones saturate instead of washing the scale out."""
OBSTACLE_TO_FLOOR_RGB = (1.0, 0.0, 0.0)
"""A true obstacle the FOG labels floor (unsafe): pure red, not on the error colour map."""
FLOOR_TO_OBSTACLE_RGB = (0.0, 0.35, 1.0)
"""A true floor the FOG labels obstacle: bright blue, not on the error colour map."""
OBSTACLE_RGB = (0.25, 0.25, 0.25)
"""A true obstacle the FOG labels obstacle."""
OUTLINE_RGB = (0.0, 0.0, 0.0)
"""Outline of an object the FOG never labelled."""
CLASS_RGB = {
    "obstacle → floor": OBSTACLE_TO_FLOOR_RGB,
    "floor → obstacle": FLOOR_TO_OBSTACLE_RGB,
    "obstacle → obstacle": OBSTACLE_RGB,
}
"""The plain colours of the cell classes (truth → FOG) other than floor → floor."""


def _classes(maps: RunMaps, truth: TruthMaps) -> dict[str, NDArray[np.bool_]]:
    """The picture's cell classes over the visited cells, (nx, ny) masks."""
    fog_floor = maps.seen & (maps.fog_types == CellType.FLOOR)
    fog_obstacle = maps.seen & (maps.fog_types == CellType.OBSTACLE)
    true_floor = truth.labels == CellType.FLOOR
    return {
        "floor → floor": fog_floor & true_floor,
        "obstacle → floor": fog_floor & ~true_floor,
        "floor → obstacle": fog_obstacle & true_floor,
        "obstacle → obstacle": fog_obstacle & ~true_floor,
    }


def floor_error_mm(maps: RunMaps, truth: TruthMaps) -> NDArray[np.float64]:
    """(nx, ny) FOG − true floor height [mm] of true floor cells the FOG labels floor, NaN."""
    floor = _classes(maps, truth)["floor → floor"]
    return np.where(floor, (maps.fog_heights_m - truth.floor_m) * 1000.0, np.nan)


def difference_rgb(maps: RunMaps) -> NDArray[np.float64]:
    """(ny, nx, 3) image of the difference picture's cell colours (module docstring)."""
    truth = _truth(maps)
    classes = _classes(maps, truth)
    rgb = np.empty((*maps.fog_types.shape, 3))
    rgb[:] = UNKNOWN_RGB
    error = floor_error_mm(maps, truth)
    norm = Normalize(-ERROR_LIMIT_MM, ERROR_LIMIT_MM, clip=True)
    floor = classes["floor → floor"]
    rgb[floor] = plt.get_cmap(ERROR_CMAP)(norm(error[floor]))[:, :3]
    for name, colour in CLASS_RGB.items():
        rgb[classes[name]] = colour
    return rgb.transpose(1, 0, 2)


def unseen_objects(maps: RunMaps) -> dict[str, NDArray[np.bool_]]:
    """Objects with cells in the truth none of which the FOG labelled: name → (nx, ny) cells."""
    truth = _truth(maps)
    unseen = {}
    for index, name in enumerate(truth.object_names):
        cells = truth.object_id == index
        if cells.any() and not (cells & maps.seen).any():
            unseen[name] = cells
    return unseen


def outline_segments(
    cells: NDArray[np.bool_], centers_xy: NDArray[np.float64], cell_m: float
) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """The edges [m] between cells in ``cells`` (nx, ny) and cells outside it (or the border).

    ``centers_xy`` (nx, ny, 2) lie on a regular lattice of ``cell_m``.
    """
    x0, y0 = (float(v) for v in centers_xy[0, 0])
    padded = np.pad(cells, 1)
    segments = []
    # An edge at lattice line i lies between cells i - 1 and i: at x0 + (i - 0.5) cell.
    for i, j in zip(*np.nonzero(padded[1:, 1:-1] != padded[:-1, 1:-1]), strict=True):
        x = x0 + (i - 0.5) * cell_m
        segments.append(((x, y0 + (j - 0.5) * cell_m), (x, y0 + (j + 0.5) * cell_m)))
    for i, j in zip(*np.nonzero(padded[1:-1, 1:] != padded[1:-1, :-1]), strict=True):
        y = y0 + (j - 0.5) * cell_m
        segments.append(((x0 + (i - 0.5) * cell_m, y), (x0 + (i + 0.5) * cell_m, y)))
    return segments


def difference_figure(maps: RunMaps, title: str) -> tuple[Figure, Axes]:
    """The difference picture as a figure and its map axes (world metres)."""
    truth = _truth(maps)
    fig = new_figure(9.0, 6.5, constrained=True)
    ax = fig.add_subplot()
    ax.imshow(
        difference_rgb(maps),
        origin="lower",
        extent=extent(maps.cell_centers_xy, maps.cell_m),
        interpolation="nearest",
    )
    for name, cells in unseen_objects(maps).items():
        segments = outline_segments(cells, maps.cell_centers_xy, maps.cell_m)
        ax.add_collection(LineCollection(segments, colors=[OUTLINE_RGB], linewidths=2.0))
        xy = maps.cell_centers_xy[cells]
        ax.annotate(
            f"{name}: never seen",
            (xy[:, 0].mean(), xy[:, 1].max() + maps.cell_m),  # above the outline
            ha="center",
            va="bottom",
            fontsize=8,
            bbox={"boxstyle": "round", "facecolor": "white", "alpha": 0.8, "linewidth": 0},
        )
    counts = {name: int(cells.sum()) for name, cells in _classes(maps, truth).items()}
    error = floor_error_mm(maps, truth)
    off = int(np.count_nonzero(np.abs(error[np.isfinite(error)]) > 20.0))
    handles = [
        Patch(color=colour, label=f"{name} ({counts[name]} cells)")
        for name, colour in CLASS_RGB.items()
    ]
    handles.append(Patch(color=UNKNOWN_RGB, label="never labelled"))
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    ax.set_title(
        f"{title}: FOG against the truth (labels: truth → FOG)\n"
        f"floor → floor cells by height error: {off} of {counts['floor → floor']} "
        "more than 20 mm off",
        fontsize=10,
    )
    colorbar(
        fig,
        ax,
        Normalize(-ERROR_LIMIT_MM, ERROR_LIMIT_MM),
        label="floor height error, FOG − truth [mm]",
        cmap=ERROR_CMAP,
        extend="both",
    )
    return fig, ax


def draw_difference(maps: RunMaps, title: str, path: str | os.PathLike[str]) -> Path:
    """Write ``difference.png`` of a run's maps with truth."""
    fig, _ = difference_figure(maps, title)
    return save_png(fig, path)


def _truth(maps: RunMaps) -> TruthMaps:
    if maps.truth is None:
        raise ReportError("the difference picture needs the truth: these maps have none")
    return maps.truth
