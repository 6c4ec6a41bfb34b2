"""Pictures of a run (matplotlib, Agg backend); the video is :mod:`fogsim.viz.video`.

Every map picture shows the whole archive (every cell that was ever inside the robot-centred
grid, each with its last value there, :class:`fogsim.eval.maps.RunMaps`), not the last grid:

* ``fog_map.png`` — the paper's Fig. 7: the FOG: floor height in colour, obstacles black with a
  cross coloured by their coarse height, unknown grey, a colour bar in mm.
* ``fig3_panels.png`` — Fig. 3's four panels: (a) the world (true floor and obstacle heights),
  (b) the floor height map, (c) the 3-D occupancy grid (occupied cells; the mapper keeps it for
  the last grid only), (d) the FOG.
* ``difference.png`` — runs with ground truth: the FOG against the truth
  (:mod:`fogsim.viz.difference`).
* ``fig5_comparison.png`` — Fig. 5 for scenarios with events: camera image, averaging map and
  FOG just before the first event and at the end of the run, and each event's figures
  (cleared, floor again) in the report's words.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from numpy.typing import NDArray

from fogsim.config import Scenario
from fogsim.eval.maps import RunMaps, archive_maps
from fogsim.eval.result import RunResult
from fogsim.viz.difference import draw_difference
from fogsim.viz.forked import ForkedCall
from fogsim.viz.style import (
    CMAP,
    OBSTACLE_RGB,
    UNKNOWN_RGB,
    colorbar,
    extent,
    height_norm,
    new_figure,
    save_png,
)
from mapper.grid import CellType


def fog_rgb(
    types: NDArray[np.integer], heights_m: NDArray[np.floating], norm: Normalize
) -> NDArray[np.float64]:
    """(ny, nx, 3) image of a FOG: floor in colour (mm), obstacles black, unknown grey."""
    t = np.asarray(types).T
    h = np.asarray(heights_m, dtype=np.float64).T * 1000.0
    rgb = np.empty((*t.shape, 3))
    rgb[:] = UNKNOWN_RGB
    floor = t == CellType.FLOOR
    rgb[floor] = plt.get_cmap(CMAP)(norm(h[floor]))[:, :3]
    rgb[t == CellType.OBSTACLE] = OBSTACLE_RGB
    return rgb


def heights_rgb(heights_m: NDArray[np.floating], norm: Normalize) -> NDArray[np.float64]:
    """(ny, nx, 3) image of a height map [m] (NaN grey)."""
    h = np.asarray(heights_m, dtype=np.float64).T * 1000.0
    rgb = np.empty((*h.shape, 3))
    rgb[:] = UNKNOWN_RGB
    known = np.isfinite(h)
    rgb[known] = plt.get_cmap(CMAP)(norm(h[known]))[:, :3]
    return rgb


def _draw_fog(
    ax: Axes,
    types: NDArray[np.integer],
    heights: NDArray[np.floating],
    centers: NDArray[np.float64],
    cell_m: float,
    norm: Normalize,
) -> None:
    ax.imshow(
        fog_rgb(types, heights, norm),
        origin="lower",
        extent=extent(centers, cell_m),
        interpolation="nearest",
    )
    obstacle = np.asarray(types) == CellType.OBSTACLE
    if obstacle.any():
        xy = centers[obstacle]
        ax.scatter(
            xy[:, 0],
            xy[:, 1],
            c=np.asarray(heights)[obstacle] * 1000.0,
            cmap=CMAP,
            norm=norm,
            marker="x",
            s=max(4.0, 600.0 / max(centers.shape[:2])),
            linewidths=0.8,
        )
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")


def _fog_norm(maps: RunMaps) -> Normalize:
    """Height colours of a FOG: over its floor and obstacle heights."""
    return height_norm(np.where(maps.fog_types != CellType.UNKNOWN, maps.fog_heights_m, np.nan))


def fog_map_figure(maps: RunMaps, title: str) -> tuple[Figure, Axes]:
    """Fig. 7: the FOG of the whole archive, as a figure and its map axes."""
    norm = _fog_norm(maps)
    fig = new_figure(8.0, 6.0)
    ax = fig.add_subplot()
    _draw_fog(ax, maps.fog_types, maps.fog_heights_m, maps.cell_centers_xy, maps.cell_m, norm)
    colorbar(fig, ax, norm)
    ax.set_title(f"{title}: floor and obstacle grid (grey unknown, black obstacle)")
    return fig, ax


def draw_fog_map(maps: RunMaps, title: str, path: Path) -> Path:
    """Write Fig. 7 (``fog_map.png``)."""
    fig, _ = fog_map_figure(maps, title)
    return save_png(fig, path)


def draw_fig3(result: RunResult, maps: RunMaps, title: str, path: Path) -> Path:
    """Fig. 3: world, floor map, 3-D occupancy grid (last grid), FOG of the whole archive."""
    mapper = result.mapper
    g = mapper.geometry
    centers, cell_m = maps.cell_centers_xy, maps.cell_m
    area = extent(centers, cell_m)
    norm = _fog_norm(maps)
    fig = new_figure(12.0, 10.0)
    ax_a = fig.add_subplot(2, 2, 1)
    if maps.truth is not None:
        truth = maps.truth
        world = np.where(np.isfinite(truth.floor_m), truth.floor_m, truth.obstacle_top_m)
        norm = height_norm(maps.floor_m, maps.fog_heights_m, world)
        ax_a.imshow(heights_rgb(world, norm), origin="lower", extent=area, interpolation="nearest")
        ax_a.set_title("(a) world: true floor / obstacle tops")
    elif result.last_depth_m is not None:
        ax_a.imshow(result.last_depth_m, cmap="magma")
        ax_a.set_title("(a) last depth image")
    ax_b = fig.add_subplot(2, 2, 2)
    ax_b.imshow(
        heights_rgb(maps.floor_m, norm), origin="lower", extent=area, interpolation="nearest"
    )
    ax_b.set_title("(b) floor height map (grey invalid)")
    ax_c = fig.add_subplot(2, 2, 3, projection="3d")
    occupied = mapper.occupancy() > mapper.params.p_occ
    ix, iy, iz = np.nonzero(occupied)
    if ix.size:
        grid_centers = g.cell_centers_xy()
        z = g.z_min_m + (iz + 0.5) * g.layer_m
        ax_c.scatter(
            grid_centers[ix, iy, 0],
            grid_centers[ix, iy, 1],
            z,
            c=z * 1000.0,
            cmap=CMAP,
            norm=norm,
            marker="s",
            s=4,
            depthshade=False,
        )
    ax_c.set_xlim(area[0], area[1])
    ax_c.set_ylim(area[2], area[3])
    ax_c.set_title("(c) 3-D occupancy grid at the last frame (occupied cells)")
    ax_c.set_xlabel("x [m]")
    ax_c.set_ylabel("y [m]")
    ax_c.set_zlabel("z [m]")
    ax_d = fig.add_subplot(2, 2, 4)
    _draw_fog(ax_d, maps.fog_types, maps.fog_heights_m, centers, cell_m, norm)
    ax_d.set_title("(d) floor and obstacle grid")
    for ax in (ax_a, ax_b):
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
    colorbar(fig, [ax_b, ax_d], norm)
    fig.suptitle(f"{title}: Fig. 3 panels")
    return save_png(fig, path)


def draw_fig5(result: RunResult, title: str, path: Path, cell_m: float) -> Path:
    """Fig. 5: camera, averaging baseline and FOG before the first event and at the end."""
    snaps = result.snapshots
    all_heights = [s.baseline_heights_m for s in snaps] + [s.fog_heights_m for s in snaps]
    norm = height_norm(*all_heights)
    fig = new_figure(14.0, 4.6 * len(snaps) + 0.3 * len(result.events))
    axes = fig.subplots(len(snaps), 3, squeeze=False)
    for row, snap in zip(axes, snaps, strict=True):
        row[0].imshow(snap.depth_m, cmap="magma")
        row[0].set_title(f"{snap.label}: depth image, frame {snap.frame_index}")
        row[0].axis("off")
        area = extent(snap.cell_centers_xy, cell_m)
        row[1].imshow(heights_rgb(snap.baseline_heights_m, norm), origin="lower", extent=area)
        row[1].set_title(f"{snap.label}: averaging (Kagami)")
        _draw_fog(row[2], snap.fog_types, snap.fog_heights_m, snap.cell_centers_xy, cell_m, norm)
        row[2].set_title(f"{snap.label}: FOG (ours)")
    colorbar(fig, axes[:, 1:].ravel().tolist(), norm)
    fig.suptitle(f"{title}: averaging vs FOG (Fig. 5)")
    fig.text(
        0.5,
        0.01,
        "\n".join(event.text() for event in result.events),
        ha="center",
        va="bottom",
        fontsize=9,
    )
    return save_png(fig, path)


def write_pictures(
    result: RunResult, scenario: Scenario | None, out_dir: str | os.PathLike[str]
) -> list[Path]:
    """Write the run's PNGs into ``out_dir``; returns their paths.

    ``result.final_truth`` must be the truth on the archive's cells (or None without truth).
    Fig. 3 (the slowest: a 3-D scatter, ~40 % of the drawing) is drawn by a forked process
    (:class:`~fogsim.viz.forked.ForkedCall`) while this one draws the others: on two cores the
    pictures take the time of the longer half. Where there is no ``fork`` all are drawn here.
    """
    out = Path(out_dir)
    title = (scenario.name if scenario is not None else None) or "run"
    maps = archive_maps(result.archive, result.final_truth)
    fig3 = out / "fig3_panels.png"
    with ForkedCall(
        lambda: draw_fig3(result, maps, title, fig3), what="the picture process"
    ) as beside:
        beside.submit()
        paths = [draw_fog_map(maps, title, out / "fog_map.png"), fig3]
        if maps.truth is not None:
            paths.append(draw_difference(maps, title, out / "difference.png"))
        if result.snapshots:
            cell_m = result.archive.cell_m
            paths.append(draw_fig5(result, title, out / "fig5_comparison.png", cell_m))
        beside.result()
    return paths
