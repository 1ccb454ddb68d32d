import csv

import gtsam
import numpy as np
import pytest
import yaml
from PIL import Image

from sim.world_io import (RosMap, StartError, has_own_scale, load_bitmap, load_ros_map, load_world, read_ros_map,
                          start_pose)
from sim.worlds import BUILTIN_WORLDS, corner_start


def save_grey(path, pixels):
    Image.fromarray(np.asarray(pixels, dtype=np.uint8), mode="L").save(path)
    return path


@pytest.fixture
def bitmap(tmp_path):
    # 4 wide, 2 high; one black pixel in the top row, last column
    pixels = np.full((2, 4), 255)
    pixels[0, 3] = 0
    return save_grey(tmp_path / "tiny.png", pixels)


def test_size_stretches_pixels_lower_left_at_origin(bitmap):
    world = load_bitmap(bitmap, size=(8.0, 2.0))
    assert world.resolution == (2.0, 1.0)  # non-square pixels, as Stage stretches bitmaps
    assert world.origin == (0.0, 0.0)
    assert world.size == (8.0, 2.0)
    # image top row is the world's upper row: the black pixel covers x in [6, 8), y in [1, 2)
    assert world.is_occupied(np.array([7.0, 1.5]))
    assert not world.is_occupied(np.array([7.0, 0.5]))
    assert not world.is_occupied(np.array([1.0, 1.5]))
    assert world.occupied.sum() == 1


def test_resolution_gives_square_cells(bitmap):
    world = load_bitmap(bitmap, resolution=0.25)
    assert world.resolution == (0.25, 0.25)
    assert world.size == (1.0, 0.5)
    assert world.is_occupied(np.array([0.9, 0.4]))


def test_off_grid_is_occupied(bitmap):
    world = load_bitmap(bitmap, size=(8.0, 2.0))
    assert world.is_occupied(np.array([-0.1, 1.0])) and world.is_occupied(np.array([4.0, 2.01]))


@pytest.mark.parametrize("kwargs, match", [
    ({}, "no scale"),
    ({"size": (4.0, 2.0), "resolution": 0.1}, "not both"),
    ({"size": (0.0, 2.0)}, "must be positive"),
    ({"size": (4.0, -2.0)}, "must be positive"),
    ({"resolution": -0.1}, "must be positive"),
])
def test_bad_scale_is_rejected_naming_the_file(bitmap, kwargs, match):
    with pytest.raises(ValueError, match=match) as err:
        load_bitmap(bitmap, **kwargs)
    assert "tiny.png" in str(err.value)


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothere.png"):
        load_world(tmp_path / "nothere.png", size=(1, 1))
    junk = tmp_path / "junk.png"
    junk.write_text("not an image")
    with pytest.raises(ValueError, match="junk.png: not a readable image"):
        load_bitmap(junk, resolution=0.1)


def write_ros_map(tmp_path, text, pixels):
    save_grey(tmp_path / "map.pgm", pixels)
    path = tmp_path / "map.yaml"
    path.write_text(text)
    return path


def test_ros_map_origin_thresholds_and_unknown(tmp_path):
    pixels = np.array([[254, 0, 205],
                       [254, 254, 254]])  # free, occupied, unknown (ROS colours)
    path = write_ros_map(tmp_path, "image: map.pgm\nresolution: 0.5\norigin: [-1.0, -2.0, 0.0]\n"
                         "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n", pixels)
    world = load_ros_map(path)
    assert world.origin == (-1.0, -2.0) and world.resolution == (0.5, 0.5)
    # top image row is y in [-1.5, -1.0)
    assert not world.is_occupied(np.array([-0.75, -1.25]))
    assert world.is_occupied(np.array([-0.25, -1.25]))
    assert world.is_occupied(np.array([0.25, -1.25]))  # unknown counts as occupied
    assert not world.occupied[0].any()


