"""The Python module rtu against rtusim on the same inputs: the same rays, hits, cycles, statistics, images, sweep
rows and plans; and its bad input (rtu.Error with the CLI's message, never a crash). ctest runs it (label python)
with PYTHONPATH at the build's python/ folder and RTUSIM naming the rtusim of the same build."""

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
import warnings

import numpy as np
import pandas as pd
import pytest

import rtu

RTUSIM = os.environ.get("RTUSIM", os.path.join(os.path.dirname(__file__), "../../build/default/rtusim"))
SCENES = os.path.join(os.path.dirname(__file__), "../../scenes")
SEED = "builtin:seed"


def cli(*args, ok=True):
    """Runs rtusim; returns the completed process (asserting its exit status 0 when ok)."""
    p = subprocess.run([RTUSIM, *map(str, args)], capture_output=True, text=True)
    if ok:
        assert p.returncode == 0, p.stderr
    return p


def cli_error(*args):
    """rtusim's error message for bad input: exit status 2, "rtusim: error: MESSAGE"."""
    p = cli(*args, ok=False)
    assert p.returncode == 2, (p.returncode, p.stdout, p.stderr)
    line = [x for x in p.stderr.splitlines() if x.startswith("rtusim: error: ")]
    assert line, p.stderr
    return line[-1][len("rtusim: error: "):]


@pytest.fixture(scope="module")
def seed():
    return rtu.load_scene(SEED)


@pytest.fixture(scope="module")
def ray_file(tmp_path_factory, seed):
    """Primary and incoherent rays of the seed scene in one ray file (written by the module, read by rtusim)."""
    path = tmp_path_factory.mktemp("rays") / "r.rays"
    rays = np.concatenate([rtu.rays(seed, "primary:80x60"), rtu.rays(seed, "incoherent:3000", seed=5)])
    rtu.write_rays(path, rays)
    return path, rays


def test_rays_equal_the_cli(tmp_path, seed):
    cli("rays", "--scene", SEED, "--width", 64, "--height", 48, "--out", tmp_path / "p.rays")
    cli("rays", "--scene", SEED, "--kind", "incoherent", "--count", 1000, "--seed", 7, "--out", tmp_path / "i.rays")
    p = rtu.rays(seed, "primary:64x48")
    i = rtu.rays(seed, "incoherent:1000", seed=7)
    assert p.shape == (64 * 48, 8) and p.dtype == np.float32
    assert p.tobytes() == (tmp_path / "p.rays").read_bytes()
    assert i.tobytes() == (tmp_path / "i.rays").read_bytes()
    assert np.array_equal(rtu.read_rays(tmp_path / "i.rays"), i)


@pytest.mark.parametrize("device", ["float", "fixed"])
def test_trace_equals_the_cli(tmp_path, seed, ray_file, device):
    path, rays = ray_file
    cli("trace", "--scene", SEED, "--rays", path, "--device", device, "--out", tmp_path / "h.hits",
        "--stats", tmp_path / "s.json", "--threads", 2)
    r = rtu.trace(seed, rays, device, threads=2)
    assert r.hits.dtype == rtu.HIT_DTYPE and len(r.hits) == len(rays)
    assert r.hits.tobytes() == (tmp_path / "h.hits").read_bytes()  # the same hits, bit for bit
    s = json.loads((tmp_path / "s.json").read_text())
    for key in ("rays", "hits", "nodes_visited", "box_tests", "prim_tests", "invalid_rays"):
        assert r.stats[key] == s[key], key
    assert 0 < r.stats["hits"] < len(rays)
    assert r.cycles is None
    assert np.array_equal(rtu.read_hits(tmp_path / "h.hits"), r.hits)


@pytest.mark.parametrize("device", ["float", "fixed", "timed"])
def test_all_hits_equal_the_cli(tmp_path, seed, ray_file, device):
    path, rays = ray_file
    for out in ("l.bin", "l.csv"):
        cli("trace", "--scene", SEED, "--rays", path, "--device", device, "--all-hits", 3, "--out", tmp_path / out,
            "--stats", tmp_path / "s.json")
    r, n = rtu.trace(seed, rays, device, all_hits=3), len(rays)
    assert r.hits.shape == (n, 3) and r.hits.dtype == rtu.HIT_DTYPE and r.counts.shape == (n,)
    # The binary file: per ray a 16-byte header (count, kept, flags, 0) and 3 hit records, as the device writes.
    raw = np.frombuffer((tmp_path / "l.bin").read_bytes(), dtype=np.uint8).reshape(n, 4 * 16)
    header = raw[:, :16].copy().view(np.uint32)
    kept = np.minimum(r.counts, 3)
    assert np.array_equal(header, np.stack([r.counts, kept, r.counts > 3, 0 * kept], axis=1).astype(np.uint32))
    assert raw[:, 16:].tobytes() == r.hits.tobytes()  # kept hits, then misses
    assert np.all(r.hits["prim"][np.arange(3)[None, :] >= kept[:, None]] == rtu.MISS)
    # The CSV: a row per kept hit, one for a ray with none; the same primitives.
    csv = pd.read_csv(tmp_path / "l.csv")
    rows = csv.dropna(subset=["hit"])
    assert len(rows) == kept.sum() and len(csv) == kept.sum() + (kept == 0).sum()
    assert np.array_equal(rows["prim"].to_numpy(np.uint32), r.hits["prim"][np.arange(3)[None, :] < kept[:, None]])
    s = json.loads((tmp_path / "s.json").read_text())
    assert s["mode"] == "all_hits" and r.stats["all_hits"] == s["all_hits"]
    assert s["all_hits"]["found"] == r.counts.sum() > n // 4 and s["all_hits"]["rays_overflowed"] > 0
    # The closest hit is the nearest of each ray's list when nothing overflowed.
    full = rtu.trace(seed, rays, device, all_hits=64)
    t = np.where(full.hits["prim"] == rtu.MISS, np.inf, full.hits["t"]).min(axis=1)
    assert (full.counts <= 64).all() and np.array_equal(t, rtu.trace(seed, rays, device).hits["t"])
    with pytest.raises(rtu.Error, match="at most 256|not in 0..256"):
        rtu.trace(seed, rays, device, all_hits=257)
    p = cli("trace", "--scene", SEED, "--rays", path, "--all-hits", 2, "--any-hit", ok=False)
    assert p.returncode == 2 and "--all-hits is not with --any-hit" in p.stderr


