"""rtu: a model of a fixed-function ray-tracing unit, from Python (python/README.md).

The thin Python layer over the compiled core `_rtu`: keyword defaults, scene dicts, and DataFrames. Every job
calls the host function `rtusim` calls, so hits, cycles and statistics equal the CLI's on the same inputs;
statistics are the dicts of the CLI's JSON files. Errors are `rtu.Error` (a RuntimeError and a ValueError) with
the CLI's message.

    import rtu
    scene = rtu.load_scene("builtin:seed")
    rays = rtu.rays(scene, "primary:64x48")             # (N, 8) float32: ox oy oz tmin dx dy dz tmax
    r = rtu.trace(scene, rays, device="timed", config={"preset": "intel", "cache_kib": 64})
    r.hits["prim"], r.cycles, r.stats["timing"]["cycles_per_ray"]
"""

import json as _json
import math as _math
import os as _os
import warnings as _warnings
from dataclasses import dataclass as _dataclass, field as _field

import numpy as _np

from . import _rtu
from ._rtu import Error, Scene, builtin_scenes, diff, formats, presets

__all__ = [
    "Error", "Scene", "InvalidRayWarning", "AccuracyWarning", "HIT_DTYPE", "RAY_FIELDS", "load_scene", "builtin_scenes", "rays",
    "make_rays", "read_rays", "write_rays", "read_hits", "write_hits", "trace", "TraceResult", "ab", "compare",
    "render", "RenderResult", "diff", "read_png", "write_png", "config", "presets", "formats", "format",
    "sweep", "sweep_on", "collect", "read_sweep", "plan", "pareto_front",
]

# The columns of a ray array (the ray file's record) and the dtype of a hit array (the hit file's record).
RAY_FIELDS = ("ox", "oy", "oz", "tmin", "dx", "dy", "dz", "tmax")
HIT_DTYPE = _rtu.hit_dtype()
MISS = 0xFFFFFFFF  # hits["prim"] of a miss (t is +inf)


class InvalidRayWarning(UserWarning):
    """Rays the device rejected at ray setup were traced as misses (invalid="warn")."""


class AccuracyWarning(UserWarning):
    """Primitives below the fixed-point grid step: the fixed and timed devices may lose or invent their hits
    (the CLI's warning; compare counts them, instancing or more coordinate bits cure them)."""


def _render_warning_kind(text):
    if "grid step" in text:
        return AccuracyWarning
    if "ray" in text and "invalid" in text:
        return InvalidRayWarning
    return UserWarning