def test_ros_map_negate(tmp_path):
    pixels = np.array([[0, 255]])
    path = write_ros_map(tmp_path, "image: map.pgm\nresolution: 1\norigin: [0, 0, 0]\nnegate: 1\n", pixels)
    world = load_world(path)
    assert not world.is_occupied(np.array([0.5, 0.5])) and world.is_occupied(np.array([1.5, 0.5]))


@pytest.mark.parametrize("text, match", [
    ("image: map.pgm\norigin: [0, 0, 0]\n", "missing key 'resolution'"),
    ("image: map.pgm\nresolution: fine\norigin: [0, 0, 0]\n", "key 'resolution' has an unreadable value"),
    ("image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0.5]\n", "yaw"),
    ("image: map.pgm\nresolution: 0.1\norigin: zero\n", "key 'origin'"),
    ("image: map.pgm\nresolution: -0.1\norigin: [0, 0, 0]\n", "must be positive"),
    ("image: [unclosed\n", "not valid YAML"),
    ("image: other.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", "other.pgm: no such image"),
])
def test_ros_map_bad_yaml_names_file_and_key(tmp_path, text, match):
    path = write_ros_map(tmp_path, text, np.full((2, 2), 254))
    with pytest.raises((ValueError, FileNotFoundError), match=match) as err:
        load_ros_map(path)
    assert "map.yaml" in str(err.value) or "other.pgm" in str(err.value)


def test_builtin_names_and_their_scale():
    cave = load_world("cave")
    assert cave.size == pytest.approx((20.0, 20.0))
    with pytest.raises(ValueError, match="own scale"):
        load_world("cave", size=(10, 10))


def test_only_bitmaps_need_a_scale():
    assert has_own_scale("cave") and has_own_scale("maps/lab.yaml") and has_own_scale("LAB.YML")
    assert not has_own_scale("maps/cave.png") and not has_own_scale("caves")


def test_start_pose_given_builtin_or_a_free_corner(tmp_path):
    cave = load_world("cave")
    assert start_pose("cave", cave, 0.25).equals(BUILTIN_WORLDS["cave"]().start, 1e-12)
    assert start_pose("cave", cave, 0.25, (2.5, 2.0, 1.0)).equals(gtsam.Pose2(2.5, 2.0, 1.0), 1e-12)
    pixels = np.full((60, 100), 255)                      # a 5 m x 3 m room, walls 0.1 m thick
    pixels[:2], pixels[-2:], pixels[:, :2], pixels[:, -2:] = 0, 0, 0, 0
    room = load_world(save_grey(tmp_path / "room.png", pixels), size=(5.0, 3.0))
    pose = start_pose(tmp_path / "room.png", room, 0.25)
    assert pose.equals(corner_start(room, 0.25), 1e-12)
    assert not room.collides((pose.x(), pose.y()), 0.25 + 0.5)   # the corner leaves a margin


def test_a_start_the_robot_does_not_fit_is_a_start_error(tmp_path):
    cave = load_world("cave")
    with pytest.raises(StartError, match=r"start \(0.10, 0.10\) is not free for a robot of radius 0.25 m"):
        start_pose("cave", cave, 0.25, (0.1, 0.1, 0.0))
    walls = load_world(save_grey(tmp_path / "walls.png", np.zeros((4, 4))), size=(1.0, 1.0))
    with pytest.raises(ValueError, match="no free place") as err:         # no start at all: the world's fault
        start_pose(tmp_path / "walls.png", walls, 0.25)
    assert not isinstance(err.value, StartError)


def scales(shared_data):
    with open(shared_data / "maps" / "map_scales.csv") as f:
        return {row["file"]: row for row in csv.DictReader(f)}


