"""The bad-input corpus: requests, websocket messages, hostile names, broken map files and broken
logs, each with the answer homebot must give. ``tests/test_api_edge.py`` runs it against a live server and
``tests/test_cli_bad_input.py`` against the CLI."""

from __future__ import annotations

import bz2
import gzip
from math import isqrt
from pathlib import Path

from app.core.config import Settings

GOOD_YAML = "image: {image}\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n" \
            "occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n"
GOOD_PGM = b"P5\n4 3\n255\n" + bytes([254] * 12)

#: (method, path, JSON body or None, status, reason)
BAD_REQUESTS = [
    ("POST", "/api/pose", {"x": 500.0, "y": 0.0}, 422, "outside_map"),
    ("POST", "/api/pose", {"x": True, "y": 1.0}, 422, "invalid_request"),
    ("POST", "/api/pose", {"x": "1", "y": 1.0}, 422, "invalid_request"),
    ("POST", "/api/pose", {"x": 1e300, "y": 0.0}, 422, "invalid_request"),
    ("POST", "/api/pose", {"x": 1.0, "y": 1.0, "yaw": 1e9}, 422, "invalid_request"),
    ("POST", "/api/places", {"name": "far", "x": 1e300, "y": 0.0}, 422, "invalid_request"),
    ("POST", "/api/places", {"name": "far", "x": 200.0, "y": 100.0}, 422, "outside_map"),
    ("POST", "/api/places", {"name": "a/b", "x": 1.0, "y": 1.0}, 422, "invalid_request"),
    ("POST", "/api/places", {"name": "x.png", "x": 1.0, "y": 1.0}, 422, "invalid_request"),
    ("POST", "/api/places", {"name": "v1.2", "x": 1.0, "y": 1.0}, 422, "invalid_request"),
    ("POST", "/api/places", {"name": "nul\u0000", "x": 1.0, "y": 1.0}, 422, "invalid_request"),
    ("POST", "/api/places", {"name": "ok", "x": 1.0, "y": 1.0, "extra": 1}, 422, "invalid_request"),
    ("POST", "/api/places", [1, 2], 422, "invalid_request"),
    ("PATCH", "/api/places/nowhere", {"x": 1.0}, 404, "not_found"),
    ("GET", "/api/places/..%5C..%5Ctoken", None, 404, "not_found"),
    ("GET", "/api/places/a%5Cb", None, 422, "invalid_request"),
    ("DELETE", "/api/maps/..%2F..%2Ftoken", None, 404, "not_found"),
    ("POST", "/api/goal", {"x": 1.0}, 422, "invalid_request"),
    ("POST", "/api/goal", {"x": "NaN", "y": 1.0}, 422, "invalid_request"),
    ("POST", "/api/goal", {"x": 1e300, "y": 0.0}, 422, "invalid_request"),
    ("POST", "/api/goal", {"x": 300.0, "y": 300.0}, 422, "goal_outside_map"),
    ("POST", "/api/goal", {"x": 1.0, "y": 2.0, "yaw": "north"}, 422, "invalid_request"),
    ("POST", "/api/goal", {"x": 1.0, "y": 2.0, "place": "kitchen"}, 422, "invalid_request"),
    ("POST", "/api/goal", {"place": "nowhere"}, 404, "not_found"),
    ("POST", "/api/goal", {"place": "nowhere", "yaw": 1.0}, 422, "invalid_request"),
    ("POST", "/api/places/nowhere/go", None, 404, "not_found"),
    ("POST", "/api/teleop", {"v": 9.0, "w": 0.0}, 422, "invalid_request"),
    ("POST", "/api/teleop", {"v": True, "w": 0.0}, 422, "invalid_request"),
    ("PUT", "/api/mode", {"mode": "flying"}, 422, "invalid_request"),
    ("PUT", "/api/mode", {"mode": "localization", "map": "nope"}, 404, "not_found"),
    ("PUT", "/api/mode", {"mode": "localization", "map": "../x"}, 422, "invalid_request"),
    ("POST", "/api/maps", {"name": ".hidden"}, 422, "invalid_request"),
    ("POST", "/api/maps", {"name": "x" * 65}, 422, "invalid_request"),
    ("POST", "/api/login", {"token": 5}, 422, "invalid_request"),
    ("DELETE", "/api/zones/99999999999999999999999", None, 422, "invalid_request"),  # beyond SQLite's
    ("PATCH", "/api/rooms/99999999999999999999999", {"name": "x"}, 422, "invalid_request"),
]