def test_ab_equals_the_cli(tmp_path, seed, ray_file):
    path, rays = ray_file
    cli("trace", "--scene", SEED, "--rays", path, "--device", "timed", "--config", "rdna4", "--against-set",
        "box_units=2", "--against-format", "compact", "--stats", tmp_path / "s.json")
    want = json.loads((tmp_path / "s.json").read_text())["ab"]
    got = rtu.ab(seed, rays, a={"config": "rdna4"}, b={"config": "rdna4", "set": {"box_units": 2},
                                                        "format": "compact"})
    # The same design points, so the same figures as the CLI's, and each side's full statistics beside them.
    for key in ("speedup", "area_ratio", "energy_ratio", "perf_per_area_ratio", "hits_differ", "t_differ", "verdict"):
        assert got[key] == want[key], key
    assert got["a"]["cycles"] == got["a_stats"]["timing"]["cycles"] == want["a"]["cycles"]
    assert got["b"]["label"] == want["b"]["label"] == "rdna4 + box_units=2, format compact"
    with pytest.raises(rtu.Error, match="device"):
        rtu.ab(seed, rays, a={"device": "fixed"})
    with pytest.raises(rtu.Error, match="expected a dict"):
        rtu.ab(seed, rays, b="rdna4")


def test_timed_cycles_equal_the_cli(tmp_path, seed, ray_file):
    path, rays = ray_file
    cli("trace", "--scene", SEED, "--rays", path, "--device", "timed", "--config", "intel", "--set", "cache_kib=64",
        "--set", "ray_slots=16", "--out", tmp_path / "h.hits", "--stats", tmp_path / "s.json")
    s = json.loads((tmp_path / "s.json").read_text())
    # Three spellings of one configuration: the same hits and cycles as the CLI's.
    for kw in ({"config": {"preset": "intel", "cache_kib": 64, "ray_slots": 16}},
               {"config": "intel", "set": {"cache_kib": 64, "ray_slots": 16}},
               {"config": "intel", "set": ["cache_kib=64", "ray_slots=16"]}):
        r = rtu.trace(seed, rays, "timed", **kw)
        assert r.hits.tobytes() == (tmp_path / "h.hits").read_bytes()
        assert r.cycles == s["timing"]["cycles"] > 0
        assert r.stats["timing"]["config"] == s["timing"]["config"]
    # Another configuration: other cycles, the same hits (timing does not change the datapath).
    other = rtu.trace(seed, rays, "timed", config="intel", set={"cache_kib": 64, "ray_slots": 4})
    assert other.cycles != r.cycles and np.array_equal(other.hits, r.hits)


def test_sampled_cycles_equal_the_cli(tmp_path, seed, ray_file):
    path, rays = ray_file
    cli("trace", "--scene", SEED, "--rays", path, "--device", "timed", "--sample", 0.25, "--sample-unit", 64,
        "--sample-seed", 3, "--stats", tmp_path / "s.json")
    s = json.loads((tmp_path / "s.json").read_text())
    r = rtu.trace(seed, rays, "timed", sample=0.25, sample_unit=64, sample_seed=3, hits=False)
    assert r.cycles == s["timing"]["cycles"]
    assert r.stats["timing"]["sample"] == s["timing"]["sample"]
    assert s["timing"]["sample"]["packets_sampled"] > 0


def test_rays_in_any_float_layout(seed, ray_file):
    _, rays = ray_file
    ref = rtu.trace(seed, rays, "fixed").hits
    # float64 and a strided view are converted once; the hits are the float32 array's.
    assert np.array_equal(rtu.trace(seed, rays.astype(np.float64), "fixed").hits, ref)
    assert np.array_equal(rtu.trace(seed, rays[::3], "fixed").hits, ref[::3])
    # make_rays builds the same array from its columns; hits arrays own their memory.
    again = rtu.make_rays(rays[:, 0:3], rays[:, 4:7], rays[:, 3], rays[:, 7])
    assert again.tobytes() == rays.tobytes()
    assert ref.flags.writeable and ref.base is not None


def test_scene_dict_equals_the_file(seed):
    path = os.path.join(SCENES, "example.json")
    with open(path) as f:
        d = json.load(f)
    a = rtu.load_scene(path)
    b = rtu.load_scene(d, base_dir=SCENES)
    assert (a.triangles, a.spheres, a.planes) == (b.triangles, b.spheres, b.planes) and a.primitives > 0
    rays = rtu.rays(a, "incoherent:2000", seed=3)
    assert np.array_equal(rtu.trace(a, rays, "fixed").hits, rtu.trace(b, rays, "fixed").hits)
    assert b.name == "scene dict" and a.camera == b.camera


def test_curves_trace_on_every_device_as_the_cli(tmp_path):
    hair = rtu.load_scene("builtin:hair?strands=500")
    assert hair.curves == 4000 and hair.spheres == 0
    rays = rtu.rays(hair, "primary:3000")
    fixed = rtu.trace(hair, rays, "fixed").hits
    assert np.array_equal(rtu.trace(hair, rays, "timed", config="rdna4-lss").hits, fixed)
    path = tmp_path / "rays.bin"
    rays.tofile(path)
    out = tmp_path / "hits.bin"
    cli("trace", "--scene", "builtin:hair?strands=500", "--rays", path, "--device", "fixed", "--out", out)
    assert np.fromfile(out, dtype=fixed.dtype).tobytes() == fixed.tobytes()
    d = {"curves": [{"points": [[0, 0, 0], [0, 1, 0]], "radius": 0.2}]}
    assert rtu.load_scene(d).curves == 1


def test_malformed_scene_dict_has_the_cli_message(tmp_path):
    bad = {"spheres": [{"center": [0, 0, 0], "radius": -1.0}], "colour": 1}
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(bad))
    message = cli_error("info", "--scene", f)
    with pytest.raises(rtu.Error) as e:
        rtu.load_scene(bad)
    assert str(e.value) == message.replace(str(f), "scene dict")
    with pytest.raises(rtu.Error, match="not JSON"):
        rtu.load_scene({"spheres": [{"center": [0, 0, object()]}]})


