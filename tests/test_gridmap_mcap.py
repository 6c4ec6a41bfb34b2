"""Maps out: ``fogsim run --mcap`` writes grid_map_msgs/GridMap per frame, read back with rosbags.

A low camera (0.3 m, looking nearly level) sees a step (floor), a tall box (obstacle) and a bar
hanging at 0.40 m with free space under it (ceiling), so every layer holds values. The last
GridMap must carry, for one cell of each layer, the value maps.npz has at that cell's world
position, where grid_map's own convention puts it: cell (row, column) at
``centre + (length / 2 − resolution / 2) − resolution · (row, column)``.
"""

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from synthetic_depth import Box, look_down_camera, render_boxes
from test_bags import INTR, real_frame

from fogsim.bags.gridmap import LAYERS, grid_map_data, grid_map_index
from fogsim.bags.write import GRID_MAP_TOPIC, POSE_TOPIC, McapMapWriter
from fogsim.cli import main
from fogsim.data.recording import Recording, save_recording
from fogsim.errors import OutputError
from fogsim.eval.maps import load_maps
from fogsim.run.runner import run_scenario
from mapper.transforms import planar_pose_to_matrix

CAMERA_IN_ROBOT = look_down_camera((0.0, 0.0, 0.3), pitch_down_deg=8.0)
BOXES = [
    Box((1.0, -0.3), (0.3, 0.4, 0.06)),
    Box((1.1, 0.45), (0.25, 0.25, 0.3)),
    Box((1.3, 0.0), (0.2, 1.4, 0.08), base_z_m=0.40),
]
FRAMES = 10
MAPS_KEYS = {
    "fog_height": "fog_heights_m",
    "fog_type": "fog_types",
    "floor": "floor_m",
    "obstacle": "obstacle_m",
    "ceiling": "ceiling_m",
}


def walk_frames():
    frames = []
    for i in range(FRAMES):
        pose = np.array([0.3 + 0.02 * i, 0.1, 0.0, 0.1])
        world = planar_pose_to_matrix(pose) @ CAMERA_IN_ROBOT
        frames.append(
            real_frame(i, i / 12.5, render_boxes(INTR, world, BOXES), CAMERA_IN_ROBOT, pose)
        )
    return frames


def read_bag(path):
    """Every message of the bag, deserialised: [(topic, timestamp_ns, message)]."""
    with AnyReader([path]) as reader:
        return [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]


def test_grid_map_axes_and_column_major_data_by_hand():
    layer = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])  # [ix, iy]: nx = 3, ny = 2
    # grid_map's matrix: row 0 = largest x (ix 2), column 0 = largest y (iy 1):
    #   [[6, 5], [4, 3], [2, 1]]; column-major: column 0 (6, 4, 2), then column 1 (5, 3, 1).
    np.testing.assert_array_equal(grid_map_data(layer), [6.0, 4.0, 2.0, 5.0, 3.0, 1.0])
    assert grid_map_index(2, 1, 3, 2) == (0, 0)
    assert grid_map_index(0, 0, 3, 2) == (2, 1)
    assert grid_map_data(layer).dtype == np.float32


@pytest.fixture(scope="module")
def mapped(tmp_path_factory):
    """A run of the walk with --mcap: (bag folder, maps.npz's RunMaps, frames)."""
    root = tmp_path_factory.mktemp("mcap")
    frames = walk_frames()
    recording = Recording(frames, None, [None] * FRAMES, INTR)
    run_scenario(None, root / "out", replay=recording, pictures=False, mcap=root / "fog")
    return root / "fog", load_maps(root / "out" / "maps.npz"), frames


def test_every_frame_has_a_grid_map_and_the_robot_pose(mapped):
    bag, _, frames = mapped
    assert sorted(p.name for p in bag.iterdir()) == ["fog.mcap", "metadata.yaml"]
    messages = read_bag(bag)
    grid_maps = [(t, m) for topic, t, m in messages if topic == GRID_MAP_TOPIC]
    poses = [(t, m) for topic, t, m in messages if topic == POSE_TOPIC]
    assert len(grid_maps) == len(poses) == FRAMES
    for frame, (stamp, grid_map), (_, pose) in zip(frames, grid_maps, poses, strict=True):
        assert stamp == round(frame.time_s * 1e9)
        assert grid_map.header.frame_id == pose.header.frame_id == "odom"
        assert grid_map.header.stamp.sec * 10**9 + grid_map.header.stamp.nanosec == stamp
        x, y, z, yaw = frame.robot_pose_believed
        p = pose.pose
        assert (p.position.x, p.position.y, p.position.z) == (x, y, z)
        assert p.orientation.z == pytest.approx(np.sin(yaw / 2), abs=1e-15)
        assert p.orientation.w == pytest.approx(np.cos(yaw / 2), abs=1e-15)


