"""rtu.trace(packet_rays=N) against `rtusim trace --packet-rays N`: the same packets and cycles; the hits do not
depend on the packet size; sizes outside 1..2^30 are refused with rtu.Error."""

import json
import os
import subprocess

import pytest

import rtu

RTUSIM = os.environ.get("RTUSIM", os.path.join(os.path.dirname(__file__), "../../build/default/rtusim"))


def test_packet_rays_equal_the_cli(tmp_path):
    scene = rtu.load_scene("builtin:cornell")
    rays = rtu.rays(scene, "incoherent:3000", seed=5)
    rtu.write_rays(tmp_path / "r.rays", rays)
    p = subprocess.run([RTUSIM, "trace", "--scene", "builtin:cornell", "--rays", tmp_path / "r.rays", "--device",
                        "timed", "--packet-rays", "700", "--stats", tmp_path / "s.json"], capture_output=True,
                       text=True)
    assert p.returncode == 0, p.stderr
    cli = json.loads((tmp_path / "s.json").read_text())
    small = rtu.trace(scene, rays, "timed", packet_rays=700)
    whole = rtu.trace(scene, rays, "timed")
    assert small.stats["packet_rays"] == 700 and whole.stats["packet_rays"] == 262144
    assert small.stats["timing"]["packets"] == cli["timing"]["packets"] == 5  # 3000 rays: 4 x 700 and 200
    assert small.stats["timing"]["cycles"] == cli["timing"]["cycles"]
    assert whole.stats["timing"]["packets"] == 1
    assert small.hits.tobytes() == whole.hits.tobytes()
    for bad in (0, -1, 2**30 + 1):
        with pytest.raises(rtu.Error, match="packet_rays"):
            rtu.trace(scene, rays, "fixed", packet_rays=bad)