def test_errors_have_the_cli_messages(seed, ray_file):
    path, rays = ray_file
    assert issubclass(rtu.Error, RuntimeError) and issubclass(rtu.Error, ValueError)
    message = cli_error("trace", "--scene", SEED, "--rays", path, "--out", "/dev/null", "--device", "timed",
                        "--set", "no_such_key=3")
    with pytest.raises(rtu.Error) as e:
        rtu.trace(seed, rays, "timed", set={"no_such_key": 3})
    assert str(e.value) == message
    message = cli_error("trace", "--scene", SEED, "--rays", path, "--out", "/dev/null", "--device", "timed",
                        "--set", "ray_slots=0")
    with pytest.raises(rtu.Error) as e:
        rtu.trace(seed, rays, "timed", config={"ray_slots": 0})
    assert str(e.value) == message
    message = cli_error("trace", "--scene", "no/such/file.json", "--rays", path, "--out", "/dev/null")
    with pytest.raises(rtu.Error) as e:
        rtu.load_scene("no/such/file.json")
    assert str(e.value) == message


def test_bad_input_raises(seed, ray_file):
    _, rays = ray_file
    for bad, match in ((rays[:, :7], r"shape \(N, 8\).*\(7800, 7\)"), (np.zeros((4, 8), np.int32), "float array"),
                       (rays[0], r"shape \(N, 8\)"), ("no such spec", "no such ray file"), ([1, 2], "shape")):
        with pytest.raises(rtu.Error, match=match):
            rtu.trace(seed, bad)
    with pytest.raises(rtu.Error, match="config applies to device='timed' only"):
        rtu.trace(seed, rays, "fixed", config="intel")
    with pytest.raises(rtu.Error, match="device: 'gpu' is not 'float', 'fixed' or 'timed'"):
        rtu.trace(seed, rays, "gpu")
    with pytest.raises(rtu.Error, match="unknown keyword argument 'cache_kib'"):
        rtu.trace(seed, rays, "timed", cache_kib=4)
    with pytest.raises(rtu.Error, match="leaf_size"):
        rtu.trace(seed, rays, leaf_size=0)
    with pytest.raises(rtu.Error, match="unknown format field"):
        rtu.trace(seed, rays, "fixed", format_fields={"no_bits": 3})
    with pytest.raises(rtu.Error, match="HIT_DTYPE"):
        rtu.write_hits("/dev/null", np.zeros(4, dtype=np.float32))


def test_nan_rays(seed):
    rays = rtu.rays(seed, "primary:8x8")
    rays[5, 4] = np.nan
    with pytest.raises(rtu.Error, match="1 invalid rays reported as misses; the first is ray 5"):
        rtu.trace(seed, rays, "fixed")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        r = rtu.trace(seed, rays, "fixed", invalid="warn")
    assert any(issubclass(x.category, rtu.InvalidRayWarning) for x in w)
    assert r.hits["prim"][5] == rtu.MISS and r.stats["invalid_rays"] == 1


def test_compare_equals_the_cli(tmp_path, seed):
    cli("compare", "--scene", SEED, "--rays", "incoherent:4000", "--seed", 9, "--coord-bits", 10,
        "--json", tmp_path / "c.json")
    s = json.loads((tmp_path / "c.json").read_text())
    c = rtu.compare(seed, "incoherent:4000", seed=9, format_fields={"coord_bits": 10})
    for key in ("rays", "compared_rays", "hit_agreement", "prim_agreement", "false_misses", "false_hits",
                "t_rel_error_mean", "t_rel_error_max", "box_checks", "box_false_negatives", "node_visit_overhead",
                "disagreements_total", "format", "bvh"):
        assert c[key] == s[key], key
    assert s["disagreements_total"] > 0  # 10 coordinate bits are wrong somewhere: the frame below is not empty
    assert len(c["disagreements"]) == len(s["disagreements"]) == len(c["disagreement_rays"])
    assert list(c["disagreements"]["ray"]) == [d["ray"] for d in s["disagreements"]]


def test_render_equals_the_cli(tmp_path, seed):
    cli("render", "--scene", SEED, "--device", "timed", "--width", 48, "--height", 36, "--spp", 2,
        "--out", tmp_path / "t.png", "--stats", tmp_path / "t.json")
    s = json.loads((tmp_path / "t.json").read_text())
    with pytest.warns(rtu.InvalidRayWarning, match="out_of_frame"):  # the CLI's warning, as a Python warning
        r = rtu.render(seed, "timed", width=48, height=36, spp=2)
    assert r.warnings == s["warnings"]
    assert r.image.shape == (36, 48, 3) and r.image.dtype == np.uint8
    assert np.array_equal(r.image, rtu.read_png(tmp_path / "t.png"))
    assert r.cycles == s["timing"]["frame_cycles"] > 0
    assert r.stats["rays"] == s["rays"]
    f = rtu.render(seed, "float", width=48, height=36, spp=2)
    d = rtu.diff(f.image, r.image)
    assert d["width"] == 48 and d["pixels_differing"] < 48 * 36 and d["mse"] >= 0
    assert rtu.diff(f.image, f.image)["identical"] and rtu.diff(f.image, f.image)["psnr_db"] is None
    with pytest.raises(rtu.Error, match="sizes|size"):
        rtu.diff(f.image, f.image[:10])


def test_render_with_micromaps_equals_the_cli(tmp_path):
    cli("render", "--scene", "builtin:forest", "--device", "timed", "--width", 64, "--height", 48, "--max-depth", 1,
        "--omm-level", 4, "--out", tmp_path / "m.png", "--stats", tmp_path / "m.json")
    s = json.loads((tmp_path / "m.json").read_text())
    r = rtu.render("builtin:forest", "timed", width=64, height=48, max_depth=1, omm_level=4)
    plain = rtu.render("builtin:forest", "timed", width=64, height=48, max_depth=1)
    assert np.array_equal(r.image, rtu.read_png(tmp_path / "m.png"))
    assert np.array_equal(r.image, plain.image)  # the maps change no pixel
    assert r.stats["micromaps"] == s["micromaps"] and s["micromaps"]["level"] == 4
    assert r.cycles == s["timing"]["frame_cycles"]
    assert r.stats["timing"]["any_hit_requests"] < plain.stats["timing"]["any_hit_requests"]
    with pytest.raises(rtu.Error, match="omm_level"):
        rtu.render("builtin:forest", "timed", width=8, height=6, omm_level=11)