@pytest.mark.parametrize("name", ["cave.png", "simple_rooms.png"])
def test_shared_bitmaps_load_at_their_documented_scale(shared_data, name):
    row = scales(shared_data)[name]
    path = shared_data / "maps" / name
    size = (float(row["world_size_x_m"]), float(row["world_size_y_m"]))
    world = load_world(path, size=size)
    assert world.resolution == pytest.approx((float(row["m_per_px_x"]), float(row["m_per_px_y"])))
    assert world.shape == (int(row["height_px"]), int(row["width_px"]))
    # a known dark pixel (image row r, column c) lands where the frame says
    grey = np.asarray(Image.open(path).convert("L"))
    r, c = np.argwhere(grey < 128)[len(np.argwhere(grey < 128)) // 2]
    rx, ry = world.resolution
    xy = np.array([(c + 0.5) * rx, (grey.shape[0] - 1 - r + 0.5) * ry])
    assert world.is_occupied(xy)
    assert world.occupied.sum() == (grey < 128).sum()


def test_stage_cave_scaled_as_in_the_paper(shared_data):
    world = load_world(shared_data / "maps" / "cave.png", size=(20.0, 20.0))
    assert world.resolution == pytest.approx((0.04, 0.04))
    # the Stage cave has no outer wall: off the bitmap counts as occupied
    assert world.is_occupied(np.array([-0.01, 10.0])) and world.is_occupied(np.array([10.0, 20.01]))


def test_exported_map_reloads_with_its_known_and_unknown_areas(tmp_path):
    """export -> ROS map -> world: free cells stay free, occupied and unknown cells are not free
    (map_saver's 205 with free_thresh 0.196 is unknown; with 0.25 it read as free)."""
    from mapping.export import write_ros_map as export_ros_map

    rng = np.random.default_rng(0)
    prob = rng.choice([0.05, 0.5, 0.95, np.nan], size=(30, 40), p=[0.5, 0.3, 0.15, 0.05])
    truth = np.full(prob.shape, RosMap.UNKNOWN)
    truth[prob <= 0.25], truth[prob >= 0.65] = RosMap.FREE, RosMap.OCCUPIED
    origin, resolution = np.array([-3.05, 2.05]), 0.1                       # centre of cell (0, 0)
    yaml_path = export_ros_map(tmp_path / "map.pgm", prob, origin, resolution)
    meta = yaml.safe_load(yaml_path.read_text())
    assert (meta["mode"], meta["negate"], meta["occupied_thresh"], meta["free_thresh"]) == ("trinary", 0, 0.65, 0.196)
    ros = read_ros_map(yaml_path)
    np.testing.assert_array_equal(ros.state, truth)
    world = load_world(yaml_path)
    assert world.origin == pytest.approx((-3.1, 2.0)) and world.resolution == pytest.approx((0.1, 0.1))
    np.testing.assert_array_equal(world.occupied, truth != RosMap.FREE)
    assert world.occupied.sum() < prob.size and (truth == RosMap.UNKNOWN).sum() > 0
    # a point in an unknown cell is a wall of the world, one in a free cell is not
    iy, ix = np.argwhere(truth == RosMap.UNKNOWN)[0]
    assert world.is_occupied(np.array([-3.1 + (ix + 0.5) * 0.1, 2.0 + (iy + 0.5) * 0.1]))
    iy, ix = np.argwhere(truth == RosMap.FREE)[0]
    assert not world.is_occupied(np.array([-3.1 + (ix + 0.5) * 0.1, 2.0 + (iy + 0.5) * 0.1]))


@pytest.mark.parametrize("mode, negate, pixels, expected", [
    ("trinary", 0, [0, 205, 254, 255, 80, 100], [1, -1, 0, 0, 1, -1]),
    ("trinary", 1, [255, 50, 1, 0], [1, -1, 0, 0]),
    ("scale", 0, [0, 150, 254], [1, -1, 0]),
    ("raw", 0, [0, 10, 50, 100, 255], [0, 0, -1, 1, -1]),
])
def test_ros_map_reads_as_map_server(tmp_path, mode, negate, pixels, expected):
    path = write_ros_map(tmp_path, f"image: map.pgm\nresolution: 1\norigin: [0, 0, 0]\nmode: {mode}\n"
                         f"negate: {negate}\n", np.array([pixels]))
    np.testing.assert_array_equal(read_ros_map(path).state, [expected])