def _plain(value, path):
    """A scene dict's value as JSON takes it: numpy arrays as lists, numpy scalars as numbers, tuples as lists;
    a NaN or an infinity is refused naming its key path (spheres[0].radius), which the JSON text could not."""
    if isinstance(value, dict):
        return {k: _plain(v, f"{path}.{k}" if path else str(k)) for k, v in value.items()}
    if isinstance(value, _np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v, f"{path}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, _np.generic):
        value = value.item()
    if isinstance(value, float) and not _math.isfinite(value):
        raise Error(f"scene dict: {path}: {value} is not a finite number")
    return value


def load_scene(scene, base_dir=None):
    """A scene from a spec (a .json scene file, a mesh file, "builtin:NAME") or a dict in the scene-file format
    (scenes/README.md; relative mesh paths are relative to base_dir, default the working directory). A Scene is
    returned as it is. In a dict, numpy arrays and scalars may stand for lists and numbers."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        plain = _plain(scene, "")  # rtu.Error naming the key path of a NaN
        try:
            text = _json.dumps(plain, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise Error(f"scene dict: not JSON: {e}") from None
        return _rtu.load_scene_text(text, "scene dict", str(base_dir or _os.getcwd()))
    if isinstance(scene, _os.PathLike):
        scene = _os.fspath(scene)
    if not isinstance(scene, str):
        raise Error(f"scene: expected a spec, a dict or an rtu.Scene, got {type(scene).__name__}")
    return _rtu.load_scene(scene)


def rays(scene, spec="primary", seed=1):
    """Rays as an (N, 8) float32 array from rtusim's ray spec: "primary", "primary:N", "primary:WxH",
    "incoherent", "incoherent:N" (seeded), or a ray file."""
    return _rtu.rays(load_scene(scene), _spec(spec, "spec"), _int(seed, "seed"))


def make_rays(origin, direction, tmin=0.0, tmax=_math.inf):
    """An (N, 8) float32 ray array from origins and directions ((N, 3) each) and tmin/tmax (scalars or (N,))."""
    o, d = _floats(origin, "origin"), _floats(direction, "direction")
    if o.ndim != 2 or o.shape[1] != 3 or d.shape != o.shape:
        raise Error(f"make_rays: origin and direction must both be (N, 3), got {o.shape} and {d.shape}")
    r = _np.empty((o.shape[0], 8), dtype=_np.float32)
    r[:, 0:3] = o
    r[:, 3] = tmin
    r[:, 4:7] = d
    r[:, 7] = tmax
    return r


def read_rays(path):
    """A ray file (binary or .csv) as an (N, 8) float32 array."""
    return _rtu.read_rays(_path(path, "path"))


def write_rays(path, rays):
    """Writes an (N, 8) ray array as a ray file (binary, or CSV when the name ends in .csv)."""
    _rtu.write_rays(_path(path, "path"), rays)


def read_hits(path):
    """A hit file (binary or .csv) as a HIT_DTYPE array."""
    return _rtu.read_hits(_path(path, "path"))


def read_png(path):
    """A PNG as a uint8 (height, width, 3) array (grey replicated, alpha dropped)."""
    return _rtu.read_png(_path(path, "path"))


def write_png(path, image):
    """Writes a uint8 (height, width, 3) array as a PNG."""
    _rtu.write_png(_path(path, "path"), image)


def write_hits(path, hits):
    """Writes a hit array (HIT_DTYPE) as a hit file (binary, or CSV when the name ends in .csv)."""
    _rtu.write_hits(_path(path, "path"), hits)


def _rays_arg(scene, rays, seed):
    """Rays given as an array (traced in place when float32, C-contiguous) or as a spec string."""
    if isinstance(rays, (str, _os.PathLike)):
        spec = _os.fspath(rays)
        return _rtu.rays(scene, spec, _int(seed, "seed")), spec
    return rays, "array"


@_dataclass
class TraceResult:
    hits: _np.ndarray  # HIT_DTYPE, one per ray (t, prim, u, v)
    stats: dict  # rtusim trace --stats
    invalid: str = ""  # the invalid-ray message ("" when every ray was valid)
    counts: _np.ndarray = None  # all_hits: intersections found per ray (uint64); more than K: the list overflowed

    @property
    def cycles(self):
        """The timed device's cycles (None on float and fixed)."""
        timing = self.stats.get("timing")
        return timing["cycles"] if timing else None


def trace(scene, rays, device="float", *, any_hit=False, all_hits=None, threads=0, hits=True, invalid="raise", seed=1,
          packet_rays=_rtu.TRACE_PACKET_RAYS, **device_options):
    """Traces rays on a device, as `rtusim trace`.

    device: "float", "fixed" or "timed". Device options (those of rtusim's tracing commands): config (a preset
    name, or a dict {"preset": NAME, key: value}), set ({key: value} or ["key=value"]), format (a spec: a
    preset, or one with changes such as "packed:coord_bits=16"), format_fields ({"coord_bits": 16, ...}),
    bvh_width, leaf_size, accel, sample, sample_unit, sample_warmup, sample_seed, watchdog_steps, flatten, and
    omm_level (trace and render, fixed and timed devices: opacity micromaps of that level, -1 none).
    Options the device would ignore are refused, as the CLI refuses them. hits=False: cycles only (timed with
    sample > 0). invalid: what to do when the device rejected rays (NaN/Inf, zero direction, out of the frame):
    "raise" (rtu.Error), "warn" (InvalidRayWarning; the CLI's behaviour) or "ignore"; the rejected rays are
    misses. all_hits=K (0..256): every intersection in [tmin, tmax] counted (result.counts) and the first K a ray
    kept, in the unit's order: result.hits is then an (N, K) array, misses after each ray's kept hits.
    packet_rays (1..2^30): the rays a TRACE packet, as `rtusim trace --packet-rays` (the timed device's cycles
    depend on it, the hits do not).
    """
    if invalid not in ("raise", "warn", "ignore"):
        raise Error(f"invalid: '{invalid}' is not raise, warn or ignore")
    scene = load_scene(scene)
    rays, name = _rays_arg(scene, rays, seed)
    k = -1 if all_hits is None else _int(all_hits, "all_hits")
    if all_hits is not None and not 0 <= k <= 256:
        raise Error(f"all_hits: {k} is not in 0..256")
    packet = _int(packet_rays, "packet_rays")
    if not 1 <= packet <= _rtu.MAX_TRACE_PACKET_RAYS:  # checked here: a negative value cannot reach size_t
        raise Error(f"packet_rays: {packet} is not in 1..{_rtu.MAX_TRACE_PACKET_RAYS}")
    out = _rtu.trace(scene, rays, _bool(any_hit, "any_hit"), _int(threads, "threads"), _bool(hits, "hits"), name, k,
                     packet, device=device, **device_options)
    h, stats, message = out[:3]
    for w in stats.get("warnings", []):
        _warnings.warn(w, AccuracyWarning, stacklevel=2)
    if message:
        if invalid == "raise":
            raise Error(message)
        if invalid == "warn":
            _warnings.warn(message, InvalidRayWarning, stacklevel=2)
    return TraceResult(h, stats, message, out[3] if len(out) > 3 else None)


def ab(scene, rays="primary", *, a=None, b=None, any_hit=False, threads=0, hits=True, seed=1, **device_options):
    """Design point B against design point A on the same rays, as `rtusim trace --against-*`: both traced on the
    timed device with the common device options, each side's dict (a, b) of device options replacing them (e.g.
    a={"config": "rdna4-chip"}, b={"config": "rdna4-chip", "set": {"l2_bytes_per_cycle": 128}}). Returns the A/B
    dict: "a" and "b" (label, cycles, rays_per_clock, limited_by, cycles_over_bound, area_mm2, pj_per_ray,
    unit_pj_per_ray, rays_per_clock_per_mm2), "speedup" (A's cycles over B's), "area_ratio", "energy_ratio",
    "unit_energy_ratio", "perf_per_area_ratio" (B over A), "hits_differ", "verdict"; and each side's full
    statistics under "a_stats" and "b_stats"."""
    for name, side in (("a", a), ("b", b)):
        if side is not None and not isinstance(side, dict):
            raise Error(f"{name}: expected a dict of device options, got {type(side).__name__}")
    if "device" in device_options or "device" in (a or {}) or "device" in (b or {}):
        raise Error("ab: both sides run on the timed device; device is not an option here")
    scene = load_scene(scene)
    rays, name = _rays_arg(scene, rays, seed)
    sides = [{**device_options, **(side or {}), "device": "timed"} for side in (a, b)]
    result, sa, sb = _rtu.ab(scene, rays, _bool(any_hit, "any_hit"), _int(threads, "threads"), _bool(hits, "hits"),
                             name, sides[0], sides[1])
    result["a_stats"], result["b_stats"] = sa, sb
    return result


def compare(scene, rays="primary", device="fixed", *, any_hit=False, threads=0, max_list=1000, seed=1, **device_options):
    """The float reference against a device on identical rays, as `rtusim compare`: its --json dict, with the
    disagreements as a DataFrame (ray, kind, float_prim, float_t, <device>_prim, <device>_t) and the disagreeing
    rays (an (N, 8) array) under "disagreement_rays"."""
    import pandas as pd

    scene = load_scene(scene)
    rays, name = _rays_arg(scene, rays, seed)
    result, replay = _rtu.compare(scene, rays, name, _bool(any_hit, "any_hit"), _int(threads, "threads"),
                                  _int(max_list, "max_list"), device=device, **device_options)
    for w in result.get("warnings", []):
        _warnings.warn(w, AccuracyWarning, stacklevel=2)
    rows = []
    for d in result["disagreements"]:
        row = {"ray": d["ray"], "kind": d["kind"]}
        for dev in ("float", result["device"]):
            row[f"{dev}_prim"] = d[dev]["prim"]
            row[f"{dev}_t"] = d[dev]["t"]
        rows.append(row)
    cols = ["ray", "kind", "float_prim", "float_t", f"{result['device']}_prim", f"{result['device']}_t"]
    result["disagreements"] = pd.DataFrame(rows, columns=cols)
    result["disagreement_rays"] = replay
    return result


@_dataclass
class RenderResult:
    image: _np.ndarray  # uint8 (height, width, 3), sRGB: what rtusim render writes as PNG
    radiance: _np.ndarray  # float32 (height, width, 3), linear
    stats: dict  # rtusim render --stats (without "image")
    warnings: list = _field(default_factory=list)

    @property
    def cycles(self):
        """The timed device's frame cycles (None on float and fixed)."""
        timing = self.stats.get("timing")
        return timing.get("frame_cycles") if timing else None


def render(scene, device="float", *, mode="raytrace", width=0, height=0, spp=1, max_depth=4, seed=1, indirect=True,
           ao=False, ao_distance=0.0, background=(0.0, 0.0, 0.0), threads=0, **device_options):
    """Renders with the firmware renderer on a device, as `rtusim render` (width, height 0: the camera's)."""
    scene = load_scene(scene)
    if not isinstance(mode, str):
        raise TypeError(f"mode: expected a str, got {mode!r}")
    try:
        background = [_number(c, "background") for c in background]
    except TypeError:
        raise TypeError(f"background: expected three numbers (r, g, b), got {background!r}") from None
    img, rad, stats, warns = _rtu.render(scene, mode, _int(width, "width"), _int(height, "height"), _int(spp, "spp"),
                                         _int(max_depth, "max_depth"), _int(seed, "seed"), _bool(indirect, "indirect"),
                                         _bool(ao, "ao"), _number(ao_distance, "ao_distance"), background,
                                         _int(threads, "threads"), device=device, **device_options)
    for w in warns:
        _warnings.warn(w, _render_warning_kind(w), stacklevel=2)
    return RenderResult(img, rad, stats, list(warns))


def motion(scene=None, *, move=(0.0, 0.0, 0.0), width=320, height=240, samples=4, level=4, motion_scale=1.0,
           time_bits=16, box_time_bits=6, seed=1, threads=0, format="default", config="rdna2", set=None,  # noqa: A002
           rays=None, times=None, instances=False):
    """Motion blur, as `rtusim motion`: the built-in moving scene (scene None; level, motion_scale; instances=True:
    the built-in moving instances, each placed by two transforms) or a scene of triangles, spheres and curves moved
    by `move` between the key frames (a scene of instances: each instance's transform moved), on the float and
    fixed devices and timed
    on a static, a time-aware and a time-oblivious unit. Returns (float image, fixed image, figures dict). With
    rays ((N, 8)) and times ((N,) shutter times in [0, 1]), as --rays and --times: those rays instead of the frame,
    and (None, None, figures dict, the fixed unit's hits)."""
    if scene is not None:
        scene = load_scene(scene)
    try:
        move = [_number(c, "move") for c in move]
    except TypeError:
        raise TypeError(f"move: expected three numbers (x, y, z), got {move!r}") from None
    sets = _sets(set)
    return _rtu.motion(scene, move, _int(width, "width"), _int(height, "height"), _int(samples, "samples"),
                       _int(level, "level"), _number(motion_scale, "motion_scale"), _int(time_bits, "time_bits"),
                       _int(box_time_bits, "box_time_bits"), _int(seed, "seed"), _int(threads, "threads"),
                       _str(format, "format", "a format spec such as 'default'"),
                       _str(config, "config", "a timing preset name such as 'rdna2'"), sets, rays, times,
                       bool(instances))


def query(points, queries=None, *, radius, kind="radius", k=None, max_results=64, device="fixed", format="default",
          config="rdna2", set=None, threads=0, order="input"):  # noqa: A002
    """Neighbour queries on the unit, as `rtusim query`: every point of `points` ((N, 3) floats) within `radius`
    of each query point (`queries`, (M, 3); None: the points), exactly; kind "count" only their numbers,
    "nearest" the k nearest within the radius. device "timed" adds the cycles; order "morton" issues the queries
    in Morton order (RTNN's reordering, as --order). Returns a dict: "ids" (the answers of all queries,
    concatenated), "offsets" (query i's are ids[offsets[i]:offsets[i+1]]), "counts" (every neighbour's count, also
    beyond the bound), "overflow" (more than max_results), "stats" (the --json dict)."""
    kind = _str(kind, "kind", "radius, count or nearest")
    if kind == "nearest":
        if k is None:
            raise Error("kind='nearest' needs k")
        bound = _int(k, "k")
    else:
        if k is not None:
            raise Error("k applies to kind='nearest' only")
        bound = _int(max_results, "max_results")
    if bound < 1:
        raise Error("k and max_results must be at least 1")
    device = _str(device, "device", "'fixed' or 'timed'")
    if device not in ("fixed", "timed"):
        raise Error(f"device: queries run on 'fixed' or 'timed', not {device!r}")
    sets = _sets(set)
    return _rtu.query(_np.asarray(points), None if queries is None else _np.asarray(queries),
                      _number(radius, "radius"), kind, bound, device == "timed",
                      _str(format, "format", "a format spec such as 'default'"),
                      _str(config, "config", "a timing preset name such as 'rdna2'"), sets, _int(threads, "threads"),
                      _str(order, "order", "'input' or 'morton'"))


def join(segments=None, probes=None, *, polygons=None, points=None, device="fixed", format="default",
         config="rdna2", set=None, threads=0):  # noqa: A002
    """A spatial join on the unit, exact, as `rtusim join`: segments (N, 4) x0 y0 x1 y1 against probes (M, 4), every
    pair that meets; or polygons (a list of (K, 2) vertex arrays) and points (M, 2), the polygons that hold each
    point (boundary included). Returns a dict: "pairs" ((P, 2) uint32: segment, probe or point, polygon; sorted),
    "stats" (the --json dict; cycles with device "timed")."""
    seg = segments is not None or probes is not None
    poly = polygons is not None or points is not None
    if seg == poly:
        raise Error("give segments and probes, or polygons and points")
    if seg and (segments is None or probes is None):
        raise Error("a segment join needs both segments and probes")
    if poly and (polygons is None or points is None):
        raise Error("point in polygon needs both polygons and points")
    device = _str(device, "device", "'fixed' or 'timed'")
    if device not in ("fixed", "timed"):
        raise Error(f"device: joins run on 'fixed' or 'timed', not {device!r}")
    sets = _sets(set)
    return _rtu.join(None if segments is None else _np.asarray(segments),
                     None if probes is None else _np.asarray(probes),
                     None if polygons is None else [_np.asarray(p) for p in polygons],
                     None if points is None else _np.asarray(points), device == "timed",
                     _str(format, "format", "a format spec such as 'default'"),
                     _str(config, "config", "a timing preset name such as 'rdna2'"), sets, _int(threads, "threads"))


def config(preset="rdna2", set=None):
    """A timing configuration, every key (rtusim config --config P --set k=v): a dict."""
    if isinstance(preset, dict):
        d = dict(preset)
        preset = d.pop("preset", "rdna2")
        set = {**d, **(set or {})}
    preset = _str(preset, "preset", "a timing preset name such as 'rdna2', or a dict {\"preset\": NAME, key: value}")
    return _rtu.config(preset, _sets(set))


def _sets(set):  # noqa: A002
    """Timing overrides as "key=value" strings, from a dict {key: value} or a list of such strings."""
    if isinstance(set, dict):
        return [f"{key}={_value(v)}" for key, v in set.items()]
    if set is None or isinstance(set, (list, tuple)):
        return [_str(x, "set", "\"key=value\" strings") for x in set or []]
    raise TypeError(f"set: expected a dict {{key: value}} or a list of \"key=value\", got {set!r}")


def _value(v):
    return ("true" if v else "false") if isinstance(v, bool) else str(v)


def format(spec="default"):  # noqa: A001 (the CLI's word)
    """A fixed-point format from a spec ("default", "packed:coord_bits=16"): every field, as a dict."""
    return _rtu.format(_str(spec, "spec", "a format spec such as 'default' or 'packed:coord_bits=16'"))


def _list(x, name, expected=None):
    """A list argument (a single str or int stands for a list of one); an empty one is refused naming it. With
    `expected` ("str" or "int"), a TypeError naming it for an item of another type."""
    if isinstance(x, (str, int, _np.integer, _os.PathLike)):
        items = [x]
    else:
        try:
            items = list(x)
        except TypeError:
            raise TypeError(f"{name}: expected a list, got {x!r}") from None
    if not items:
        raise Error(f"{name}: empty (give at least one)")
    items = [int(i) if isinstance(i, _np.integer) else _os.fspath(i) if isinstance(i, _os.PathLike) else i
             for i in items]
    kind = {"str": str, "int": int}.get(expected)
    for i in items:
        if kind is not None and (not isinstance(i, kind) or isinstance(i, bool)):
            raise TypeError(f"{name}: expected a list of {'strings' if kind is str else 'ints'}, got the item {i!r}")
    return items


def _str(value, name, expected):
    """A string argument; a TypeError naming it and what it takes otherwise."""
    if not isinstance(value, str):
        raise TypeError(f"{name}: expected {expected}, got {value!r}")
    return value


def _optional_path(value, name):
    """A file name argument that may be left out (None or ""): "" for none."""
    return _path(value, name) if value is not None and value != "" else ""


def _floats(value, name):
    """An array of numbers as float32; a TypeError naming the argument when it holds anything else."""
    try:
        return _np.asarray(value, dtype=_np.float32)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected an array of numbers, got {value!r}") from None


def _int(value, name):
    """An integer argument (numpy integers too); a TypeError naming it otherwise (e.g. a NaN for a count)."""
    if isinstance(value, bool) or not isinstance(value, (int, _np.integer)):
        raise TypeError(f"{name}: expected an int, got {value!r}")
    return int(value)


def _bool(value, name):
    """A flag argument (numpy booleans and integers too); a TypeError naming it otherwise."""
    if not isinstance(value, (bool, _np.bool_, int, _np.integer)):
        raise TypeError(f"{name}: expected True or False, got {value!r}")
    return bool(value)


def _path(value, name):
    """A file name argument (str or os.PathLike); a TypeError naming it otherwise."""
    if not isinstance(value, (str, _os.PathLike)):
        raise TypeError(f"{name}: expected a file name (str or os.PathLike), got {value!r}")
    return _os.fspath(value)


def _spec(value, name):
    """A ray spec or a ray file's name."""
    if not isinstance(value, (str, _os.PathLike)):
        raise TypeError(f"{name}: expected a ray spec such as 'primary:64x48' or a ray file's name, got {value!r}")
    return _os.fspath(value)


def _number(value, name):
    """A finite number argument; NaN and infinities are refused naming it (a NaN would pass range checks)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, _np.integer, _np.floating)):
        raise TypeError(f"{name}: expected a number, got {value!r}")
    if not _math.isfinite(float(value)):
        raise Error(f"{name}: {value} is not a finite number")
    return float(value)


def sweep(scenes, formats=("default",), bvh_widths=(4,), configs=("rdna2",), *, rays=20000, seed=1, image_width=128,
          threads=0, area=None, flatten=False, shard=None):
    """A design sweep, as `rtusim sweep`: one row per scene x BVH width x format x configuration, with the CSV's
    columns (error, cycles, bytes, area, energy). Configurations are presets or "preset:key=value:...".
    flatten: trace instanced scenes in one image on the fixed and timed devices (rtusim sweep --flatten).
    shard: (k, N) or "k/N", 1 <= k <= N: only every N-th point of the grid's order, starting at the k-th, as
    rtusim sweep --shard k/N (rtu.sweep_on runs the N shards on an executor)."""
    import io

    import pandas as pd

    csv = _sweep_csv(scenes, formats, bvh_widths, configs, rays=rays, seed=seed, image_width=image_width,
                     threads=threads, area=area, flatten=flatten, shard=shard)
    return _sweep_frame(pd.read_csv(io.StringIO(csv), dtype=_SWEEP_DTYPES))


def _sweep_csv(scenes, formats, bvh_widths, configs, *, rays, seed, image_width, threads, area, flatten, shard):
    """rtu.sweep's rows as the CSV text rtusim sweep writes (header and one line per point)."""
    k, n = _shard(shard)
    scenes, formats, bvh_widths, configs = _grid(scenes, formats, bvh_widths, configs)
    return _rtu.sweep(scenes, formats, bvh_widths, configs, _int(rays, "rays"), _int(seed, "seed"),
                      _int(image_width, "image_width"), _int(threads, "threads"), _optional_path(area, "area"),
                      _bool(flatten, "flatten"), k, n)


def _grid(scenes, formats, bvh_widths, configs):
    """A sweep's grid: the lists of scene specs, format specs, BVH widths and configuration specs, checked."""
    return (_list(scenes, "scenes", "str"), _list(formats, "formats", "str"), _list(bvh_widths, "bvh_widths", "int"),
            _list(configs, "configs", "str"))


def _shard(shard):
    """(k, N) from None (the whole grid: (1, 1)), a pair or "k/N"; rtu.Error unless 1 <= k <= N."""
    if shard is None:
        return 1, 1
    try:
        k, n = (shard.split("/") if isinstance(shard, str) else shard)
        k, n = int(k), int(n)
    except (TypeError, ValueError):
        raise Error(f"shard: expected (k, N) or 'k/N', got {shard!r}") from None
    if not 1 <= k <= n:
        raise Error(f"shard: expected 1 <= k <= N, got {k}/{n}")
    return k, n


def _sweep_task(shard, shards, grid, options):
    """The body of one task of rtu.sweep_on, run on an executor's worker (a separate process on a Dask cluster or
    a process pool, so a module-level function the worker imports by name): shard `shard` of `shards` of the grid
    as CSV text. The one place that says what a task computes."""
    return _sweep_csv(*grid, shard=(shard, shards), **options)


def _manifest_task(shard, shards, manifest, points, threads, area):
    """The body of one task of rtu.sweep_on(results=...): shard `shard` of `shards` of the manifest's points into
    the folder `points`, as rtusim sweep --manifest --results --shard; (points, run, already there)."""
    return _rtu.run_manifest(manifest, points, shard, shards, threads, area)


def _run_tasks(executor, task, shards, *args):
    """Shards 1..shards of `task` on the executor; their results in shard order. A task that fails cancels the
    others and raises rtu.Error naming its shard."""
    futures = [executor.submit(task, k, shards, *args) for k in range(1, shards + 1)]
    results = []
    try:
        for k, f in enumerate(futures, start=1):
            try:
                results.append(f.result())
            except Exception as e:
                raise Error(f"sweep_on: shard {k}/{shards} failed: {type(e).__name__}: {e}") from e
    finally:
        for f in futures:
            f.cancel()  # after a failure, the shards not yet started (no-op on finished ones)
    return results


def sweep_on(executor, scenes, formats=("default",), bvh_widths=(4,), configs=("rdna2",), *, shards=None, rays=20000,
             seed=1, image_width=128, threads=1, area=None, flatten=False, results=None):
    """rtu.sweep's grid run as `shards` tasks on any concurrent.futures.Executor (a ProcessPoolExecutor, a Dask
    cluster's `Client.get_executor()`, submitit's or Ray's executors): task k runs shard k/shards (every
    shards-th point), and the DataFrame returned is rtu.sweep's of the whole grid, in its row order, the same but
    for the wall time `seconds`. shards defaults to the number of points (a task per point); threads is each
    task's (the executor's workers are the parallelism). Workers must import rtu (PYTHONPATH naming the build's
    python/ folder) and see the scene files at the same paths. A task that fails cancels the others and raises
    rtu.Error naming its shard, chained to the worker's exception.

    results: a folder every worker sees. The grid's points are written to results/manifest.txt, each with its
    content key, the tasks write one file per point to results/points/ (points whose file is there are skipped,
    so a rerun resumes), and the collected table to results/sweep.csv with results/sweep.csv.provenance.csv:
    the folder rtusim sweep --write-manifest, --manifest and --collect make (rtu.collect reads it back); the
    rows then come in the manifest's order, a point listed twice once. The manifest is created once: a call with
    another grid into the same folder, even at the same moment, raises rtu.Error before any of its points runs."""
    import io

    import pandas as pd

    grid = _grid(scenes, formats, bvh_widths, configs)
    points = len(grid[0]) * len(grid[1]) * len(grid[2]) * len(grid[3])
    shards = points if shards is None else _int(shards, "shards")
    if shards < 1:
        raise Error(f"shards: expected at least 1, got {shards}")
    shards = min(shards, points)  # a shard beyond the points would run none
    options = dict(rays=_int(rays, "rays"), seed=_int(seed, "seed"), image_width=_int(image_width, "image_width"),
                   threads=_int(threads, "threads"), area=_optional_path(area, "area") or None,
                   flatten=_bool(flatten, "flatten"))
    if results is not None:
        folder = _os.path.abspath(_path(results, "results"))
        _os.makedirs(folder, exist_ok=True)
        manifest = _os.path.join(folder, "manifest.txt")
        # The folder's manifest is created once, whole; a call with another grid is refused here, before any of
        # its points runs, so every call collects its own grid's points.
        *_, text = _rtu.write_manifest(manifest, *grid, options["rays"], options["seed"], options["image_width"],
                                       options["flatten"], options["area"] or "")
        _run_tasks(executor, _manifest_task, shards, manifest, _os.path.join(folder, "points"),
                   options["threads"], options["area"] or "")
        return _collect(folder, None, text)
    texts = _run_tasks(executor, _sweep_task, shards, grid, options)
    # The shards' lines back in the grid's order (line i of shard k is point (k - 1) + i * shards), read as one
    # CSV text: the DataFrame rtu.sweep reads from the whole grid's text.
    header, lines = None, [None] * points
    for k, text in enumerate(texts, start=1):
        head, *rows = text.splitlines()
        if header not in (None, head):
            raise Error(f"sweep_on: shard {k}/{shards} has another header than shard 1 (another rtu on a worker?)")
        header = head
        for i, row in enumerate(rows):
            point = k - 1 + i * shards
            if point >= points:
                raise Error(f"sweep_on: shard {k}/{shards} returned more rows than its points")
            lines[point] = row
    if None in lines:
        raise Error(f"sweep_on: point {lines.index(None)} of {points} is missing from shard "
                    f"{lines.index(None) % shards + 1}/{shards}")
    return _sweep_frame(pd.read_csv(io.StringIO("\n".join([header, *lines]) + "\n"), dtype=_SWEEP_DTYPES))


def collect(results, out=None):
    """A sweep folder's table (results/manifest.txt's points from results/points/, as rtusim sweep --collect) as
    a DataFrame; the CSV and its provenance (key, version, model, host, threads, seconds) are written to `out` and
    out.provenance.csv (default results/sweep.csv; refused when it names the manifest or a point file). rtu.Error
    naming the points without a file, or a point file of another build than the manifest's."""
    return _collect(results, out, None)


def _collect(results, out, manifest_text):
    """rtu.collect; with manifest_text, the folder's manifest must be that text (rtu.Error otherwise)."""
    import io

    import pandas as pd

    folder = _path(results, "results")
    manifest, points = _os.path.join(folder, "manifest.txt"), _os.path.join(folder, "points")
    out = _path(out, "out") if out is not None else _os.path.join(folder, "sweep.csv")
    for path in (out, out + ".provenance.csv"):  # written below: never one of the sweep's inputs
        real = _os.path.realpath(path)
        if real == _os.path.realpath(manifest) or _os.path.dirname(real) == _os.path.realpath(points):
            raise Error(f"collect: out {out} would overwrite the sweep's manifest or point files; name another file")
    if manifest_text is not None:
        with open(manifest, encoding="utf-8", newline="") as f:
            if f.read() != manifest_text:
                raise Error(f"sweep_on: {manifest} was replaced while the sweep ran (another sweep into the same "
                            "folder?); use a results folder per sweep")
    csv, provenance = _rtu.collect(manifest, points)
    for path, text in ((out, csv), (out + ".provenance.csv", provenance)):
        _rtu.check_output_file(path)  # a directory or a missing folder named as rtusim names them
        with open(path, "w", encoding="utf-8", newline="") as f:
            f.write(text)
    return _sweep_frame(pd.read_csv(io.StringIO(csv), dtype=_SWEEP_DTYPES))


# The model identity is 16 hex digits: read as text, or an all-digit one would become a number.
_SWEEP_DTYPES = {"model": str}


def _sweep_frame(df):
    """The derived column every plot uses: hit disagreement = 1 - hit agreement. A PSNR not measured (no render,
    an empty CSV cell) is NaN; flatten is a bool. The keys the rows' specs name get columns of their own
    (_swept_columns)."""
    df["psnr_db"] = df["psnr_db"].astype(float)
    df["flatten"] = df["flatten"].astype(bool)
    df["hit_disagreement"] = 1.0 - df["hit_agreement"]
    return _swept_columns(df)


def _spec_keys(spec):
    """The keys a spec "preset:key=value:..." changes, in its order."""
    return [kv.split("=", 1)[0] for kv in str(spec).split(":")[1:] if "=" in kv]


def _swept_columns(df):
    """Each key a row's format spec (packed:coord_bits=16) or configuration spec (rdna2:cache_kib=64, as
    rtusim sweep --set makes them) names, as a column of its own after "config": every row's value of the key,
    its spec's where the spec names it and its preset's otherwise, so that a key swept is a column to group or
    plot by. Keys the frame has a column for already (bvh_width; a format's width, which bvh_width replaces)
    are left to it. A spec this rtu cannot read (a CSV of another version) gives None in its rows."""
    if df.empty or "format" not in df.columns or "config" not in df.columns:
        return df

    def resolved(specs, resolve):
        values = {}
        for spec in specs.unique():
            try:
                values[spec] = resolve(spec)
            except Error:
                values[spec] = {}
        return values

    def config_of(spec):
        preset, *sets = str(spec).split(":")
        return _rtu.config(preset, sets)

    after = list(df.columns).index("config") + 1
    for column, resolve in (("format", lambda s: _rtu.format(str(s))), ("config", config_of)):
        keys = []
        for spec in df[column].unique():
            keys += [k for k in _spec_keys(spec) if k not in keys and k not in df.columns and k != "width"]
        if not keys:
            continue
        values = resolved(df[column], resolve)
        for key in keys:
            df.insert(after, key, [values[s].get(key) for s in df[column]])
            after += 1
    return df


def read_sweep(path):
    """A sweep CSV written by `rtusim sweep` as a DataFrame (the columns of rtu.sweep)."""
    import pandas as pd

    path = _path(path, "path")
    _rtu.check_input_file(path)  # a directory or a missing file named as rtusim names them
    # utf-8-sig: a byte order mark (a spreadsheet's) is not part of the first column's name.
    return _sweep_frame(pd.read_csv(path, encoding="utf-8-sig", dtype=_SWEEP_DTYPES))


def plan(scene, max_error, *, metric="hit", min_psnr=0.0, confidence=0.95, config="rdna2", format="",
         minimise="cycles", min_gain=2.0, area_budget=0.0, bvh_widths=(2, 4, 6, 8),
         coord_bits=tuple(range(8, 29, 2)), child_bits=(4, 6, 8, 12), rays=20000, seed=1, image_width=128,
         threads=0, area=None, flatten=False):
    """The cheapest format within an error budget, as `rtusim plan`: its --json dict ("plan" is None when no
    format meets the budget) with every candidate measured as a DataFrame under "candidates" (the sweep's
    columns, "meets" and "perf_per_mm2", rays per clock per mm^2). minimise: cycles, bytes, energy, area or
    perf-per-area; min_gain: the percentage a candidate with more bits or area must save (rtusim plan
    --min-gain). flatten: instanced scenes in one image (rtusim plan --flatten)."""
    import io

    import pandas as pd

    if isinstance(scene, Scene):
        scene = scene.name
    if isinstance(scene, _os.PathLike):
        scene = _os.fspath(scene)
    scene = _str(scene, "scene", "a scene spec or an rtu.Scene")
    text = {name: _str(value, name, "a str") for name, value in
            (("metric", metric), ("config", config), ("format", format), ("minimise", minimise))}
    j, csv, meets, perf = _rtu.plan(scene, _number(max_error, "max_error"), text["metric"],
                                    _number(min_psnr, "min_psnr"), _number(confidence, "confidence"),
                                    text["config"], text["format"], text["minimise"], _number(min_gain, "min_gain"),
                                    _number(area_budget, "area_budget"), _list(bvh_widths, "bvh_widths", "int"),
                                    _list(coord_bits, "coord_bits", "int"), _list(child_bits, "child_bits", "int"),
                                    _int(rays, "rays"), _int(seed, "seed"), _int(image_width, "image_width"),
                                    _int(threads, "threads"), _optional_path(area, "area"), _bool(flatten, "flatten"))
    df = _sweep_frame(pd.read_csv(io.StringIO(csv), dtype=_SWEEP_DTYPES))
    df["meets"] = meets
    df["perf_per_mm2"] = perf
    j["candidates"] = df
    return j


def pareto_front(df, cost="cycles", error="hit_disagreement"):
    """A boolean Series: the rows of df on the Pareto front of (cost, error), both minimised (host/jobs/pareto.h's
    rule: no other row at most as costly and at most as wrong and better in one). Rows with a negative cost
    (unknown, e.g. rtl_cells = -1) are never on it."""
    import pandas as pd

    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"df: expected a DataFrame of sweep rows (rtu.sweep, rtu.read_sweep), got {type(df).__name__}")
    for name, column in (("cost", cost), ("error", error)):
        if column not in df.columns:
            raise Error(f"{name}: the frame has no column {column!r} (columns: {', '.join(map(str, df.columns))})")
    known = df[df[cost] >= 0]
    idx = _rtu.pareto_front(list(zip(known[cost].astype(float), known[error].astype(float))))
    mask = pd.Series(False, index=df.index)
    mask.loc[known.index[list(idx)]] = True
    return mask