def test_motion_equals_the_cli(tmp_path):
    cli("motion", "--width", 40, "--height", 30, "--samples", 2, "--level", 2, "--image", tmp_path / "m",
        "--json", tmp_path / "m.json")
    s = json.loads((tmp_path / "m.json").read_text())
    f, x, j = rtu.motion(width=40, height=30, samples=2, level=2)
    assert f.shape == (30, 40, 3) and x.dtype == np.uint8
    assert np.array_equal(f, rtu.read_png(tmp_path / "m_float.png"))
    assert np.array_equal(x, rtu.read_png(tmp_path / "m_fixed.png"))
    assert [d["cycles"] for d in j["designs"]] == [d["cycles"] for d in s["designs"]]
    assert [d["unit"] for d in j["designs"]] == ["static", "time-aware", "time-oblivious"]
    # A loaded scene of triangles, set in motion.
    _, _, c = rtu.motion("builtin:cornell", move=(0.2, 0, 0), width=16, height=12, samples=1)
    assert c["moving_primitives"] == c["triangles"] > 0
    with pytest.raises(rtu.Error, match="spheres and curve segments only"):
        rtu.motion(SEED, move=(1, 0, 0), width=8, height=6)
    with pytest.raises(rtu.Error, match="scene only"):
        rtu.motion(move=(1, 0, 0))
    with pytest.raises(rtu.Error, match="box_time_bits"):
        rtu.motion(width=8, height=6, time_bits=8, box_time_bits=9)
    with pytest.raises(rtu.Error, match="not a finite"):
        rtu.motion("builtin:cornell", move=(float("nan"), 0, 0))


