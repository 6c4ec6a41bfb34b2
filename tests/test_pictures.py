"""Pictures with known pixels: the difference picture's classes and the whole archive drawn.

The hand-built run of ``test_maps`` is drawn; a cell's pixel is found through the map axes'
data transform (figures are made at the PNG's resolution) and read back from the file.
"""

from __future__ import annotations

import matplotlib.image
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.colors import Normalize
from test_maps import (
    FLOOR_AS_OBSTACLE,
    HIGH_FLOOR,
    OBSTACLE_AS_FLOOR,
    POST,
    UNVISITED,
    hand_built_maps,
    run_result,
)

from fogsim.eval.maps import RunMaps, archive_maps
from fogsim.viz.difference import (
    ERROR_CMAP,
    ERROR_LIMIT_MM,
    FLOOR_TO_OBSTACLE_RGB,
    OBSTACLE_RGB,
    OBSTACLE_TO_FLOOR_RGB,
    OUTLINE_RGB,
    difference_figure,
    outline_segments,
    unseen_objects,
)
from fogsim.viz.pictures import fog_map_figure, write_pictures
from fogsim.viz.style import UNKNOWN_RGB, save_png


def maps_with_truth() -> RunMaps:
    archive, truth = hand_built_maps()
    return archive_maps(archive, truth)


def pixel_rgb(image: np.ndarray, ax: Axes, x_m: float, y_m: float) -> np.ndarray:
    """RGB of the saved picture at world point (x, y) of the map axes."""
    column, row_up = ax.transData.transform((x_m, y_m))
    return image[int(image.shape[0] - row_up), int(column), :3]


def cell_rgb(image: np.ndarray, ax: Axes, maps: RunMaps, cell: tuple[int, int]) -> np.ndarray:
    x, y = maps.cell_centers_xy[cell]
    return pixel_rgb(image, ax, x, y)


def saved(fig, path) -> np.ndarray:
    save_png(fig, path)
    return matplotlib.image.imread(path)


def test_difference_picture_colours_each_class_at_its_cells(tmp_path):
    maps = maps_with_truth()
    fig, ax = difference_figure(maps, "hand-built")
    image = saved(fig, tmp_path / "difference.png")
    one_level = 1.5 / 255  # PNG colours are 8 bits

    def colour_at(cell):
        return cell_rgb(image, ax, maps, cell)

    np.testing.assert_allclose(colour_at(OBSTACLE_AS_FLOOR), OBSTACLE_TO_FLOOR_RGB, atol=one_level)
    np.testing.assert_allclose(colour_at(FLOOR_AS_OBSTACLE), FLOOR_TO_OBSTACLE_RGB, atol=one_level)
    np.testing.assert_allclose(colour_at((2, 2)), OBSTACLE_RGB, atol=one_level)  # box, obstacle
    for cell in UNVISITED:
        np.testing.assert_allclose(colour_at(cell), UNKNOWN_RGB, atol=one_level)
    # Floor cells by their error: +30 mm, and 0 mm (white-ish middle of the colour map).
    error_colour = plt.get_cmap(ERROR_CMAP)(Normalize(-ERROR_LIMIT_MM, ERROR_LIMIT_MM)(30.0))
    np.testing.assert_allclose(colour_at(HIGH_FLOOR), error_colour[:3], atol=one_level)
    middle = plt.get_cmap(ERROR_CMAP)(0.5)[:3]
    np.testing.assert_allclose(colour_at((10, 8)), middle, atol=one_level)
    # The post was never labelled: grey inside, outlined in black along its cells' edges.
    x, y = maps.cell_centers_xy[11, 6] + 0.01
    np.testing.assert_allclose(pixel_rgb(image, ax, x, y), UNKNOWN_RGB, atol=one_level)
    left_edge_x = maps.cell_centers_xy[11, 6, 0] - maps.cell_m / 2
    np.testing.assert_allclose(pixel_rgb(image, ax, left_edge_x, y), OUTLINE_RGB, atol=0.2)


def test_only_never_labelled_objects_are_outlined_along_their_cell_edges():
    maps = maps_with_truth()
    unseen = unseen_objects(maps)
    assert list(unseen) == ["post"]  # the box has labelled cells
    segments = outline_segments(unseen["post"], maps.cell_centers_xy, maps.cell_m)
    # The post is 2 × 2 cells from x 0.44 to 0.52, y 0.24 to 0.32: 8 unit edges round it.
    assert len(segments) == 8
    xs = sorted({round(x, 9) for segment in segments for x, _ in segment})
    ys = sorted({round(y, 9) for segment in segments for _, y in segment})
    assert xs == [0.44, 0.48, 0.52] and ys == [0.24, 0.28, 0.32]
    assert unseen["post"].sum() == 4 and unseen["post"][POST].all()


def test_the_fog_map_shows_the_whole_archive(tmp_path):
    maps = maps_with_truth()
    fig, ax = fog_map_figure(maps, "hand-built")
    image = saved(fig, tmp_path / "fog_map.png")
    # The axes span every archive cell: x 0 to 0.56 m, y 0 to 0.44 m, unvisited corners too.
    assert ax.get_xlim() == pytest.approx((0.0, 0.56))
    assert ax.get_ylim() == pytest.approx((0.0, 0.44))
    for cell in UNVISITED:
        np.testing.assert_allclose(cell_rgb(image, ax, maps, cell), UNKNOWN_RGB, atol=1.5 / 255)


def test_write_pictures_draws_the_difference_only_with_truth(tmp_path):
    archive, truth = hand_built_maps()
    names = [p.name for p in write_pictures(run_result(archive, truth), None, tmp_path / "a")]
    assert names == ["fog_map.png", "fig3_panels.png", "difference.png"]
    names = [p.name for p in write_pictures(run_result(archive, None), None, tmp_path / "b")]
    assert names == ["fog_map.png", "fig3_panels.png"]
