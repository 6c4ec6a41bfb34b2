"""The examples run as documented and map their known scenes right."""

import importlib.util
from pathlib import Path

import numpy as np

from fogsim.eval.maps import load_maps

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load_example(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_real_data_example_maps_the_floor_and_the_box_top_at_their_heights(tmp_path, capsys):
    example = load_example("real_data")
    assert example.run(tmp_path / "out") == 0
    out = capsys.readouterr().out
    assert f"imported {example.FRAMES} frames" in out and "no ground truth" in out
    folder = tmp_path / "out" / "map"
    for name in ("report.json", "maps.npz", "fog_map.png", "fig3_panels.png"):
        assert (folder / name).stat().st_size > 0, name
    maps = load_maps(folder / "maps.npz")
    x, y = maps.cell_centers_xy[..., 0], maps.cell_centers_xy[..., 1]
    floor = maps.fog_types == 1
    (x0, y0, _), (x1, y1, top_m) = example.BOX_MIN_XYZ_M, example.BOX_MAX_XYZ_M
    on_top = (x > x0 + 0.04) & (x < x1 - 0.04) & (y > y0 + 0.04) & (y < y1 - 0.04)
    ground = (x > 0.8) & (x < x0 - 0.1) & (abs(y) < 0.3)  # in view from the first frame on
    assert on_top.sum() >= 40 and floor[on_top].all()  # every cell of the box's top seen
    assert ground.sum() >= 200 and floor[ground].all()
    np.testing.assert_allclose(np.median(maps.fog_heights_m[on_top]), top_m, atol=0.002)
    np.testing.assert_allclose(np.median(maps.fog_heights_m[ground & floor]), 0.0, atol=0.002)