def test_query_equals_the_cli_and_brute_force(tmp_path):
    rng = np.random.default_rng(5)
    pts = rng.random((3000, 3), dtype=np.float32) * 20
    qs = rng.random((400, 3)).astype(np.float32) * 20
    r = rtu.query(pts, qs, radius=1.5, max_results=1000)
    assert r["offsets"].shape == (401,) and r["ids"].dtype == np.uint32
    m = rtu.query(pts, qs, radius=1.5, max_results=1000, order="morton")  # the same answers in input order
    assert np.array_equal(m["ids"], r["ids"]) and np.array_equal(m["offsets"], r["offsets"])
    d2 = ((qs[:, None, :].astype(np.float64) - pts[None, :, :]) ** 2).sum(axis=2)
    for i in range(len(qs)):
        want = np.flatnonzero(d2[i] <= 1.5 ** 2)  # no distance within 1e-9 of the radius here: double decides
        assert np.array_equal(r["ids"][r["offsets"][i]:r["offsets"][i + 1]], want)
    assert np.array_equal(r["counts"], (d2 <= 2.25).sum(axis=1))
    near = rtu.query(pts, qs, radius=1.5, kind="nearest", k=2)
    for i in range(0, len(qs), 37):
        got = near["ids"][near["offsets"][i]:near["offsets"][i + 1]]
        assert np.array_equal(got, np.argsort(d2[i], kind="stable")[:len(got)])
    # The CLI on the same points, as a PLY file; the timed unit's figures.
    for name, a in (("p.csv", pts), ("q.csv", qs)):
        (tmp_path / name).write_text("x,y,z\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in a.astype(float)))
    cli("query", "--points", tmp_path / "p.csv", "--queries", tmp_path / "q.csv", "--radius", 1.5, "--device",
        "timed", "--json", tmp_path / "q.json")
    s = json.loads((tmp_path / "q.json").read_text())
    t = rtu.query(pts, qs, radius=1.5, device="timed")
    assert t["stats"]["cycles"] == s["cycles"] > 0 and t["stats"]["results"] == s["results"]
    with pytest.raises(rtu.Error, match="shape"):
        rtu.query(pts[:, :2], radius=1)
    with pytest.raises(rtu.Error, match="needs k"):
        rtu.query(pts, radius=1, kind="nearest")
    with pytest.raises(rtu.Error, match="radius"):
        rtu.query(pts, radius=0)


def test_join_exact_and_equal_to_the_cli(tmp_path):
    # A square and a triangle; points inside, on edges and outside (boundaries count as inside).
    polys = [np.array([[0, 0], [4, 0], [4, 4], [0, 4]], np.float32), np.array([[2, 2], [6, 2], [6, 6]], np.float32)]
    pts = np.array([[1, 1], [3, 3], [5, 5], [4, 1], [9, 9]], np.float32)
    r = rtu.join(polygons=polys, points=pts)
    assert r["pairs"].tolist() == [[0, 0], [1, 0], [1, 1], [2, 1], [3, 0]]
    # Segments: a crossing, a touching end point, a collinear overlap, a miss.
    a = np.array([[0, 0, 2, 2], [3, 0, 3, 2], [5, 5, 7, 5]], np.float32)
    b = np.array([[0, 2, 2, 0], [3, 2, 4, 3], [6, 5, 8, 5], [10, 10, 11, 11]], np.float32)
    s = rtu.join(a, b)
    assert s["pairs"].tolist() == [[0, 0], [1, 1], [2, 2]]
    with open(tmp_path / "a.csv", "w") as f:
        f.write("".join(",".join(str(x) for x in row) + "\n" for row in a.tolist()))
    with open(tmp_path / "b.csv", "w") as f:
        f.write("".join(",".join(str(x) for x in row) + "\n" for row in b.tolist()))
    cli("join", "--segments", tmp_path / "a.csv", "--probes", tmp_path / "b.csv", "--device", "timed", "--json",
        tmp_path / "j.json")
    j = json.loads((tmp_path / "j.json").read_text())
    t = rtu.join(a, b, device="timed")
    assert t["stats"]["cycles"] == j["cycles"] > 0 and t["pairs"].tolist() == s["pairs"].tolist()
    with pytest.raises(rtu.Error, match="segments and probes, or polygons"):
        rtu.join(a, b, points=pts)
    with pytest.raises(rtu.Error, match="shape"):
        rtu.join(a[:, :3], b)
    with pytest.raises(rtu.Error, match="fewer than 3"):
        rtu.join(polygons=[polys[0][:2]], points=pts)


def test_sweep_equals_the_cli(tmp_path):
    args = dict(formats=["default", "default:coord_bits=12"], bvh_widths=[4, 8], configs=["rdna2"], rays=1500,
                image_width=0)
    cli("sweep", "--scene", SEED, "--formats", ",".join(args["formats"]), "--bvh-width", "4,8", "--config", "rdna2",
        "--rays", 1500, "--image-width", 0, "--out", tmp_path / "s.csv")
    df = rtu.sweep(SEED, **args)
    ref = rtu.read_sweep(tmp_path / "s.csv")
    assert len(df) == 4 and list(df.columns) == list(ref.columns)
    measured = [c for c in df.columns if c != "seconds"]
    pd.testing.assert_frame_equal(df[measured], ref[measured])
    assert df["cycles"].nunique() > 1
    front = rtu.pareto_front(df, "cycles", "hit_disagreement")
    assert front.any() and front.dtype == bool
    with pytest.raises(rtu.Error, match="--bvh-width: 5 is not 2, 4, 6 or 8"):
        rtu.sweep(SEED, bvh_widths=[5])


def test_plan_equals_the_cli(tmp_path):
    opts = ["--max-error", "1e-2", "--bvh-width", "4", "--coord-bits", "8,12,16", "--child-bits", "8",
            "--rays", 800, "--image-width", 0, "--json", tmp_path / "p.json"]
    cli("plan", "--scene", SEED, *opts)
    s = json.loads((tmp_path / "p.json").read_text())
    p = rtu.plan(SEED, 1e-2, bvh_widths=[4], coord_bits=[8, 12, 16], child_bits=[8], rays=800, image_width=0)
    assert p["plan"] == s["plan"] and p["plan"] is not None
    assert p["widths"] == s["widths"]
    assert len(p["candidates"]) >= 1 and p["candidates"]["meets"].any()
    # The same defaults: the cost and the threshold of --min-gain.
    assert (p["minimise"], p["min_gain_pct"]) == (s["minimise"], s["min_gain_pct"]) == ("cycles", 2.0)
    # Each candidate's rays per clock per mm^2, the JSON's for the width's candidates (the last row is the base
    # format, measured for comparison).
    listed = [c["perf_per_mm2"] for c in s["widths"][0]["candidates"]]
    assert list(p["candidates"]["perf_per_mm2"])[:-1] == listed and min(listed) > 0


def test_plan_objectives_and_min_gain_equal_the_cli(tmp_path):
    opts = ["--max-error", "1e-2", "--bvh-width", "4", "--coord-bits", "8,12,16", "--child-bits", "8",
            "--rays", 800, "--image-width", 0, "--minimise", "perf-per-area", "--min-gain", 5,
            "--json", tmp_path / "p.json"]
    cli("plan", "--scene", SEED, *opts)
    s = json.loads((tmp_path / "p.json").read_text())
    p = rtu.plan(SEED, 1e-2, bvh_widths=[4], coord_bits=[8, 12, 16], child_bits=[8], rays=800, image_width=0,
                 minimise="perf-per-area", min_gain=5)
    assert p["plan"] == s["plan"] and p["widths"] == s["widths"]
    assert (p["minimise"], p["min_gain_pct"], p["min_gain_applies"]) == ("perf-per-area", 5, False)
    with pytest.raises(rtu.Error, match="--minimise: cycles, bytes, energy, area or perf-per-area, got 'foo'"):
        rtu.plan(SEED, 1e-2, minimise="foo")
    for bad in (-1, 100.5):
        with pytest.raises(rtu.Error, match="min_gain: not in"):
            rtu.plan(SEED, 1e-2, min_gain=bad)


def test_config_and_presets():
    assert "rdna2" in rtu.presets() and "default" in rtu.formats()
    c = rtu.config("intel", {"cache_kib": 64})
    assert c["preset"] == "intel" and c["cache_kib"] == 64
    assert rtu.config({"preset": "intel", "cache_kib": 64}) == c
    assert rtu.format("default:coord_bits=16")["coord_bits"] == 16


def test_gil_released_while_tracing(seed):
    rays = rtu.rays(seed, "incoherent:600000", seed=2)
    done = threading.Event()
    gaps = []

    def work():
        rtu.trace(seed, rays, "fixed", threads=1)
        done.set()

    t = threading.Thread(target=work)
    start = time.perf_counter()
    last = start
    t.start()
    while not done.is_set():
        now = time.perf_counter()
        gaps.append(now - last)
        last = now
        time.sleep(0.001)
    t.join()
    total = time.perf_counter() - start
    # Were the GIL held while tracing, this thread would stall for the whole trace.
    assert total > 0.05 and max(gaps) < 0.5 * total, (max(gaps), total)


def test_alpha_scene_dict_equals_the_cli(tmp_path):
    """A scene dict with a texture and an alpha mask: the module asks the same any-hit stage as rtusim, so the
    hits, the any-hit counts and the timed cycles are the CLI's."""
    with open(os.path.join(SCENES, "alpha.json")) as f:
        d = json.load(f)
    s = rtu.load_scene(d, base_dir=SCENES)
    rays = rtu.rays(s, "primary")
    ray_path = tmp_path / "p.rays"
    rtu.write_rays(ray_path, rays)
    r = rtu.trace(s, rays, "timed")
    cli("trace", "--scene", os.path.join(SCENES, "alpha.json"), "--rays", ray_path, "--out", tmp_path / "h.hits",
        "--device", "timed", "--stats", tmp_path / "s.json")
    with open(tmp_path / "s.json") as f:
        stats = json.load(f)
    assert np.array_equal(r.hits, rtu.read_hits(tmp_path / "h.hits"))
    assert r.stats["any_hit_calls"] == stats["any_hit_calls"] > 0
    assert 0 < r.stats["any_hit_ignored"] == stats["any_hit_ignored"] < stats["any_hit_calls"]
    assert r.cycles == stats["timing"]["cycles"]
    assert stats["timing"]["any_hit_requests"] == stats["any_hit_calls"]


def test_instanced_scene_two_levels_and_flatten_equal_the_cli(tmp_path):
    city = rtu.load_scene("builtin:city")
    cli("rays", "--scene", "builtin:city", "--count", "2000", "--out", tmp_path / "p.rays")
    rays = rtu.read_rays(tmp_path / "p.rays")
    for flatten in (False, True):
        extra = ["--flatten"] if flatten else []
        cli("trace", "--scene", "builtin:city", "--rays", tmp_path / "p.rays", "--device", "timed", *extra,
            "--out", tmp_path / "h.hits", "--stats", tmp_path / "s.json")
        s = json.loads((tmp_path / "s.json").read_text())
        r = rtu.trace(city, rays, "timed", flatten=flatten)
        assert r.hits.tobytes() == (tmp_path / "h.hits").read_bytes()
        assert r.cycles == s["timing"]["cycles"]
        assert (r.stats["timing"]["instance_transforms"] == 0) == flatten
    with pytest.raises(rtu.Error, match="flatten"):
        rtu.trace(city, rays, "float", flatten=True)


def test_sweep_flatten_and_unmeasured_psnr_equal_the_cli(tmp_path):
    """--flatten on an instanced scene: other bytes, recorded in the flatten column; a PSNR without a render is an
    empty cell, NaN in the frame, as rtusim writes it."""
    cli("sweep", "--scene", "builtin:city", "--rays", 64, "--image-width", 0, "--flatten", "--out", tmp_path / "f.csv")
    ref = rtu.read_sweep(tmp_path / "f.csv")
    flat = rtu.sweep("builtin:city", rays=64, image_width=0, flatten=True)
    two = rtu.sweep("builtin:city", rays=64, image_width=0)
    measured = [c for c in flat.columns if c != "seconds"]
    pd.testing.assert_frame_equal(flat[measured], ref[measured])
    assert bool(flat["flatten"][0]) and not bool(two["flatten"][0])
    assert flat["bvh_bytes"][0] > 10 * two["bvh_bytes"][0]
    assert math.isnan(flat["psnr_db"][0]) and math.isnan(ref["psnr_db"][0])
    p = rtu.plan("builtin:city", 0.05, bvh_widths=[4], coord_bits=[16], child_bits=[8], rays=64, image_width=0,
                 flatten=True)
    assert p["flatten"] is True and p["plan"]["psnr_db"] is None
    assert p["plan"]["bytes"] == flat["bvh_bytes"][0]


def test_read_sweep_takes_crlf_and_a_bom(tmp_path):
    cli("sweep", "--scene", SEED, "--rays", 64, "--image-width", 0, "--out", tmp_path / "s.csv")
    text = (tmp_path / "s.csv").read_text()
    (tmp_path / "w.csv").write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode())
    a, b = rtu.read_sweep(tmp_path / "s.csv"), rtu.read_sweep(tmp_path / "w.csv")
    assert list(b.columns)[0] == "scene"
    pd.testing.assert_frame_equal(a, b)
    cli("sweep", "--merge", tmp_path / "w.csv", "--out", tmp_path / "m.csv")  # and rtusim reads it