#: (websocket message text, the ``error`` reply's reason)
BAD_WS_MESSAGES = [
    ('{"type": "goal", "x": 1e300, "y": 0}', "invalid_request"),
    ('{"type": "goal", "x": "1", "y": 0}', "invalid_request"),
    ('{"type": "goal", "x": true, "y": 1}', "invalid_request"),
    ('{"type": "goal", "x": NaN, "y": 1}', "invalid_request"),
    ('{"type": "goal", "place": "../x"}', "invalid_request"),
    ('{"type": "goal", "place": "nowhere"}', "not_found"),
    ('{"type": "goal", "x": 300, "y": 300}', "goal_outside_map"),
    ('{"type": "goal", "x": 1, "y": 1, "bogus": 1}', "invalid_request"),
    ('{"type": "teleop", "v": 9, "w": 0}', "invalid_request"),
    ('{"type": "teleop"}', "invalid_request"),
    ('{"type": 5}', "invalid_request"),
    ("[1, 2]", "invalid_request"),
    ("not json", "invalid_request"),
    ("x" * 5000, "invalid_request"),
]

#: one more cell a side than the server's default map capacity (and under Pillow's bomb limit)
_OVER_CAPACITY = isqrt(Settings.model_fields["map_capacity_cells"].default) + 1

#: case -> (YAML text, image bytes, words the error must contain)
BAD_MAPS = {
    "inf_resolution": (GOOD_YAML.replace("0.05", ".inf"), GOOD_PGM, "resolution must be finite"),
    "nan_origin": (GOOD_YAML.replace("[0.0, 0.0, 0.0]", "[.nan, 0.0, 0.0]"), GOOD_PGM,
                   "origin must be finite"),
    "huge_origin": (GOOD_YAML.replace("[0.0, 0.0, 0.0]", "[1.0e+308, 0.0, 0.0]"), GOOD_PGM,
                    "origin farther"),
    "nan_threshold": (GOOD_YAML.replace("0.65", ".nan"), GOOD_PGM, "occupied_thresh must be finite"),
    "swapped_thresholds": (GOOD_YAML.replace("0.65", "0.1"), GOOD_PGM, "free_thresh < occupied_thresh"),
    "bomb": (GOOD_YAML, b"P5\n200000 200000\n255\n" + bytes(64), "too large"),
    "oversized": (GOOD_YAML, b"P5\n%d %d\n255\n" % (_OVER_CAPACITY, _OVER_CAPACITY) + bytes(64), "too large"),
    "truncated_image": (GOOD_YAML, b"P5\n100 100\n255\n" + bytes(10), "cannot read map image"),
    "not_an_image": (GOOD_YAML, b"hello, I am not a picture", "cannot read map image"),
    "binary_yaml": ("\x00\x01\x02\xff", GOOD_PGM, "cannot read map YAML"),
    "list_yaml": ("- a\n- b\n", GOOD_PGM, "must be a mapping"),
    "string_resolution": (GOOD_YAML.replace("0.05", "'0.05'"), GOOD_PGM, "must be numbers"),
}


def write_bad_map(directory: Path, name: str, case: str) -> str:
    """Write ``NAME.yaml`` and ``NAME.pgm`` of a broken map; returns what its error must say."""
    text, image, problem = BAD_MAPS[case]
    directory.mkdir(parents=True, exist_ok=True)
    (directory / f"{name}.yaml").write_bytes(text.format(image=f"{name}.pgm").encode("latin-1"))
    (directory / f"{name}.pgm").write_bytes(image)
    return problem


GOOD_LOG_LINES = (
    "ODOM 0.0 0.0 0.0 0 0 0 0.0 robot 0.0\n"
    "FLASER 3 1.0 1.0 1.0 0.0 0.0 0.0 0.0 0.0 0.0 0.1 robot 0.1\n"
)

