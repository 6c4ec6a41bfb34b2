"""maps.npz: a hand-built archive and truth written and read back cell for cell."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from archive_factory import CELL, FLOOR, OBSTACLE, UNKNOWN, centers, store, truth_grid

from fogsim.config import RunParams
from fogsim.errors import ReportError
from fogsim.eval import maps as maps_module
from fogsim.eval.archive import WorldArchive
from fogsim.eval.maps import archive_maps, load_maps, save_maps, write_maps
from fogsim.eval.report.schema import PoseErrorStats
from fogsim.eval.result import RunResult
from fogsim.world.truth import GroundTruthGrid
from mapper import AveragingMap, FloorObstacleMapper

NX, NY = 14, 11
"""The archive: two 10 × 8 grids, the second 4 cells right and 3 up of the first."""
BOX = (slice(2, 4), slice(2, 4))  # a true obstacle, top 0.2 m: object 0
POST = (slice(11, 13), slice(6, 8))  # a true obstacle, top 0.3 m, never labelled: object 1
OBSTACLE_AS_FLOOR = (3, 3)  # a box cell the FOG labels floor at 0.2 m
FLOOR_AS_OBSTACLE = (8, 2)  # a floor cell the FOG labels obstacle at 0.1 m
HIGH_FLOOR = (6, 5)  # a floor cell 30 mm too high
TABLE = (6, 6)  # a true ceiling at 0.7 m, mapped at 0.69 m
UNVISITED = ((12, 1), (1, 9))  # outside both grids


def hand_built_maps() -> tuple[WorldArchive, GroundTruthGrid]:
    """The archive of two stored grids and the truth on its cells (constants above)."""
    types = np.full((NX, NY), FLOOR, dtype=np.int8)
    heights = np.zeros((NX, NY))
    types[BOX], heights[BOX] = OBSTACLE, 0.2
    heights[OBSTACLE_AS_FLOOR] = 0.2
    types[OBSTACLE_AS_FLOOR] = FLOOR
    types[FLOOR_AS_OBSTACLE], heights[FLOOR_AS_OBSTACLE] = OBSTACLE, 0.1
    heights[HIGH_FLOOR] = 0.03
    types[POST], heights[POST] = UNKNOWN, np.nan
    ceiling = np.full((NX, NY), np.nan)
    ceiling[TABLE] = 0.69
    baseline = heights + 0.001
    in_view = types != UNKNOWN
    lattice = centers(NX, NY)
    archive = WorldArchive(CELL)
    for grid in ((slice(0, 10), slice(0, 8)), (slice(4, 14), slice(3, 11))):
        store(
            archive,
            lattice[grid],
            types[grid],
            heights[grid],
            baseline[grid],
            ceiling_m=ceiling[grid],
            in_view=in_view[grid],
        )
    labels = np.full((NX, NY), FLOOR, dtype=np.int8)
    tops = np.full((NX, NY), np.nan)
    object_id = np.full((NX, NY), -1)
    for index, (cells, top) in enumerate(((BOX, 0.2), (POST, 0.3))):
        labels[cells], tops[cells], object_id[cells] = OBSTACLE, top, index
    true_ceiling = np.full((NX, NY), np.nan)
    true_ceiling[TABLE] = 0.7
    truth = truth_grid(
        labels,
        np.zeros((NX, NY)),
        tops,
        ceiling_m=true_ceiling,
        object_id=object_id,
        object_names=("box", "post"),
    )
    return archive, truth


def run_result(archive: WorldArchive, truth: GroundTruthGrid | None) -> RunResult:
    """A run that produced ``archive`` (with ``truth`` on its cells) and nothing else."""
    return RunResult(
        frames=0,
        withdrawn=0,
        z_matched=0,
        frames_without_ground_plane=0,
        update_ms=np.zeros(0),
        segmentation_ms=np.zeros(0),
        frame_ms=np.zeros(0),
        wall_s=0.0,
        mapper=FloorObstacleMapper(),
        baseline=AveragingMap(),
        archive=archive,
        scores=None,
        events=(),
        pose_error=PoseErrorStats(frames=0),
        params=RunParams(),
        final_truth=truth,
    )


def test_maps_npz_holds_the_archive_and_the_truth_cell_for_cell(tmp_path):
    archive, truth = hand_built_maps()
    path = write_maps(tmp_path / "maps.npz", run_result(archive, truth), truth)
    maps = load_maps(path)
    assert maps.cell_m == CELL and maps.fog_types.shape == (NX, NY)
    np.testing.assert_allclose(maps.cell_centers_xy[0, 0], (0.02, 0.02))
    np.testing.assert_allclose(maps.cell_centers_xy[-1, -1], (0.54, 0.42))
    for cell in UNVISITED:
        assert not maps.visited[cell] and not maps.seen[cell]
        assert maps.fog_types[cell] == UNKNOWN and np.isnan(maps.fog_heights_m[cell])
    assert maps.visited.sum() == NX * NY - 2 * 4 * 3
    assert not maps.seen[POST].any() and not maps.in_view[POST].any()
    assert maps.seen.sum() == maps.visited.sum() - 4
    assert maps.fog_types[2, 2] == OBSTACLE and maps.obstacle_m[2, 2] == 0.2
    assert maps.fog_types[OBSTACLE_AS_FLOOR] == FLOOR and maps.floor_m[OBSTACLE_AS_FLOOR] == 0.2
    assert maps.fog_heights_m[HIGH_FLOOR] == 0.03 and np.isnan(maps.obstacle_m[HIGH_FLOOR])
    assert maps.averaging_heights_m[HIGH_FLOOR] == pytest.approx(0.031)
    assert maps.ceiling_m[TABLE] == 0.69 and np.isfinite(maps.ceiling_m).sum() == 1
    t = maps.truth
    assert t is not None and t.object_names == ("box", "post")
    assert t.surface_names == ("ground",) and t.surface_heights_m == {"ground": 0.0}
    assert (t.object_id[POST] == 1).all() and t.object_id[HIGH_FLOOR] == -1
    assert (t.labels[BOX] == OBSTACLE).all() and t.obstacle_top_m[POST].max() == 0.3
    assert t.ceiling_m[TABLE] == 0.7 and t.floor_m[HIGH_FLOOR] == 0.0
    for name in ("labels", "floor_m", "obstacle_top_m", "surface_id", "interior"):
        np.testing.assert_array_equal(getattr(t, name), getattr(truth, name))


def test_every_key_of_the_file_is_documented_with_its_dtype(tmp_path):
    archive, truth = hand_built_maps()
    path = save_maps(tmp_path / "maps.npz", archive_maps(archive, truth))
    # The module docstring's table: ``key`` (shape) dtype-code ...
    table = re.findall(r"^``(\w+)``\s+(\(nx, ny(?:, 2)?\)|0-d) (\w+)", maps_module.__doc__, re.M)
    codes = {"f8": "float64", "i1": "int8", "i4": "int32", "bool": "bool", "str": "<U"}
    shapes = {"0-d": (), "(nx, ny)": (NX, NY), "(nx, ny, 2)": (NX, NY, 2)}
    with np.load(path, allow_pickle=False) as data:
        assert sorted(data.files) == sorted(key for key, _, _ in table)
        for key, shape, code in table:
            assert str(data[key].dtype).startswith(codes[code]), key
            assert data[key].shape == shapes[shape], key
        meta = json.loads(str(data["meta_json"]))
    assert meta["cell_types"] == {"unknown": 0, "floor": 1, "obstacle": 2}
    assert meta["has_truth"] and meta["object_names"] == ["box", "post"]


def test_maps_without_truth_have_no_truth_keys(tmp_path):
    archive, _ = hand_built_maps()
    maps = load_maps(save_maps(tmp_path / "maps.npz", archive_maps(archive, None)))
    assert maps.truth is None and maps.fog_types[2, 2] == OBSTACLE
    with np.load(tmp_path / "maps.npz") as data:
        assert not [key for key in data.files if key.startswith("truth_")]


def test_truth_on_other_cells_and_broken_files_are_refused(tmp_path):
    archive, truth = hand_built_maps()
    other = truth_grid(np.full((3, 3), FLOOR), np.zeros((3, 3)))
    with pytest.raises(ReportError, match=r"archive's cells, \(14, 11\).*got \(3, 3\)"):
        archive_maps(archive, other)
    path = save_maps(tmp_path / "maps.npz", archive_maps(archive, truth))
    with np.load(path) as data:
        arrays = {key: data[key] for key in data.files if key != "truth_object_id"}
    np.savez(tmp_path / "cut.npz", **arrays)
    with pytest.raises(ReportError, match="'truth_object_id' is missing"):
        load_maps(tmp_path / "cut.npz")
    arrays["meta_json"] = np.array(json.dumps({"format": "fogsim-recording", "version": 1}))
    np.savez(tmp_path / "other.npz", **arrays)
    with pytest.raises(ReportError, match="expected 'fogsim-maps' version 1"):
        load_maps(tmp_path / "other.npz")
    with pytest.raises(ReportError, match="not a readable maps"):
        load_maps(tmp_path / "missing.npz")
