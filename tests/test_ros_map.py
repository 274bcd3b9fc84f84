"""ROS map_server / Nav2 maps: homebot -> Nav2 and Nav2 -> homebot, including the vertical flip."""

import numpy as np
import pytest
import yaml
from PIL import Image

from slam_core.io.render import save_png
from slam_core.io.ros_map import MapFileError, load_map, save_map
from slam_core.occupancy_grid import OccupancyGrid, logit

#: The keys nav2_map_server's map_io reads from a map YAML.
NAV2_KEYS = {"image", "mode", "resolution", "origin", "negate", "occupied_thresh", "free_thresh"}


def small_grid():
    g = OccupancyGrid(0.5, origin=(-3.0, 2.0), shape=(4, 3))
    g.data[3, 0] = logit(0.9)     # high y, left: occupied
    g.data[0, 2] = logit(0.1)     # low y, right: free
    g.data[1, 1] = logit(0.6)     # in between: unknown
    g.data[2, 2] = logit(0.99)
    return g


def test_save_writes_trinary_pgm_with_high_y_at_the_top(tmp_path):
    pgm, yml = save_map(small_grid(), tmp_path / "sub" / "map")
    assert (pgm.name, yml.name) == ("map.pgm", "map.yaml")
    with Image.open(pgm) as img:
        assert img.format == "PPM" and img.mode == "L"      # PIL reads PGM as its PPM family
        pixels = np.asarray(img)
    assert pgm.read_bytes().startswith(b"P5")
    assert pixels.shape == (4, 3)
    expected = np.full((4, 3), 205)
    expected[0, 0] = 0            # data[3, 0] -> top row
    expected[3, 2] = 254          # data[0, 2] -> bottom row
    expected[1, 2] = 0            # data[2, 2]
    assert pixels.tolist() == expected.tolist()


def test_yaml_has_exactly_the_nav2_keys(tmp_path):
    _, yml = save_map(small_grid(), tmp_path / "map")
    meta = yaml.safe_load(yml.read_text())
    assert set(meta) == NAV2_KEYS
    assert meta == {"image": "map.pgm", "mode": "trinary", "resolution": 0.5, "origin": [-3.0, 2.0, 0.0],
                    "negate": 0, "occupied_thresh": 0.65, "free_thresh": 0.196}
    assert isinstance(meta["negate"], int)


def test_round_trip(tmp_path):
    g = small_grid()
    _, yml = save_map(g, tmp_path / "map")
    back = load_map(yml)
    assert back.resolution == g.resolution and back.origin.tolist() == g.origin.tolist()
    assert back.shape == g.shape
    assert back.trinary().tolist() == g.trinary().tolist()
    assert back.trinary()[3, 0] == 100 and back.trinary()[0, 2] == 0
    assert back.data[3, 0] == np.float32(back.model.l_max) and back.data[0, 2] == np.float32(back.model.l_min)
    assert back.data[1, 1] == 0.0


def test_round_trip_of_a_mapped_grid(tmp_path):
    rng = np.random.default_rng(7)
    g = OccupancyGrid(0.05, origin=(-1.6, -3.2), shape=(40, 64))
    g.data[:] = rng.normal(0, 2, g.shape)
    _, yml = save_map(g, tmp_path / "m")
    back = load_map(yml)
    assert np.array_equal(back.trinary(), g.trinary())
    assert np.allclose(back.origin, g.origin)


def write_nav2(tmp_path, pixels, negate=0, mode="trinary", name="nav2.pgm", extra=""):
    Image.fromarray(np.asarray(pixels, np.uint8)).save(tmp_path / name)
    yml = tmp_path / "nav2.yaml"
    yml.write_text(f"image: {name}\nresolution: 0.5\norigin: [-10.0, -5.0, 0.0]\nnegate: {negate}\n"
                   f"occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: {mode}\n{extra}")
    return yml


# A 3 x 4 image: row 0 is the top (largest y).
IMAGE = [[0, 254, 205, 254],
         [254, 254, 254, 0],
         [205, 100, 170, 60]]


def cell_at(grid, x, y):
    ix, iy = grid.world_to_cell([x, y])
    return grid.trinary()[iy, ix]


@pytest.mark.parametrize("name", ["nav2.pgm", "nav2.png"])
def test_nav2_map_loads_at_the_right_world_coordinates(tmp_path, name):
    g = load_map(write_nav2(tmp_path, IMAGE, name=name))
    assert g.shape == (3, 4) and g.origin.tolist() == [-10.0, -5.0]
    # Pixel (row 0, col 0) covers x in [-10, -9.5], y in [-4, -3.5] (the top row).
    assert cell_at(g, -9.75, -3.75) == 100
    assert cell_at(g, -9.25, -3.75) == 0
    assert cell_at(g, -8.75, -3.75) == -1
    assert cell_at(g, -8.25, -4.25) == 100       # row 1, col 3
    assert cell_at(g, -9.75, -4.75) == -1        # bottom-left pixel sits at the origin
    # p = (255 - v) / 255: 100 -> 0.61 unknown, 170 -> 0.33 unknown, 60 -> 0.76 occupied.
    assert g.trinary()[0].tolist() == [-1, -1, -1, 100]