def test_the_last_grid_map_matches_maps_npz_cell_by_cell(mapped):
    bag, maps, frames = mapped
    grid_map = [m for topic, _, m in read_bag(bag) if topic == GRID_MAP_TOPIC][-1]
    assert list(grid_map.layers) == list(LAYERS)
    assert list(grid_map.basic_layers) == ["fog_height"]
    assert (grid_map.outer_start_index, grid_map.inner_start_index) == (0, 0)
    info = grid_map.info
    res = info.resolution
    assert res == 0.04 and (info.length_x, info.length_y) == (4.0, 4.0)  # 100 × 100 cells
    rows, cols = round(info.length_x / res), round(info.length_y / res)
    # The grid is centred on the robot's cell: x = 0.48 lies in cell 12 (0.48–0.52) of the
    # world lattice, the central cell 50 of the grid, whose corner is at 0.48 − 50·0.04.
    x_robot, y_robot = frames[-1].robot_pose_believed[:2]
    assert info.pose.position.x == pytest.approx((np.floor(x_robot / res) - 50) * res + 2.0)
    assert info.pose.position.y == pytest.approx((np.floor(y_robot / res) - 50) * res + 2.0)
    assert (info.pose.orientation.w, info.pose.orientation.z) == (1.0, 0.0)
    centre = np.array([info.pose.position.x, info.pose.position.y])
    checked = []
    for name, array in zip(grid_map.layers, grid_map.data, strict=True):
        dims = array.layout.dim
        assert [(d.label, d.size, d.stride) for d in dims] == [
            ("column_index", cols, rows * cols),
            ("row_index", rows, rows),
        ]
        values = np.asarray(array.data)
        assert values.shape == (rows * cols,)
        npz = np.asarray(getattr(maps, MAPS_KEYS[name]), dtype=np.float64)
        valid = npz > 0 if name == "fog_type" else np.isfinite(npz)  # fog_type 0: unknown
        # one cell with a value, the last frame's grid holding it (near the robot)
        distance = np.linalg.norm(maps.cell_centers_xy - centre, axis=-1)
        candidates = np.argwhere(valid & (distance < 1.5))
        assert len(candidates), name
        ix, iy = candidates[len(candidates) // 2]
        x, y = maps.cell_centers_xy[ix, iy]
        row = round((centre[0] + info.length_x / 2 - res / 2 - x) / res)
        col = round((centre[1] + info.length_y / 2 - res / 2 - y) / res)
        assert values[col * rows + row] == np.float32(npz[ix, iy]), (name, x, y)
        checked.append(name)
        if name != "fog_type":  # a height layer's unknown cells stay NaN (grid_map: invalid)
            assert np.isnan(values).any()
    assert checked == list(LAYERS)


def test_a_failed_run_leaves_no_bag_and_an_earlier_one_untouched(tmp_path):
    frames = walk_frames()
    bag = tmp_path / "fog"
    with McapMapWriter(bag):
        pass  # an empty bag
    before = (bag / "fog.mcap").read_bytes()

    class BoomError(Exception):
        pass

    with pytest.raises(BoomError), McapMapWriter(bag) as writer:
        writer.messages  # noqa: B018
        raise BoomError
    assert (bag / "fog.mcap").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fog"]  # no temporaries left
    (bag / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match=r"notes.txt, which is not a bag fogsim wrote"):
        McapMapWriter(bag)
    assert len(frames) == FRAMES


def test_run_mcap_on_the_command_line(tmp_path, capsys):
    recording = save_recording(tmp_path / "walk.npz", walk_frames())
    out, bag = tmp_path / "out", tmp_path / "fog"
    argv = ["run", "--replay", str(recording), "--quiet", "--no-pictures", "--out", str(out)]
    assert main([*argv, "--mcap", str(bag)]) == 0
    assert len([m for m in read_bag(bag) if m[0] == GRID_MAP_TOPIC]) == FRAMES
    first = (bag / "fog.mcap").read_bytes()
    assert main([*argv, "--mcap", str(bag)]) == 0  # replaces the earlier bag whole
    assert (bag / "fog.mcap").read_bytes() == first  # bit for bit the same
    (tmp_path / "file").write_text("x")
    assert main([*argv, "--mcap", str(tmp_path / "file")]) == 2
    assert "is a file; a bag is a folder" in capsys.readouterr().err
    assert main(["run", "flat_floor", "--seeds", "1-2", "--mcap", str(bag)]) == 2
    assert "--mcap writes one run's maps" in capsys.readouterr().err
