"""Obstacle height (eq. 10), floor and obstacle grid (eq. 11) and ceiling map (Sec. VI).

Conventions (heights in world metres, NaN = invalid):

- ``Obstacle(x, y)`` is the *top face* of the highest occupied cell of the column,
  ``z_min + (k + 1)·layer`` — the coarse upper bound of what is there.
- FOG: obstacle if ``h_o > h_f + δ`` (with an invalid floor every valid ``h_o`` counts), else
  floor if ``h_f`` is valid, else unknown. Beyond the paper, a floor whose points do not cover
  its cell (`mapper.floor_cover`, `MapperParams.floor_pass_fraction`) counts as invalid here.
  Obstacles below the floor surface are ignored; an
  occupied cell hanging above a floor (curtain, table top) makes the cell an obstacle.
- Beyond the paper, with a margin of ``m`` cells (`MapperParams.obstacle_margin_cells`; 0 = the
  paper) a floor ``h_f`` that eq. 11 keeps is an obstacle, an edge may cross its cell, when
  within the ``(2m + 1)²`` cells around it

  - the highest ``h_o`` exceeds ``h_f + δ`` (a box, the top of a step or sill beside it): the
    cell's height is then that ``h_o``; or
  - a floor lies in a layer ``k`` below the layer of ``h_f − ε`` (another surface, lower than
    this floor's own noise reaches) and this column's layer ``k`` is occupied too: that lower
    surface is seen inside this cell, whose floor is the higher one's (a sill's edge cell, a
    quarter sill, whose sill points won the votes). The cell's height is then ``h_f``'s
    layer top. A cell over a solid surface never sees the layers under it.
- ``Ceiling(x, y)`` is the *bottom face* of the lowest occupied cell above the free space a
  robot could use: where the floor is valid, the lowest occupied cell whose top is above
  ``h_f + δ`` (the cells the FOG counts as obstacle); where it is not, the lowest occupied cell
  with a cell observed free (``OG < 0.5``) somewhere below it in its column (something seen
  overhanging). NaN where there is none. ``ceiling − floor`` is the clearance to crawl under.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from mapper.grid import CellType
from mapper.params import LEVEL_UNKNOWN

_UNKNOWN = np.int8(CellType.UNKNOWN)
_FLOOR = np.int8(CellType.FLOOR)
_OBSTACLE = np.int8(CellType.OBSTACLE)


@numba.njit(cache=True, inline="always")
def _edge_height(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    delta: float,
    eps: float,
    ix: int,
    iy: int,
    margin: int,
) -> float:
    """The obstacle height of a floor cell an edge may cross (module docstring), NaN if none.

    The highest top within ``margin`` cells if it lies more than ``delta`` above the floor;
    else the top of the floor's layer if a floor within ``margin`` cells lies in a layer below
    that of ``floor − eps`` and this column's cell in that layer is occupied.
    """
    nx, ny = floor.shape
    hf = floor[ix, iy]
    own = np.floor((hf - eps - z_min) / layer)
    highest = -np.inf
    lower_seen = False
    for jx in range(max(ix - margin, 0), min(ix + margin + 1, nx)):
        for jy in range(max(iy - margin, 0), min(iy + margin + 1, ny)):
            if obstacle[jx, jy] > highest:  # NaN: never
                highest = obstacle[jx, jy]
            k = np.floor((floor[jx, jy] - z_min) / layer)  # NaN floor: no comparison holds
            if 0 <= k < own and og[ix, iy, int(k)] > occ_level:
                lower_seen = True
    if highest > hf + delta:
        return highest
    if lower_seen:
        return z_min + (np.floor((hf - z_min) / layer) + 1.0) * layer
    return np.nan


@numba.njit(cache=True, nogil=True, boundscheck=False)
def update_fog_area(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    obstacle: NDArray[np.float64],
    fog_types: NDArray[np.int8],
    fog_heights: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    delta: float,
    ix0: int,
    ix1: int,
    iy0: int,
    iy1: int,
    cover_ends: NDArray[np.int32],
    cover_passes: NDArray[np.int32],
    min_rays: int,
    pass_fraction: float,
    margin: int = 0,
    eps: float = 0.0,
) -> None:
    """Recompute ``obstacle`` (eq. 10) and the FOG (eq. 11) in ``[ix0, ix1) × [iy0, iy1)``.

    A floor reached by at least ``min_rays`` rays of which more than ``pass_fraction`` passed
    through it (`mapper.floor_cover`) does not cover its cell: the cell is then unknown unless
    eq. 11 makes it an obstacle; ``pass_fraction`` 0 = off (the paper).

    With ``margin`` m > 0 (`MapperParams.obstacle_margin_cells`) a floor is also compared with
    the tops and floors within m cells (module docstring; ``eps`` the gate of eq. 9), so the
    FOG is recomputed m cells beyond the area too (clipped to the grid): their windows reach
    into it. ``obstacle`` outside the area is current, as only the area's columns changed.
    """
    nx, ny, nz = og.shape
    for ix in range(ix0, ix1):
        for iy in range(iy0, iy1):
            # Highest occupied layer, as a branch-free scan the compiler vectorises.
            k_top = -1
            for k in range(nz):
                k_top = k if og[ix, iy, k] > occ_level else k_top
            obstacle[ix, iy] = z_min + (k_top + 1) * layer if k_top >= 0 else np.nan
    for ix in range(max(ix0 - margin, 0), min(ix1 + margin, nx)):
        for iy in range(max(iy0 - margin, 0), min(iy1 + margin, ny)):
            top = obstacle[ix, iy]
            hf = floor[ix, iy]
            edge = np.nan
            if margin > 0 and not np.isnan(hf) and not top > hf + delta:
                edge = _edge_height(
                    og, floor, obstacle, occ_level, z_min, layer, delta, eps, ix, iy, margin
                )
            passes = cover_passes[ix, iy]
            reached = cover_ends[ix, iy] + passes
            covered = not (
                pass_fraction > 0.0 and reached >= min_rays and passes > pass_fraction * reached
            )
            if not np.isnan(edge):
                fog_types[ix, iy] = _OBSTACLE
                fog_heights[ix, iy] = edge
            elif not np.isnan(top) and (np.isnan(hf) or top > hf + delta):
                fog_types[ix, iy] = _OBSTACLE
                fog_heights[ix, iy] = top
            elif not np.isnan(hf) and covered:
                fog_types[ix, iy] = _FLOOR
                fog_heights[ix, iy] = hf
            else:
                fog_types[ix, iy] = _UNKNOWN
                fog_heights[ix, iy] = np.nan


@numba.njit(cache=True, nogil=True)
def ceiling_map(
    og: NDArray[np.uint8],
    floor: NDArray[np.float64],
    occ_level: int,
    z_min: float,
    layer: float,
    delta: float,
) -> NDArray[np.float64]:
    """(nx, ny) ceiling heights [m] as defined in the module docstring, NaN where none."""
    nx, ny, nz = og.shape
    out = np.full((nx, ny), np.nan)
    for ix in range(nx):
        for iy in range(ny):
            hf = floor[ix, iy]
            seen_free = False
            for k in range(nz):
                level = og[ix, iy, k]
                if level > occ_level:
                    if np.isnan(hf):
                        if seen_free:
                            out[ix, iy] = z_min + k * layer
                            break
                    elif z_min + (k + 1) * layer > hf + delta:
                        out[ix, iy] = z_min + k * layer
                        break
                elif level < LEVEL_UNKNOWN:
                    seen_free = True
    return out