def test_nav2_negate(tmp_path):
    g = load_map(write_nav2(tmp_path, IMAGE, negate=1))
    # p = v / 255: 0 -> free, 254 -> occupied, 205 -> 0.80 occupied, 100 -> 0.39 and 60 -> 0.24 unknown.
    assert g.trinary()[::-1].tolist() == [[0, 100, 100, 100],
                                          [100, 100, 100, 0],
                                          [100, -1, 100, -1]]


def test_nav2_scale_mode_keeps_in_between_probabilities(tmp_path):
    g = load_map(write_nav2(tmp_path, IMAGE, mode="scale"))
    p = g.probability()[::-1]
    assert p[2, 1] == pytest.approx(155 / 255, abs=1e-6)
    assert p[2, 2] == pytest.approx(85 / 255, abs=1e-6)
    assert p[0, 2] == pytest.approx(50 / 255, abs=1e-6)
    assert g.trinary()[::-1][0].tolist() == [100, 0, -1, 0]


def test_raw_mode_values_above_100_are_unknown(tmp_path):
    g = load_map(write_nav2(tmp_path, [[0, 100, 255, 50]], mode="raw"))
    assert g.trinary().tolist() == [[0, 100, -1, -1]]


def test_rgb_image_is_read_as_grey(tmp_path):
    rgb = np.stack([np.asarray(IMAGE, np.uint8)] * 3, axis=-1)
    Image.fromarray(rgb, "RGB").save(tmp_path / "c.png")
    yml = tmp_path / "c.yaml"
    yml.write_text("image: c.png\nresolution: 0.5\norigin: [-10.0, -5.0, 0.0]\nnegate: 0\n"
                   "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    assert np.array_equal(load_map(yml).trinary(), load_map(write_nav2(tmp_path, IMAGE)).trinary())


def test_absolute_image_path(tmp_path):
    (tmp_path / "maps").mkdir()
    Image.fromarray(np.asarray(IMAGE, np.uint8)).save(tmp_path / "maps" / "x.pgm")
    yml = tmp_path / "x.yaml"
    yml.write_text(f"image: {tmp_path / 'maps' / 'x.pgm'}\nresolution: 0.5\norigin: [0, 0, 0]\n")
    assert load_map(yml).shape == (3, 4)


@pytest.mark.parametrize("yaml_text, message", [
    ("resolution: 0.5\norigin: [0, 0, 0]\n", "missing key 'image'"),
    ("image: nav2.pgm\norigin: [0, 0, 0]\n", "missing key 'resolution'"),
    ("image: nav2.pgm\nresolution: 0.5\n", "missing key 'origin'"),
    ("image: nav2.pgm\nresolution: 0.5\norigin: [0, 0, 0.5]\n", "rotated map origins"),
    ("image: nav2.pgm\nresolution: 0.5\norigin: [0, 0]\n", "origin [x, y, yaw]"),
    ("image: nav2.pgm\nresolution: 0\norigin: [0, 0, 0]\n", "resolution > 0"),
    ("image: nav2.pgm\nresolution: fine\norigin: [0, 0, 0]\n", "must be numbers"),
    ("image: nav2.pgm\nresolution: 0.5\norigin: 3\n", "must be numbers"),
    ("image: nav2.pgm\nresolution: 0.5\norigin: [0, 0, 0]\nmode: fancy\n", "unknown mode 'fancy'"),
    ("- just\n- a list\n", "must be a mapping"),
    ("image: [unclosed\n", "cannot read map YAML"),
])
def test_bad_yaml_gives_a_clear_error(tmp_path, yaml_text, message):
    Image.fromarray(np.asarray(IMAGE, np.uint8)).save(tmp_path / "nav2.pgm")
    yml = tmp_path / "bad.yaml"
    yml.write_text(yaml_text)
    with pytest.raises(MapFileError, match=r"bad\.yaml") as info:
        load_map(yml)
    assert message in str(info.value)


def test_missing_image_and_missing_yaml(tmp_path):
    yml = tmp_path / "m.yaml"
    yml.write_text("image: gone.pgm\nresolution: 0.5\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match=r"gone\.pgm: cannot read map image"):
        load_map(yml)
    with pytest.raises(MapFileError, match=r"nothere\.yaml: cannot read map YAML"):
        load_map(tmp_path / "nothere.yaml")
    (tmp_path / "junk.pgm").write_bytes(b"not an image")
    yml.write_text("image: junk.pgm\nresolution: 0.5\norigin: [0, 0, 0]\n")
    with pytest.raises(MapFileError, match=r"junk\.pgm: cannot read map image"):
        load_map(yml)


def test_png_rendering_is_flipped_like_the_pgm(tmp_path):
    g = OccupancyGrid(1.0, shape=(10, 20))
    g.data[9, 0] = logit(0.97)                      # top-left in the picture
    g.data[0, 19] = logit(0.12)                     # bottom-right
    track = np.array([[5.5, 8.5, 0.0], [15.5, 8.5, 0.0]])
    path = save_png(g, tmp_path / "m.png", trajectory=track)
    with Image.open(path) as img:
        rgb = np.asarray(img.convert("RGB")).astype(int)
    assert rgb.shape == (10, 20, 3)
    assert rgb[0, 0].tolist() == [8, 8, 8]          # 255 * (1 - 0.97), rounded
    assert rgb[9, 19].tolist() == [224, 224, 224]   # 255 * (1 - 0.12)
    assert rgb[5, 10].tolist() == [128, 128, 128]   # unknown
    assert rgb[1, 10].tolist() == [220, 30, 30]     # the red track, high y at the top
