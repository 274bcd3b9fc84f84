"""Places and saved maps survive a server restart; shutdown saves the map as PGM + YAML + PNG."""

from __future__ import annotations

import yaml

from tests.live_server import LiveServer


def test_places_maps_and_token_persist_and_shutdown_saves_the_map(tmp_path):
    data = tmp_path / "data"
    server = LiveServer(data).start()
    try:
        token = server.token
        with server.client() as c:
            assert c.post("/api/places", json={"name": "kitchen", "x": 2.0, "y": 1.5}).status_code == 201
            sofa = {"name": "sofa", "x": 8.0, "y": 6.5, "yaw": 1.0}
            assert c.post("/api/places", json=sofa).status_code == 201
            assert c.post("/api/places", json={"name": "sofa", "x": 0, "y": 0}).status_code == 409
            r = c.patch("/api/places/sofa", json={"name": "couch"})
            assert r.status_code == 200 and r.json() == {"name": "couch", "x": 8.0, "y": 6.5, "yaw": 1.0}
            assert c.delete("/api/places/kitchen").status_code == 204
            assert c.delete("/api/places/kitchen").status_code == 404
            r = c.post("/api/maps", json={"name": "home 1"})
            assert r.status_code == 201, r.text
            assert c.post("/api/maps", json={"name": "home 1"}).status_code == 409
            assert c.get("/api/maps/home 1.png").content[:4] == b"\x89PNG"
            assert c.post("/api/maps", json={"name": "scratch"}).status_code == 201
            assert c.delete("/api/maps/scratch").status_code == 204
            pgm = c.get("/api/map.pgm")
            assert pgm.status_code == 200 and pgm.content[:2] == b"P5"
            meta = yaml.safe_load(c.get("/api/map.yaml").text)
            assert meta["resolution"] == 0.05 and meta["image"] == "map.pgm"
        assert not (data / "maps" / "scratch.pgm").exists()
        assert (data / "maps" / "home 1.pgm").exists()
    finally:
        assert server.stop() in (0, -15), server.output  # uvicorn re-raises SIGTERM after a clean exit
    for suffix in (".pgm", ".yaml", ".png"):
        assert (data / f"last_map{suffix}").stat().st_size > 0, suffix

    again = LiveServer(data).start()
    try:
        assert again.token == token
        with again.client() as c:
            assert c.get("/api/places").json() == [{"name": "couch", "x": 8.0, "y": 6.5, "yaw": 1.0}]
            assert [m["name"] for m in c.get("/api/maps").json()] == ["home 1"]
            status = c.get("/api/status").json()
            assert status["worker"]["restarts"] == 0 and status["map"]["width"] > 0
    finally:
        again.stop()
    assert "first start" not in again.output