def test_unshowable_budgets_and_nan_options_are_refused():
    message = cli_error("plan", "--scene", SEED, "--max-error", 0)
    for budget in (0.0, 1e-20, 4.9e-324):
        with pytest.raises(rtu.Error, match="below the smallest hit disagreement a plan can show"):
            rtu.plan(SEED, budget)
    with pytest.raises(rtu.Error) as e:
        rtu.plan(SEED, 0.0)
    assert str(e.value) == message
    for name in ("min_psnr", "confidence", "min_gain", "area_budget"):
        with pytest.raises(rtu.Error, match=f"{name}: nan is not a finite number"):
            rtu.plan(SEED, 1e-2, **{name: float("nan")})
    with pytest.raises(rtu.Error, match="max_error: nan is not a finite number"):
        rtu.plan(SEED, float("nan"))
    with pytest.raises(TypeError, match="rays: expected an int"):
        rtu.sweep(SEED, rays=float("nan"))


def test_argument_errors_name_the_parameter(seed):
    with pytest.raises(TypeError, match="device: expected 'float', 'fixed' or 'timed', got None"):
        rtu.trace(seed, "primary:4x4", device=None)
    with pytest.raises(TypeError, match="bvh_width: expected an int"):
        rtu.trace(seed, "primary:4x4", "fixed", bvh_width="4")
    with pytest.raises(rtu.Error, match="rays: no rays given"):
        rtu.compare(seed, np.zeros((0, 8), np.float32))
    for name in ("scenes", "formats", "bvh_widths", "configs"):
        with pytest.raises(ValueError, match=f"{name}: empty"):
            rtu.sweep([] if name == "scenes" else SEED, **({} if name == "scenes" else {name: []}))
    for name in ("bvh_widths", "coord_bits", "child_bits"):
        with pytest.raises(ValueError, match=f"{name}: empty"):
            rtu.plan(SEED, 1e-2, **{name: []})


def test_scene_dict_with_numpy_values_and_nan_key_path():
    plain = {"spheres": [{"center": [0.0, 1.0, 0.0], "radius": 0.5}], "planes": [{"normal": [0, 1, 0], "offset": 0}]}
    arrays = {"spheres": [{"center": np.array([0.0, 1.0, 0.0]), "radius": np.float32(0.5)}],
              "planes": [{"normal": np.array([0, 1, 0]), "offset": np.int64(0)}]}
    a, b = rtu.load_scene(plain), rtu.load_scene(arrays)
    assert a.bounds == b.bounds and a.primitives == b.primitives == 2
    rays = rtu.rays(a, "primary:16x16")
    assert np.array_equal(rtu.trace(a, rays).hits, rtu.trace(b, rays).hits)
    bad = {"spheres": [{"center": [0, 0, 0], "radius": 1.0}, {"center": [0, 0, 0], "radius": float("nan")}]}
    with pytest.raises(rtu.Error, match=r"scene dict: spheres\[1\]\.radius: nan is not a finite number"):
        rtu.load_scene(bad)
    with pytest.raises(rtu.Error, match=r"spheres\[0\]\.center\[2\]: inf"):
        rtu.load_scene({"spheres": [{"center": np.array([0, 0, np.inf]), "radius": 1.0}]})


