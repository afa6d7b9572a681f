"""rtu.motion with the user's rays and shutter times against `rtusim motion --rays --times --out`: the same hits,
bit for bit, and the same cycles; bad times are refused with rtu.Error."""

import json
import os
import subprocess

import numpy as np
import pytest

import rtu

RTUSIM = os.environ.get("RTUSIM", os.path.join(os.path.dirname(__file__), "../../build/default/rtusim"))


def test_motion_rays_equal_the_cli(tmp_path):
    scene = rtu.load_scene("builtin:cornell")
    rays = rtu.rays(scene, "incoherent:2000", seed=3)
    times = np.random.default_rng(4).random(len(rays)).astype(np.float32)
    rtu.write_rays(tmp_path / "r.rays", rays)
    times.tofile(tmp_path / "t.f32")
    p = subprocess.run([RTUSIM, "motion", "--scene", "builtin:cornell", "--move", "0.2", "0", "0", "--rays",
                        tmp_path / "r.rays", "--times", tmp_path / "t.f32", "--out", tmp_path / "h.hits",
                        "--json", tmp_path / "m.json"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    f, x, figures, hits = rtu.motion(scene, move=(0.2, 0, 0), rays=rays, times=times)
    assert f is None and x is None and hits.dtype == rtu.HIT_DTYPE and len(hits) == len(rays)
    assert hits.tobytes() == (tmp_path / "h.hits").read_bytes()
    s = json.loads((tmp_path / "m.json").read_text())
    assert [d["cycles"] for d in figures["designs"]] == [d["cycles"] for d in s["designs"]]
    assert (hits["prim"] != rtu.MISS).sum() > len(rays) // 2
    with pytest.raises(rtu.Error, match="go together"):
        rtu.motion(scene, move=(0.2, 0, 0), rays=rays)
    with pytest.raises(rtu.Error, match="not in"):
        rtu.motion(scene, move=(0.2, 0, 0), rays=rays, times=times + 1.5)
    with pytest.raises(rtu.Error, match="one a ray"):
        rtu.motion(scene, move=(0.2, 0, 0), rays=rays, times=times[:10])


def test_motion_instances_equal_the_cli(tmp_path):
    p = subprocess.run([RTUSIM, "motion", "--instances", "--level", "2", "--width", "24", "--height", "16",
                        "--samples", "1", "--image", tmp_path / "mi", "--json", tmp_path / "m.json"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    f, x, figures = rtu.motion(instances=True, level=2, width=24, height=16, samples=1)
    s = json.loads((tmp_path / "m.json").read_text())
    assert figures["moving_instances"] == s["moving_instances"] == 8
    assert [d["cycles"] for d in figures["designs"]] == [d["cycles"] for d in s["designs"]]
    assert np.array_equal(x, rtu.read_png(tmp_path / "mi_fixed.png"))
    with pytest.raises(rtu.Error, match="scene=None"):
        rtu.motion(rtu.load_scene("builtin:cornell"), instances=True)