#: case -> (file name, file bytes (None: a directory), words the error must contain)
BAD_LOGS = {
    "binary": ("binary.clf", bytes(range(256)) * 8, "binary.clf:1"),
    "empty": ("empty.clf", b"", "empty.clf"),
    "truncated_gz": ("cut.clf.gz", gzip.compress(GOOD_LOG_LINES.encode() * 50)[:40], "cut.clf.gz"),
    "truncated_bz2": ("cut.clf.bz2", bz2.compress(GOOD_LOG_LINES.encode() * 50)[:40], "cut.clf.bz2"),
    "garbage_line": ("garbage.clf", b"FLASER -5 1 2\n",
                     "garbage.clf:1: FLASER beam count must be at least 1"),
    "nan_pose": ("nan.clf", GOOD_LOG_LINES.replace("0.0 0.0 0.0 0.0 0.0 0.0", "nan 0.0 0.0 nan 0.0 0.0")
                 .encode(), "nan.clf:2"),
    "huge_pose": ("huge.clf", GOOD_LOG_LINES.replace("0.0 0.0 0.0 0.0 0.0 0.0", "1e300 0.0 0.0 1e300 0.0 0.0")
                  .encode(), "huge.clf:2"),
    "directory": ("a_directory", None, "a_directory"),
}


def write_bad_log(directory: Path, case: str) -> tuple[Path, str]:
    """Write one broken log; returns its path and what its error must say."""
    name, data, expected = BAD_LOGS[case]
    path = directory / name
    if data is None:
        path.mkdir()
    else:
        path.write_bytes(data)
    return path, expected


#: case -> (SLAM config file bytes (``--config``), words the error must contain)
BAD_CONFIGS = {
    "binary": (bytes(range(256)), "config.json: not a SLAM config"),
    "not_json": (b"{particles: 8", "config.json: not a SLAM config"),
    "list": (b"[1, 2]", "must be a JSON object"),
    "unknown_key": (b'{"particles": 8, "no_such_setting": 1}', "unknown key no_such_setting"),
    "string_number": (b'{"particles": "many"}', "particles must be an integer"),
    "nan": (b'{"resolution": NaN}', "resolution must be a number"),
    "huge": (b'{"matcher": {"max_range": 1e300}}', "matcher.max_range must be a number"),
    "infinite_count": (b'{"particles": 1e999}', "particles must be an integer"),
    "tiny_resolution": (b'{"resolution": 1e-9}', "resolution in"),
    "boolean_as_number": (b'{"loop_closure": {"enabled": 1}}', "loop_closure.enabled must be true or false"),
}

SIMULATED_ROBOT = Path(__file__).resolve().parents[1] / "slam_core" / "robots" / "simulated.yaml"

#: case -> (robot file bytes (``--robot``), words the error must contain)
BAD_ROBOTS = {
    "binary": (bytes(range(256)), "robot.yaml: not a text file"),
    "nan": (SIMULATED_ROBOT.read_bytes().replace(b"wheel_base: 0.23", b"wheel_base: .nan"),
            "wheels.wheel_base must be finite"),
    "huge": (SIMULATED_ROBOT.read_bytes().replace(b"beams: 360", b"beams: 1000000000000"),
             "laser.beams must be finite and within"),
    "far_mount": (SIMULATED_ROBOT.read_bytes().replace(b"{x: 0.0,", b"{x: 1.0e+300,"),
                  "laser.mount.x must be finite and within"),
    "mount_off_the_robot": (SIMULATED_ROBOT.read_bytes().replace(b"{x: 0.0,", b"{x: 50.0,"),
                            "more than 10 m from the robot's centre"),
}

SHIPPED_WORLD = Path(__file__).resolve().parents[1] / "slam_core" / "sim" / "worlds" / "flat.txt"

#: case -> (world file text (``homebot sim record``), words the error must contain)
BAD_WORLDS = {
    "huge_wall": (SHIPPED_WORLD.read_text().replace("room kitchen   0.0 0.0 4.0 3.0",
                                                    "room kitchen   0.0 0.0 4.0e300 3.0"),
                  "world.txt:8: room corners (x0 y0 x1 y1): 4.0e300 is beyond"),
    "huge_start": (SHIPPED_WORLD.read_text().replace("start   1.0 3.75 0", "start   1e300 3.75 0"),
                   "world.txt:5: start (x y theta_degrees): 1e300 is beyond"),
    "start_outside": (SHIPPED_WORLD.read_text().replace("start   1.0 3.75 0", "start   9000 3.75 0"),
                      "world.txt:5: start (9000, 3.75) lies outside the walls"),
    "nan": (SHIPPED_WORLD.read_text().replace("door 2.5 3.0 3.3 3.0", "door 2.5 nan 3.3 3.0"),
            "is not a finite number"),
}