def test_long_calls_stop_on_ctrl_c():
    """Ctrl-C (SIGINT) during a sweep, a plan, a trace, a compare or a render stops it with KeyboardInterrupt
    between its steps (points, chunks of 2^18 rays, the firmware's doorbells). The signal is sent only once the
    call has released the GIL (the switch interval is made longer than the test, so the sender thread runs only
    when the main thread gives the GIL up: inside the job), and the jobs would run for minutes without the
    check."""
    main = threading.get_ident()
    jobs = (lambda: rtu.sweep(SEED, formats=[f"default:coord_bits={b}" for b in range(8, 28)], rays=1 << 20,
                              image_width=0, threads=1),
            lambda: rtu.plan(SEED, 1e-3, rays=1 << 20, image_width=0, threads=1),
            lambda: rtu.trace(SEED, "incoherent:4000000", "timed", threads=1),
            lambda: rtu.compare(SEED, "incoherent:4000000", "timed", threads=1),
            lambda: rtu.render(SEED, "timed", width=1280, height=960, spp=16, threads=1))
    for job in jobs:
        raised = []

        def handler(signum, frame):
            if not raised:
                raised.append(signum)
                raise KeyboardInterrupt

        done = threading.Event()

        def sender():
            while not done.is_set():
                time.sleep(0.05)
                if not done.is_set():
                    signal.pthread_kill(main, signal.SIGINT)

        old_handler = signal.signal(signal.SIGINT, handler)
        old_interval = sys.getswitchinterval()
        t = threading.Thread(target=sender)
        try:
            sys.setswitchinterval(1000.0)
            t.start()
            with pytest.raises(KeyboardInterrupt):
                job()
        finally:
            done.set()
            sys.setswitchinterval(old_interval)
            t.join()
            for _ in range(3):  # any signal still pending reaches the handler installed above, which ignores it
                time.sleep(0.01)
            signal.signal(signal.SIGINT, old_handler)
        assert raised == [signal.SIGINT]


def test_primitives_below_the_grid_step_warn():
    """Two unit boxes 10^12 apart: on the fixed and timed devices their 24 triangles are below the grid step, which
    trace, compare and render say as an AccuracyWarning; the float device and the same boxes as instances do
    not."""
    box = {"generate": "box", "size": [1, 1, 1]}
    cam = {"position": [0, 0, 5], "look_at": [0, 0, 0], "width": 32, "height": 24}
    flat = rtu.load_scene({"camera": cam, "meshes": [box, dict(box, transform={"translate": [1e12, 0, 0]})]})
    for job in (lambda: rtu.trace(flat, "primary", "fixed"), lambda: rtu.compare(flat, "primary", "timed"),
                lambda: rtu.render(flat, "fixed", width=16, height=12)):
        with pytest.warns(rtu.AccuracyWarning, match="24 of 24 primitives are smaller than the grid step"):
            job()
    inst = rtu.load_scene({"camera": cam, "prototypes": {"cube": {"meshes": [box]}},
                           "instances": [{"prototype": "cube"},
                                         {"prototype": "cube", "transform": {"translate": [1e12, 0, 0]}}]})
    with warnings.catch_warnings():
        warnings.simplefilter("error", rtu.AccuracyWarning)
        rtu.trace(flat, "primary", "float")
        assert rtu.compare(inst, "primary", "fixed")["hit_agreement"] == 1.0


def test_wrong_argument_types_name_the_argument(seed, tmp_path):
    # Not pybind11's "incompatible function arguments" listing the C++ signature: the argument, what it takes.
    with pytest.raises(TypeError, match="threads: expected an int, got 'two'"):
        rtu.trace(seed, "primary:4x4", threads="two")
    with pytest.raises(TypeError, match="any_hit: expected True or False, got 'yes'"):
        rtu.trace(seed, "primary:4x4", any_hit="yes")
    with pytest.raises(TypeError, match="max_list: expected an int"):
        rtu.compare(seed, "primary:4x4", max_list=None)
    with pytest.raises(TypeError, match="width: expected an int, got 32.5"):
        rtu.render(seed, width=32.5, height=24)
    with pytest.raises(TypeError, match=r"background: expected three numbers \(r, g, b\)"):
        rtu.render(seed, width=8, height=8, background=("a", 0, 0))
    with pytest.raises(TypeError, match="spec: expected a ray spec"):
        rtu.rays(seed, 64)
    with pytest.raises(TypeError, match="path: expected a file name"):
        rtu.read_rays(3)
    # A directory is named with its path.
    with pytest.raises(rtu.Error, match=str(tmp_path)):
        rtu.read_rays(tmp_path)


def test_format_specs_equal_the_per_field_options(tmp_path, seed, ray_file):
    # A spec such as sweep's formats take is one design point with the per-field options, on every device that
    # has a format, and the same as the CLI's --format SPEC.
    path, rays = ray_file
    for spec, preset, fields in (("packed:coord_bits=16", "packed", {"coord_bits": 16}),
                                 ("rdna4:node_kind=0", "rdna4", {"node_kind": 0})):
        by_fields = rtu.trace(seed, rays, "fixed", format=preset, format_fields=fields)
        by_spec = rtu.trace(seed, rays, "fixed", format=spec)
        assert np.array_equal(by_spec.hits, by_fields.hits)
        timed = rtu.trace(seed, rays, "timed", format=preset, format_fields=fields)
        assert np.array_equal(timed.hits, by_fields.hits)
        for options in ({"format": spec}, {"set": {"format": spec}}, {"config": {"preset": "rdna2", "format": spec}}):
            assert rtu.trace(seed, rays, "timed", **options).cycles == timed.cycles, options
        cli("trace", "--scene", SEED, "--rays", path, "--device", "timed", "--format", spec, "--out",
            tmp_path / "h.bin", "--stats", tmp_path / "s.json")
        assert json.loads((tmp_path / "s.json").read_text())["timing"]["cycles"] == timed.cycles
        assert np.array_equal(rtu.read_hits(tmp_path / "h.bin"), timed.hits)
    message = cli_error("trace", "--scene", SEED, "--rays", path, "--device", "timed", "--set",
                        "format=packed:coord_bits=x")
    with pytest.raises(rtu.Error) as e:
        rtu.trace(seed, rays, "timed", set={"format": "packed:coord_bits=x"})
    assert str(e.value) == message
    with pytest.raises(rtu.Error, match="format spec packed:frobs=3: 'frobs=3' is not key=value"):
        rtu.trace(seed, rays, "fixed", format="packed:frobs=3")
    with pytest.raises(TypeError, match="format: expected a format spec"):
        rtu.trace(seed, rays, "fixed", format=3)


def test_sweep_frames_carry_the_swept_keys(tmp_path):
    # The keys the format and configuration specs name are columns of their own, after "config": each row's value,
    # the spec's where it names the key and its preset's where not; in every frame of sweep rows.
    formats = ["default", "default:coord_bits=16:child_bits=6"]
    cli("sweep", "--scene", SEED, "--formats", ",".join(formats), "--config", "rdna2,intel", "--set",
        "cache_kib=16,64", "--rays", 64, "--image-width", 0, "--out", tmp_path / "s.csv")
    configs = ["rdna2:cache_kib=16", "rdna2:cache_kib=64", "intel:cache_kib=16", "intel:cache_kib=64", "embedded"]
    df = rtu.sweep(SEED, formats=formats, configs=configs, rays=64, image_width=0)
    columns = list(df.columns)
    assert columns[columns.index("config") + 1:columns.index("config") + 4] == ["coord_bits", "child_bits",
                                                                                  "cache_kib"]
    for _, row in df.iterrows():
        assert row["coord_bits"] == rtu.format(row["format"])["coord_bits"]
        assert row["child_bits"] == rtu.format(row["format"])["child_bits"]
        preset, *sets = row["config"].split(":")
        assert row["cache_kib"] == rtu.config(preset, sets)["cache_kib"]
    assert sorted(df["coord_bits"].unique()) == [16, 24]
    assert set(df[df["config"] != "embedded"]["cache_kib"]) == {16, 64}
    assert df[df["config"] == "embedded"]["cache_kib"].iloc[0] == rtu.config("embedded")["cache_kib"]
    # rtusim sweep --set's rows read back, and the plan's candidates (their formats name the bits the plan varies).
    ref = rtu.read_sweep(tmp_path / "s.csv")
    assert set(ref["cache_kib"]) == {16, 64} and set(ref["coord_bits"]) == {16, 24}
    measured = [c for c in ref.columns if c != "seconds"]
    pd.testing.assert_frame_equal(ref[measured], df[df["config"] != "embedded"][measured].reset_index(drop=True))
    p = rtu.plan(SEED, 0.05, bvh_widths=[4], coord_bits=[8, 12], child_bits=[8], rays=64, image_width=0)
    assert {"coord_bits", "child_bits"} <= set(p["candidates"].columns)
    # Keys without a column of their own: a sweep of presets adds none.
    plain = rtu.read_sweep(tmp_path / "s.csv").iloc[:0]
    assert rtu.sweep(SEED, rays=64, image_width=0).columns.tolist() == [c for c in plain.columns if c not in
                                                                        ("coord_bits", "child_bits", "cache_kib")]


def test_wrong_types_and_paths_are_named_not_pybind11s(seed, tmp_path):
    # Not pybind11's "incompatible function arguments" or "Unable to cast Python instance to C++ type", nor
    # Python's "expected str, bytes or os.PathLike object": the argument and what it takes.
    for call, match in (
            (lambda: rtu.config(3), "preset: expected a timing preset name"),
            (lambda: rtu.config("rdna2", [3]), "set: expected \"key=value\" strings, got 3"),
            (lambda: rtu.format(3), "spec: expected a format spec"),
            (lambda: rtu.sweep(3), "scenes: expected a list of strings, got the item 3"),
            (lambda: rtu.sweep(SEED, formats=[3]), "formats: expected a list of strings, got the item 3"),
            (lambda: rtu.sweep(SEED, bvh_widths=["4"]), "bvh_widths: expected a list of ints"),
            (lambda: rtu.sweep(SEED, configs=[None]), "configs: expected a list of strings"),
            (lambda: rtu.sweep(SEED, area=3), "area: expected a file name"),
            (lambda: rtu.plan(3, 0.1), "scene: expected a scene spec"),
            (lambda: rtu.plan(SEED, 0.1, config=4), "config: expected a str, got 4"),
            (lambda: rtu.collect(3), "results: expected a file name"),
            (lambda: rtu.read_sweep(3), "path: expected a file name"),
            (lambda: rtu.make_rays("a", "b"), "origin: expected an array of numbers"),
            (lambda: rtu.pareto_front(3), "df: expected a DataFrame"),
            (lambda: rtu.trace(seed, "primary:4x4", "timed", config={"preset": 3}),
             r"config\[\"preset\"\]: expected a timing preset name"),
            (lambda: rtu.trace(seed, "primary:4x4", "timed", set=[3]), "set: expected \"key=value\" strings"),
            (lambda: rtu.trace(seed, "primary:4x4", "fixed", format=3), "format: expected a format spec")):
        with pytest.raises(TypeError, match=match):
            call()
    with pytest.raises(rtu.Error, match="a: expected a uint8 array"):  # the first bad argument, by its name
        rtu.diff(3, 4)
    with pytest.raises(rtu.Error, match="cost: the frame has no column 'no_such'"):
        rtu.pareto_front(pd.DataFrame({"cycles": [1]}), "no_such")
    # A directory where a file is named: rtu.Error with the path, as rtusim says it (not IsADirectoryError).
    for call, words in (
            (lambda: rtu.read_sweep(tmp_path), ": is a directory, not a file"),
            (lambda: rtu.load_scene(str(tmp_path)), ": is a directory, not a file"),
            (lambda: rtu.write_png(tmp_path, np.zeros((2, 2, 3), np.uint8)), ": is a directory, not a file"),
            (lambda: rtu.write_rays(tmp_path / "none" / "r.rays", np.zeros((1, 8), np.float32)),
             "/none does not exist"),
            (lambda: rtu.sweep(SEED, rays=16, image_width=0, area=tmp_path), ": is a directory, not a file")):
        with pytest.raises(rtu.Error) as e:
            call()
        assert str(tmp_path) in str(e.value) and words in str(e.value)


def test_out_of_memory_says_what_bounds_it():
    # A std::bad_alloc no estimate foresaw is a MemoryError naming the budget, not "std::bad_alloc". The address
    # space is limited to 48 MiB above what the interpreter holds: the rays' estimate (48 bytes a ray) passes that
    # limit, their 32 bytes a ray do not fit in what is left.
    code = (
        "import resource, rtu\n"
        "vm = int([l.split()[1] for l in open('/proc/self/status') if l.startswith('VmSize:')][0]) * 1024\n"
        "limit = vm + (48 << 20)\n"
        "resource.setrlimit(resource.RLIMIT_AS, (limit, resource.RLIM_INFINITY))\n"
        "try:\n"
        "    rtu.rays('builtin:seed', 'incoherent:%d' % (limit // 48 - 1000))\n"
        "    print('no error')\n"
        "except MemoryError as e:\n"
        "    print('MemoryError:', e)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=os.environ)
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith("MemoryError: rtu: out of memory"), p.stdout
    assert "RTU_MEMORY_LIMIT" in p.stdout and "std::bad_alloc" not in p.stdout
