#!/usr/bin/python3
"""Check README.md's "Current figures" against the commands that produce them.

    /usr/bin/python3 bench/check_figures.py [--rtusim PATH] [--build DIR] [--all] [ROW_ID ...]

For each row of the README table the script finds the row (by its first cell), reads the figures the row states
out of its text with a pattern (so a row whose text changed without the script, or the other way round, fails
instead of passing silently), runs the row's command (or a cheaper command named below that yields the same
figure), extracts the figures from the command's output, stats JSON or CSV, and compares them within the
tolerance written beside each check:

- cycles, bytes, hit counts, errors and ratios of them are deterministic (the same on every machine and thread
  count), so they must equal the stated figure to the digits the README prints (the measured value rounded like
  the stated one);
- wall-time figures (MRays/s, ratios against Embree, the simulator's speed) move by up to 2x on this project's
  shared 2-core VM from one run to the next, so they pass within a stated relative band.

Rows whose command takes more than about 5 minutes are skipped (SKIP with the reason) unless --all is given.
Output: one line per row, PASS, FAIL or SKIP with measured against stated figures; exit status 1 if any row
failed, 2 on a usage error. Standard library only.
"""

import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MODELS = "/usr/share/assimp/models"
HOUSE = f"{MODELS}/IFC/AC14-FZK-Haus.ifc"
ENGINE = f"{MODELS}/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"
SUZANNE = f"{MODELS}/BLEND/SuzanneSubdiv_252.blend"


class Drift(Exception):
    """The README row no longer states the figure this check reads."""


class CommandFailed(Exception):
    pass


# ---------------------------------------------------------------------------------------------------- helpers


def readme_rows(path):
    """The "Current figures" table: {first cell: whole row text}."""
    text = open(path, encoding="utf-8").read()
    m = re.search(r"^## Current figures\n(.*?)(?=^## )", text, re.S | re.M)
    if not m:
        raise SystemExit("check_figures.py: README.md has no '## Current figures' section")
    rows = {}
    for line in m.group(1).splitlines():
        if not line.startswith("| ") or line.startswith("| question") or line.startswith("|---"):
            continue
        first = line.split("|")[1].strip()
        rows[first] = line
    return rows


def stated(row, pattern):
    """The groups of `pattern` in the README row; Drift if the row does not say it any more."""
    m = re.search(pattern, row)
    if not m:
        raise Drift(f"README row no longer matches /{pattern}/")
    return m.groups()


def like(value, text):
    """`value` printed with the digits of the stated `text` (decimals, or significant digits in e-notation)."""
    text = text.strip()
    if "e" in text.lower():
        mant = text.lower().split("e")[0]
        digits = len(mant.replace("-", "").replace(".", "").lstrip("0")) or 1
        return f"{value:.{digits - 1}e}"
    decimals = len(text.split(".")[1]) if "." in text else 0
    return f"{value:.{decimals}f}"


def same_digits(value, text):
    """Deterministic figure: equal to the stated one once rounded to its printed digits."""
    return float(like(value, text)) == float(text)


def in_band(value, text, lo, hi):
    """Wall-time figure: value / stated within [lo, hi]."""
    s = float(text)
    return s > 0 and lo <= value / s <= hi


class Result:
    def __init__(self):
        self.items = []  # (label, measured, stated, ok)

    def exact(self, label, value, text):
        self.items.append((label, like(value, text), text, same_digits(value, text)))

    def equal(self, label, measured, text):
        self.items.append((label, str(measured), text, str(measured) == text))

    def band(self, label, value, text, lo, hi):
        self.items.append((label, f"{value:.3g}", text, in_band(value, text, lo, hi)))

    def note(self, label, text):
        self.items.append((label, text, "", True))

    @property
    def ok(self):
        return all(i[3] for i in self.items)

    def line(self):
        parts = []
        for label, meas, st, ok in self.items:
            if st == "":
                parts.append(f"{label}: {meas}")
            else:
                parts.append(f"{label} {meas} vs {st}{'' if ok else ' (!)'}")
        return "; ".join(parts)


class Ctx:
    def __init__(self, rtusim, build, tmp, verbose):
        self.rtusim = rtusim
        self.build = build
        self.tmp = tmp
        self.verbose = verbose
        self.cache = {}

    def run(self, args, env=None, cwd=None, key=None):
        """Run a command; its stdout. Cached by `key` (rows sharing one command run it once)."""
        if key and key in self.cache:
            return self.cache[key]
        e = dict(os.environ)
        e.update(env or {})
        if self.verbose:
            print("  $ " + " ".join(args), file=sys.stderr, flush=True)
        p = subprocess.run(args, cwd=cwd or ROOT, env=e, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if p.returncode != 0:
            raise CommandFailed(f"`{' '.join(args)}` exited {p.returncode}: {p.stderr.strip()[-400:]}")
        if key:
            self.cache[key] = p.stdout
        return p.stdout

    def path(self, name):
        return os.path.join(self.tmp, name)


def md_tables(text):
    """Every Markdown table in text: a list of lists of {header: cell}."""
    tables, cur, head = [], None, None
    for line in text.splitlines():
        line = line.strip()
        if not line.startswith("|"):
            if cur is not None:
                tables.append(cur)
            cur, head = None, None
            continue
        cells = [c.strip() for c in line.strip("|").split("|")]
        if head is None:
            head, cur = [], []
            for c in cells:  # a repeated header ("DRAM B/ray" after each preset) gets " 2", " 3", ...
                n = sum(1 for h in head if h == c or h.startswith(c + " "))
                head.append(c if n == 0 else f"{c} {n + 1}")
        elif all(re.fullmatch(r":?-+:?", c) for c in cells if c):
            continue
        else:
            cur.append(dict(zip(head, cells)))
    if cur is not None:
        tables.append(cur)
    return tables


def table_with(text, column):
    for t in md_tables(text):
        if t and column in t[0]:
            return t
    raise CommandFailed(f"no table with a '{column}' column in the command's output")


def num(cell):
    return float(re.sub(r"[^0-9.eE+-]", "", cell.replace(",", "")))


# ---------------------------------------------------------------------------------------------------- checks
# Each check: (id, first cell of its README row, slow reason or None, function(row, ctx, all) -> Result).


def check_fixed_float(row, ctx, full):
    # README: hit agreement H% on N M rays of two meshes; node overhead +A-B%; Z box false negatives.
    # The row's command, bench/format_sweep.sh 300000 (about a minute): H, N and the overheads from its
    # default-format rows, Z summed over every row. Tolerance: deterministic, exact to the printed digits.
    h, n, a, b, z = stated(row, r"hit agreement ([\d.]+)% on ([\d.]+)M rays of two meshes; node overhead "
                                r"\+([\d.]+)-([\d.]+)%; (\d+) box false negatives")
    rays = 300000
    out = ctx.run(["bench/format_sweep.sh", ctx.rtusim, str(rays)])
    t = table_with(out, "box false neg.")
    agree, over, fneg, total = [], [], 0, 0
    for x in t:
        fneg += int(x["box false neg."])
        if x["format"].startswith("default"):
            agree.append(num(x["hit agreement"]))
            over.append(num(x["node / prim overhead"].split("/")[0]))
            total += rays  # 4 default rows (2 meshes x primary, incoherent) of 300,000 rays: 1.2M
    r = Result()
    r.exact("hit agreement %", min(agree), h)
    r.exact("rays (M)", total / 1e6, n)
    r.exact("node overhead min %", min(over), a)
    r.exact("max %", max(over), b)
    r.equal("box false negatives (every format)", fneg, z)
    return r


def check_watertight(row, ctx, full):
    # README: 0 leaks in X M float and Y M fixed rays (...); 0 false negatives in Z M exactly checked box tests.
    # The leak tests count their rays by construction (tests/oracle/test_watertight.cpp) and pass only with 0
    # leaks, so the leak figure is their exit status and X, Y are not re-counted. The box tests are those of the
    # row's stress run (`rtusim stress --count 100000`: every category's fixed-device box_checks), of
    # `test_hwmodel "[box]"` (2M cases by construction, passing only with 0 false negatives) and of `rtusim compare`
    # on 2CylinderEngine's 1M incoherent rays (watertightness.md), each repeated in exact arithmetic.
    # Tolerance: 0 exactly; Z to the printed digits.
    leaks, _, _, fn, total = stated(row, r"(\d+) leaks in ([\d.]+)M float and ([\d.]+)M fixed rays.*?; (\d+) false "
                                         r"negatives in (\d+)M exactly checked box tests")
    r = Result()
    ctx.run([os.path.join(ctx.build, "tests/test_oracle"), "[watertight]"])
    r.equal("leaks (test_oracle [watertight] passes)", 0, leaks)
    ctx.run([os.path.join(ctx.build, "tests/test_hwmodel"), "[box]"])
    f = ctx.path("stress.json")
    ctx.run([ctx.rtusim, "stress", "--count", "100000", "--json", f], key="stress")
    j = json.load(open(f))
    bad = sum(deep_sum(c["figures"], "box_false_negatives") for c in j["categories"])
    checks = sum(deep_sum(c["figures"], "box_checks") for c in j["categories"])
    c = ctx.path("engine1m.json")
    ctx.run([ctx.rtusim, "compare", "--scene", ENGINE, "--rays", "incoherent:1000000", "--json", c])
    e = json.load(open(c))
    bad += int(e["box_false_negatives"])
    checks += int(e["box_checks"]) + 2_000_000
    r.equal("box false negatives", bad, fn)
    r.exact("box tests (M)", checks / 1e6, total)
    r.note("rays", "the leak tests' ray counts are fixed by their code")
    return r


def deep_sum(d, key):
    """The sum of every `key` in a nested dict (stress figures nest per sub-case: centered, far, cells, ...)."""
    if not isinstance(d, dict):
        return 0
    return sum(int(v) if k == key else deep_sum(v, key) for k, v in d.items())


def check_embree(row, ctx, full):
    # README: D hit/miss disagreements in N M rays. `test_oracle "[embree]" -s` prints one line per scene and
    # kind ("...: N rays, D hit/miss disagreements, ..."). Tolerance: D exactly; rays to the printed digits.
    d, n = stated(row, r"(\d+) hit/miss disagreements? in ([\d.]+)M rays")
    out = ctx.run([os.path.join(ctx.build, "tests/test_oracle"), "[embree]", "-s"])
    rays = dis = 0
    for m in re.finditer(r": (\d+) rays, (\d+) hit/miss disagreements", out):
        rays += int(m.group(1))
        dis += int(m.group(2))
    if rays == 0:
        raise CommandFailed("test_oracle printed no agreement lines")
    r = Result()
    r.equal("disagreements", dis, d)
    r.exact("rays (M)", rays / 1e6, n)
    return r


def trace_bench(ctx):
    f = ctx.path("trace_bench.json")
    ctx.run([os.path.join(ctx.build, "trace_bench"), "--rays", "300000", "--json", f], key="trace_bench")
    rows = json.load(open(f))
    by = {}
    for x in rows:
        by.setdefault(x["mesh"], {})[x["tracer"]] = x
    return by


# Wall time: this VM's speed moves by up to 1.5-2x within minutes (speed-vs-embree.md: four quiet runs gave
# fixed/Embree 0.19-0.38x), and a ratio against Embree only cancels part of it (the tracers run one after the
# other). A speed figure passes when measured / stated lies in [0.5, 2]. Peak memory is not noise of that kind
# (the same allocations each run): +-15%.
SPEED_BAND = (0.5, 2.0)
MEMORY_BAND = (0.85, 1.15)


def check_speed_embree(row, ctx, full):
    g = stated(row, r"float ([\d.]+)-([\d.]+)x primary, ([\d.]+)-([\d.]+)x incoherent; fixed ([\d.]+)-([\d.]+)x "
                    r"and ([\d.]+)-([\d.]+)x; peak memory ([\d.]+)-([\d.]+)x")
    by = trace_bench(ctx)
    r = Result()
    vals = {}
    for tracer in ("rtu-float", "rtu-fixed"):
        for kind in ("primary", "incoherent"):
            vals[(tracer, kind)] = [m[tracer][f"{kind}_mrays_per_s"] / m["embree"][f"{kind}_mrays_per_s"]
                                    for m in by.values()]
    mem = [m[t]["peak_rss_bytes"] / m["embree"]["peak_rss_bytes"] for m in by.values()
           for t in ("rtu-float", "rtu-fixed")]
    i = 0
    for tracer in ("rtu-float", "rtu-fixed"):
        for kind in ("primary", "incoherent"):
            v = vals[(tracer, kind)]
            r.band(f"{tracer[4:]}/embree {kind} min", min(v), g[i], *SPEED_BAND)
            r.band("max", max(v), g[i + 1], *SPEED_BAND)
            i += 2
    r.band("peak memory min", min(mem), g[8], *MEMORY_BAND)
    r.band("max", max(mem), g[9], *MEMORY_BAND)
    # The same row's timed device: its simulation speed on camera rays (the same trace_bench run).
    lo, hi = stated(row, r"timed device ([\d.]+)-([\d.]+) M primary rays/s")
    v = [m["rtu-timed"]["primary_mrays_per_s"] for m in by.values()]
    r.band("timed M primary rays/s min", min(v), lo, *SPEED_BAND)
    r.band("max", max(v), hi, *SPEED_BAND)
    r.note("band", "speed x0.5-2, memory +-15%")
    return r


def check_cycles(row, ctx, full):
    # README: rdna2 camera a-b, incoherent c-d cycles per ray; intel e-f and g-h, over the three meshes.
    # Tolerance: deterministic, exact to the printed digits.
    g = stated(row, r"([\d.]+)-([\d.]+) camera rays, ([\d.]+)-([\d.]+) incoherent rays; `intel` ([\d.]+)-([\d.]+) "
                    r"and ([\d.]+)-([\d.]+)")
    out = ctx.run(["bench/cycles_table.sh", ctx.rtusim])
    t = table_with(out, "cycles/ray")
    r = Result()
    i = 0
    for preset in ("rdna2", "intel"):
        for kind in ("primary", "incoherent"):
            # cycles / rays, not the table's rounded cycles/ray (8.35 there is 8.351 and prints as 8.4)
            v = [num(x["cycles"]) / num(x["rays"].split()[1]) for x in t
                 if x["preset"] == preset and x["rays"].startswith(kind) and not x["scene"].startswith("builtin:")]
            if len(v) != 3:
                raise CommandFailed(f"expected 3 mesh rows of {preset} {kind}, found {len(v)}")
            r.exact(f"{preset} {kind} min", min(v), g[i])
            r.exact("max", max(v), g[i + 1])
            i += 2
    return r


SWEEP_STRUCT = ["sweep", "--scene", HOUSE, "--scene", ENGINE, "--formats",
                "default,default:coord_bits=12,default:coord_bits=16,default:coord_bits=20,default:child_bits=4,compact",
                "--bvh-width", "4,8", "--config", "rdna2", "--rays", "20000", "--area", "bench/data/rtl_area.csv"]
SWEEP_PACKED = ["sweep", "--scene", HOUSE, "--scene", ENGINE, "--formats",
                "default,packed:coord_bits=12,packed:coord_bits=16,packed:coord_bits=20,packed,packed:coord_bits=28",
                "--bvh-width", "4", "--config", "rdna2,rdna2-mem", "--rays", "20000", "--area",
                "bench/data/rtl_area.csv"]


def sweep(ctx, args, name):
    f = ctx.path(name)
    if os.path.exists(f):
        os.remove(f)
    ctx.run([ctx.rtusim] + args + ["--out", f], key=name)
    return list(csv.DictReader(open(f)))


def check_coord_bits(row, ctx, full):
    # README: 16 instead of 24: hit agreement H%, at most C% more cycles, A% less box-unit area. The first sweep
    # of bench/results/pareto-and-scaling.md (two meshes, BVH4 and BVH8, rdna2, 20,000 + 20,000 rays).
    # H: the lowest hit agreement of the 16-bit points; C: the largest cycle increase of a 16-bit point over the
    # 24-bit point of the same mesh and width; A: RTL box-unit cells, 16 against 24 bits.
    # Tolerance: deterministic, exact to the printed digits.
    h, c, a = stated(row, r"16 instead of 24: hit agreement ([\d.]+)%, at most ([\d.]+)% more cycles, (\d+)% less "
                          r"box-unit area")
    rows = sweep(ctx, SWEEP_STRUCT, "sweep_struct.csv")
    base = {(x["scene"], x["bvh_width"]): x for x in rows if x["format"] == "default"}
    b16 = [x for x in rows if x["format"] == "default:coord_bits=16"]
    r = Result()
    r.exact("hit agreement %", min(100 * float(x["hit_agreement"]) for x in b16), h)
    r.exact("cycles +%", max(100 * (int(x["cycles"]) / int(base[(x["scene"], x["bvh_width"])]["cycles"]) - 1)
                            for x in b16), c)
    cells16 = [int(x["rtl_cells"]) for x in b16 if int(x["rtl_cells"]) > 0][0]
    cells24 = [int(x["rtl_cells"]) for x in base.values() if int(x["rtl_cells"]) > 0][0]
    r.exact("box-unit area -%", 100 * (1 - cells16 / cells24), a)
    return r


def check_packed(row, ctx, full):
    # README: CWBVH-like BVH8 nodes a-b% of the float BVH2's; 16-bit packed grid -c to -d% DRAM bytes per ray,
    # e-fx fewer cycles on rdna2-mem; both against the widest structs (16-bit offsets), bench/compression.sh.
    # Tolerance: deterministic, exact to the printed digits.
    g = stated(row, r"CWBVH-like BVH8 nodes (\d+)-(\d+)% of the float BVH2's.*?16-bit packed grid -(\d+) to -(\d+)% "
                    r"DRAM bytes per ray, ([\d.]+)-([\d.]+)x fewer cycles on `rdna2-mem`")
    out = ctx.run(["bench/compression.sh", ctx.rtusim, "50000"])
    tabs = [t for t in md_tables(out) if t and "nodes of float BVH2 nodes" in t[0]]
    if len(tabs) != 2:
        raise CommandFailed(f"expected 2 format tables, found {len(tabs)}")
    cw, dram, cyc = [], [], []
    for t in tabs:
        by = {x["format"]: x for x in t}
        cw.append(num(by["compressed-wide BVH8 + blocks"]["nodes of float BVH2 nodes"]))
        wide = by["structs, 16-bit offsets, BVH4"]
        narrow = by["bit-packed BVH4 + blocks, 16-bit grid, 6-bit offsets"]
        # the first "DRAM B/ray" column follows "rdna2-mem cycles"
        dram.append(100 * (1 - num(narrow["DRAM B/ray"]) / num(wide["DRAM B/ray"])))
        cyc.append(num(wide["rdna2-mem cycles"]) / num(narrow["rdna2-mem cycles"]))
    r = Result()
    r.exact("CWBVH nodes min %", min(cw), g[0])
    r.exact("max %", max(cw), g[1])
    r.exact("DRAM bytes min -%", min(dram), g[2])
    r.exact("max -%", max(dram), g[3])
    r.exact("fewer cycles min x", min(cyc), g[4])
    r.exact("max x", max(cyc), g[5])
    return r


def check_energy(row, ctx, full):
    # README: rdna2 A mm^2, B nJ per camera ray and C per incoherent ray, D-E% of it in the units; 32-bit
    # multiply F pJ; 12-bit coordinates -G% area. bench/energy.sh (the house, 50,000 rays per kind).
    # Tolerance: deterministic (simulated energy), exact to the printed digits.
    g = stated(row, r"`rdna2` ([\d.]+) mm\^2, ([\d.]+) nJ per camera ray and ([\d.]+) per incoherent ray, "
                    r"(\d+)-(\d+)% of it in the units; 32-bit multiply ([\d.]+) pJ.*?12-bit coordinates -(\d+)% area")
    out = ctx.run(["bench/energy.sh", ctx.rtusim, "50000"])
    t = table_with(out, "pJ/ray")
    rd = {x["rays"]: x for x in t if x["preset"] == "rdna2"}
    r = Result()
    r.exact("rdna2 mm^2", num(rd["primary"]["area mm^2 (units + SRAM)"].split()[0]), g[0])
    r.exact("camera nJ", num(rd["primary"]["pJ/ray"]) / 1000, g[1])
    r.exact("incoherent nJ", num(rd["incoherent"]["pJ/ray"]) / 1000, g[2])
    units = [num(x["units"]) for x in t]
    r.exact("units min %", min(units), g[3])
    r.exact("max %", max(units), g[4])
    m = re.search(r"32-bit integer multiply\s+([\d.]+) pJ", out)
    if not m:
        raise CommandFailed("no multiply line in energy.sh's output")
    r.exact("multiply pJ", float(m.group(1)), g[5])
    aq = table_with(out, "area vs 24 bits")
    b12 = [x for x in aq if x["format"] == "default:coord_bits=12"][0]
    r.exact("12-bit area -%", -num(b12["area vs 24 bits"]), g[6])
    return r


def check_two_level(row, ctx, full):
    # README: city Nx fewer bytes, Mx fewer incoherent cycles; engine +P% on camera rays. bench/two_level.sh.
    # Tolerance: deterministic, exact to the printed digits.
    n, m, p = stated(row, r"city (\d+)x fewer bytes, ([\d.]+)x fewer incoherent cycles; engine \+(\d+)% on camera rays")
    out = ctx.run(["bench/two_level.sh", ctx.rtusim, "100000"])
    bt = table_with(out, "two-level bytes")
    city = [x for x in bt if x["scene"] == "builtin:city"][0]
    ct = table_with(out, "cycles two / one")

    def cyc(scene, kind, levels):
        return [num(x["cycles"]) for x in ct
                if x["scene"] == scene and x["rays"].startswith(kind) and x["levels"].startswith(levels)][0]

    r = Result()
    r.exact("city bytes x", num(city["flattened image bytes"]) / num(city["two-level bytes"]), n)
    r.exact("city incoherent x", cyc("builtin:city", "incoherent", "one") / cyc("builtin:city", "incoherent", "two"), m)
    r.exact("engine camera +%", 100 * (cyc("2CylinderEngine.glb", "primary", "two") /
                                       cyc("2CylinderEngine.glb", "primary", "one") - 1), p)
    return r


def check_motion(row, ctx, full):
    # README: time-aware A-Bx; time-oblivious Cx (small moves) to Dx. bench/results/motion-blur.md: the time-aware
    # unit's ratio to the static frame at motion scale 0 and 1 (its least and largest), the time-oblivious unit's
    # at scale 0.1 with a 100-clock shader round trip and at scale 1 (rdna2's 400). `rtusim motion --json`, 320x240
    # at 4 shutter times. Tolerance: deterministic cycles, exact to the printed digits.
    a, b, c, d = stated(row, r"time-aware ([\d.]+)-([\d.]+)x; time-oblivious ([\d.]+)x \(small moves\) to (\d+)x")

    def ratios(name, *args):
        f = ctx.path(name)
        ctx.run([ctx.rtusim, "motion", "--json", f, *args], key=name)
        return [x["ratio_to_static"] for x in json.load(open(f))["designs"]]

    still, full_moves = ratios("motion0.json", "--motion-scale", "0"), ratios("motion1.json")
    small = ratios("motion01.json", "--motion-scale", "0.1", "--set", "any_hit_latency=100")
    r = Result()
    r.exact("time-aware at no motion", still[1], a)
    r.exact("at full moves", full_moves[1], b)
    r.exact("time-oblivious, small moves, 100-clock shader", small[2], c)
    r.exact("full moves", full_moves[2], d)
    return r


def check_queries(row, ctx, full):
    # README: one rdna2 unit A-Bx a nanoflann thread. build/default/query_bench (about a minute): the rdna2 column's
    # ratios against nanoflann measured in the same run, the least and the largest. Tolerance: wall time (x0.5-2).
    a, b = stated(row, r"one `rdna2` unit ([\d.]+)-([\d.]+)x a nanoflann thread")
    out = ctx.run([os.path.join(ctx.build, "query_bench")], key="query_bench")
    # Each row: `| rdna2 cycles | rdna2 queries/s (ratio) | rdna4 ... |`; the rdna2 ratios are every other match.
    ratios = [float(m) for m in re.findall(r"\| [\d.]+ \| \d+ \(([\d.]+)x\) (?=\|)", out)[0::2]]
    if not ratios:
        raise CommandFailed("query_bench printed no rdna2 ratios")
    r = Result()
    r.band("least", min(ratios), a, *SPEED_BAND)
    r.band("largest", max(ratios), b, *SPEED_BAND)
    r.note("band", "speed x0.5-2")
    return r


def check_stress(row, ctx, full):
    # README: F failures in N M hostile cases on both devices. `rtusim stress --count 100000 --json`: its total
    # cases and failures. Tolerance: failures exactly, cases to the printed digits.
    f_, n = stated(row, r"(\d+) failures in ([\d.]+)M hostile cases")
    f = ctx.path("stress.json")
    ctx.run([ctx.rtusim, "stress", "--count", "100000", "--json", f], key="stress")
    j = json.load(open(f))
    r = Result()
    r.equal("failures", int(j["failures"]), f_)
    r.exact("cases (M)", int(j["cases"]) / 1e6, n)
    return r


def check_hybrid(row, ctx, full):
    # README: a-bx direct lighting at 1 spp; c-dx path tracing; e-fx at 13 triangles per pixel.
    # bench/hybrid_table.sh: depth-0 rows of the built-in scenes at default detail (seed, cornell, icosphere),
    # depth-4 rows, and SuzanneSubdiv_252 at 160x120 (252k triangles over 19,200 pixels).
    # Tolerance: deterministic (cycle ratios), exact to the printed digits.
    g = stated(row, r"([\d.]+)-([\d.]+)x direct lighting at 1 spp; ([\d.]+)-([\d.]+)x path tracing; ([\d.]+)-([\d.]+)x "
                    r"at 13 triangles per pixel")
    out = ctx.run(["bench/hybrid_table.sh", ctx.rtusim])
    t = table_with(out, "hybrid speedup")
    direct = [num(x["hybrid speedup"]) for x in t
              if x["size, spp, depth"].endswith(", 1, 0") and x["scene"] in
              ("builtin:seed", "builtin:cornell", "builtin:icosphere")]
    path = [num(x["hybrid speedup"]) for x in t if x["size, spp, depth"].endswith(", 4")]
    dense = [num(x["hybrid speedup"]) for x in t
             if x["scene"].startswith("SuzanneSubdiv_252") and x["size, spp, depth"].startswith("160x120")]
    r = Result()
    for i, (label, v) in enumerate((("direct", direct), ("path", path), ("13 tri/pixel", dense))):
        r.exact(f"{label} min x", min(v), g[2 * i])
        r.exact("max x", max(v), g[2 * i + 1])
    return r


def check_sampled(row, ctx, full):
    # README: a-bx faster on camera rays, c-dx on incoherent; rms error e-f% and g-h% over 30 seeds. The row's
    # command (several minutes). The speed-ups are wall time (x0.5-2). The rms errors are deterministic (the
    # estimates of seeds 1-30 against the full simulation's cycles): exact to the printed digits.
    g = stated(row, r"([\d.]+)-([\d.]+)x faster on camera rays, ([\d.]+)-([\d.]+)x on incoherent; rms error "
                    r"([\d.]+)-([\d.]+)% and ([\d.]+)-([\d.]+)% over 30 seeds")
    out = ctx.run(["bench/sample_bench.sh", ctx.rtusim, "4000000"],
                  env={"SEEDS": "30", "REPEAT": "1", "FRACTIONS": "0.01", "MODES": "cycles-only"})
    t = table_with(out, "rms error")
    r = Result()
    for i, kind in enumerate(("primary", "incoherent")):
        v = [num(x["speed-up"]) for x in t if x["rays"] == kind]
        r.band(f"{kind} speed-up min", min(v), g[2 * i], *SPEED_BAND)
        r.band("max", max(v), g[2 * i + 1], *SPEED_BAND)
    for i, kind in enumerate(("primary", "incoherent")):
        v = [num(x["rms error"]) for x in t if x["rays"] == kind]
        r.exact(f"{kind} rms % min", min(v), g[4 + 2 * i])
        r.exact("max", max(v), g[5 + 2 * i])
    return r


def check_chip(row, ctx, full):
    # README: `rdna2-chip` (80 units) at 16 B/clock: flat from F units (first principles: c-d).
    # BANDWIDTH=16 bench/chip_scaling.sh 200000 (about 20 s): c-d are the engine's first-principles knees (its
    # camera and incoherent rows; the house's lie beyond 80 units), deterministic, exact. "Flat from F" reads the
    # engine's speed-up curves: the first unit count from which the speed-up grows by less than 10% to the next
    # count, the same for both ray kinds; deterministic, exact.
    g = stated(row, r"flat from (\d+) units \(first principles: (\d+)-(\d+)\)")
    out = ctx.run(["bench/chip_scaling.sh", ctx.rtusim, "200000"], env={"BANDWIDTH": "16"})
    t = table_with(out, "knee (units)")
    eng = [x for x in t if x["mesh"].startswith("2CylinderEngine")]
    knees = [num(x["knee (units)"]) for x in eng]
    flat = []
    for kind in ("primary", "incoherent"):
        rows = sorted(((int(x["units"]), num(x["speed-up"])) for x in eng if x["rays"] == kind))
        flat.append(next((u for (u, s), (_, s2) in zip(rows, rows[1:]) if s2 < 1.1 * s), rows[-1][0]))
    r = Result()
    if len(set(flat)) != 1:
        r.note("flat from", f"camera {flat[0]}, incoherent {flat[1]} units differ")
        r.items.append(("flat from", str(flat), g[0], False))
    else:
        r.exact("flat from", flat[0], g[0])
    r.exact("knee min", min(knees), g[1])
    r.exact("max", max(knees), g[2])
    return r


def check_rtl_box(row, ctx, full):
    # README: `rdna2` unit C cells, D with 1 lane. bench/rtl_area.sh (yosys; deterministic cell counts, exact).
    c, d = stated(row, r"`rdna2` unit ([\d,]+) cells, ([\d,]+) with 1 lane")
    out = ctx.run(["bench/rtl_area.sh", ctx.build, "300000"])
    t = table_with(out, "cells")
    by = {x["unit"]: x for x in t}
    r = Result()
    r.equal("rdna2 cells", f"{int(num(by['rdna2']['cells'])):,}", c)
    r.equal("1 lane", f"{int(num(by['rdna2,lanes=1']['cells'])):,}", d)
    r.note("bit-exact tests", "counted by the RTL testbench, not re-counted")
    return r


def check_rtl_trav(row, ctx, full):
    # README: N packets: mean error M%, largest L%, r R; D designs ranked alike. bench/rtl_correlation.sh on
    # rtu_rtl_trav_bench (Verilator and the timing model: deterministic cycles, exact to the printed digits).
    g = stated(row, r"(\d+) packets: mean error ([\d.]+)%, largest ([\d.]+)%, r ([\d.]+); (\d+) designs ranked alike")
    subprocess.run(["cmake", "--build", ctx.build, "--target", "rtu_rtl_trav_bench", "-j2"], cwd=ROOT, check=True,
                   stdout=subprocess.DEVNULL)
    out = ctx.run(["bench/rtl_correlation.sh", os.path.join(ctx.build, "rtl_sim/rtu_rtl_trav_bench")])
    m = re.search(r"All (\d+) packets: mean absolute error ([\d.]+)%, largest ([\d.]+)%, correlation ([\d.]+)", out)
    d = re.search(r"(\d+) designs: Kendall's tau ([\d.]+)", out)
    if not m or not d:
        raise CommandFailed("no summary line in rtl_correlation.sh's output")
    r = Result()
    r.exact("packets", int(m.group(1)), g[0])
    r.exact("mean error %", float(m.group(2)), g[1])
    r.exact("largest %", float(m.group(3)), g[2])
    r.exact("r", float(m.group(4)), g[3])
    r.exact("designs", int(d.group(1)), g[4])
    r.equal("ranked alike (Kendall's tau 1)", d.group(2), "1.0000")
    return r


def check_rtl_tri(row, ctx, full):
    # README: `rdna2` unit C cells, `embedded` D. test_rtl_tri must pass; bench/rtl_tri_area.sh gives the cells
    # (yosys; deterministic, exact).
    c, d = stated(row, r"`rdna2` unit ([\d,]+) cells, `embedded` ([\d,]+)")
    ctx.run([os.path.join(ctx.build, "rtl_sim/test_rtl_tri")])
    out = ctx.run(["bench/rtl_tri_area.sh", ctx.build])
    t = table_with(out, "cells")
    by = {x["unit"]: x for x in t}
    r = Result()
    r.equal("rdna2 cells", f"{int(num(by['rdna2']['cells'])):,}", c)
    r.equal("embedded", f"{int(num(by['embedded']['cells'])):,}", d)
    return r


def check_sim_speed(row, ctx, full):
    # README: the atrium's 1080p frame (33M rays) on `rdna2-chip`: A s full, B s sampled (E%); the fixed device
    # C s; the units' replay R x on 2 threads. bench/simulator_speed.sh on the atrium (about 5 minutes), and
    # chip_threads_bench on 1M rays (half a minute). The seconds are wall time and the replay's speed-up a
    # same-run ratio: x0.5-2. The sampled frame's error against the full one is deterministic (cycles, seed 1):
    # exact. Every counter of the replay on 2 threads must equal one thread's.
    g = stated(row, r"atrium at 1080p on `rdna2-chip`: ([\d.]+) s full, ([\d.]+) s sampled at 1 in 10 "
                    r"\(([+-][\d.]+)%\); fixed device ([\d.]+) s; units' replay ([\d.]+)x on 2 threads")
    out = ctx.run(["bench/simulator_speed.sh", ctx.rtusim, "builtin:atrium"])
    t = table_with(out, "simulated rays / s / core")
    by = {x["device"]: x for x in t if x["scene"] == "builtin:atrium"}
    r = Result()
    r.band("full s", num(by["rdna2-chip"]["render s"]), g[0], *SPEED_BAND)
    sampled = by["rdna2-chip, dynamic, --sample 0.1"]
    r.band("sampled s", num(sampled["render s"]), g[1], *SPEED_BAND)
    r.equal("sampled error", sampled["error"].rstrip("%"), g[2])
    r.band("fixed s", num(by["fixed"]["render s"]), g[3], *SPEED_BAND)
    out = ctx.run([os.path.join(os.path.dirname(ctx.rtusim), "chip_threads_bench"), "--rays", "1000000",
                   "--threads", "1,2", "--runs", "2"])
    t = table_with(out, "same counters")
    r.equal("replay counters on 2 threads", t[-1]["same counters"], "yes")
    r.band("replay speed-up", num(t[-1]["speed-up"].rstrip("x")), g[4], *SPEED_BAND)
    return r


CHECKS = [
    ("fixed-float", "Fixed (default format) against float", None, check_fixed_float),
    ("watertight", "Watertightness, conservative boxes", None, check_watertight),
    ("embree", "Float reference against Embree", None, check_embree),
    ("speed-embree", "Speed against Embree (one thread)", None, check_speed_embree),
    ("sim-speed", "Simulator speed, a chip frame (2 threads)", "bench/simulator_speed.sh: about 5 minutes",
     check_sim_speed),
    ("cycles", "Cycles per ray, `rdna2`, three meshes", None, check_cycles),
    ("sampled", "Sampled timing, 4M rays, F = 0.01", None, check_sampled),  # 4.5 min
    ("coord-bits", "Coordinate bits", None, check_coord_bits),
    ("packed", "Packed nodes and triangle blocks", None, check_packed),
    ("rtl-box", "RTL box unit", "yosys synthesizes one unit per row: about 18 minutes", check_rtl_box),
    ("rtl-tri", "RTL triangle unit", "yosys synthesizes each preset's unit: minutes per row", check_rtl_tri),
    ("rtl-trav", "Model against the RTL traversal unit", "Verilator runs 180 packets twice and 40 designs: about 10 minutes",
     check_rtl_trav),
    ("energy", "Area and energy (45 nm)", None, check_energy),
    ("chip", "Chip of units sharing L2 and DRAM", None, check_chip),
    ("two-level", "Two levels against flattened", None, check_two_level),
    ("hybrid", "Hybrid against ray-traced frames", None, check_hybrid),
    ("motion", "Motion blur against the static frame", None, check_motion),
    ("queries", "Neighbour queries against a CPU k-d tree", None, check_queries),
    ("stress", "Stress suite", None, check_stress),
]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rows", nargs="*", metavar="ROW_ID", help="rows to check (default: all); ids: " +
                    ", ".join(c[0] for c in CHECKS))
    ap.add_argument("--rtusim", default="build/default/rtusim", help="rtusim binary (default %(default)s)")
    ap.add_argument("--build", default="build/default", help="build directory of the tests, trace_bench and the "
                    "RTL testbenches (default %(default)s)")
    ap.add_argument("--all", action="store_true", help="also run the rows whose commands take more than ~5 min")
    ap.add_argument("--readme", default=os.path.join(ROOT, "README.md"), help=argparse.SUPPRESS)
    ap.add_argument("-v", "--verbose", action="store_true", help="print each command as it runs (stderr)")
    a = ap.parse_args()
    ids = [c[0] for c in CHECKS]
    for r in a.rows:
        if r not in ids:
            ap.error(f"unknown row id {r!r}; ids: {', '.join(ids)}")
    rtusim = os.path.abspath(a.rtusim) if os.path.exists(a.rtusim) else a.rtusim
    build = os.path.abspath(a.build)
    if not os.access(rtusim, os.X_OK):
        print(f"check_figures.py: {rtusim} is not an executable (--rtusim)", file=sys.stderr)
        return 2
    rows = readme_rows(a.readme)
    failed = 0
    # Every README row must have a check, so a new row cannot go unchecked.
    known = {c[1] for c in CHECKS}
    for first in rows:
        if first not in known and not a.rows:
            print(f"FAIL (no check): README row '{first}' has no check in bench/check_figures.py")
            failed += 1
    t_all = time.time()
    with tempfile.TemporaryDirectory(prefix="check_figures.") as tmp:
        ctx = Ctx(rtusim, build, tmp, a.verbose)
        for cid, first, slow, fn in CHECKS:
            if a.rows and cid not in a.rows:
                continue
            row = rows.get(first)
            if row is None:
                print(f"FAIL {cid}: no README row starting '{first}' (renamed? update the check)")
                failed += 1
                continue
            if slow and not a.all and cid not in a.rows:
                # Even skipped, the row must still state what the check reads.
                try:
                    fn_pattern_probe(fn, row)
                except Drift as e:
                    print(f"FAIL {cid}: {e}")
                    failed += 1
                    continue
                print(f"SKIP {cid}: skipped: {slow} (--all or the row id runs it)")
                continue
            t0 = time.time()
            try:
                res = fn(row, ctx, a.all)
            except Drift as e:
                print(f"FAIL {cid}: {e}")
                failed += 1
                continue
            except (CommandFailed, KeyError, IndexError, ValueError, OSError) as e:
                print(f"FAIL {cid} ({time.time() - t0:.0f} s): {type(e).__name__}: {e}")
                failed += 1
                continue
            status = "PASS" if res.ok else "FAIL"
            failed += not res.ok
            print(f"{status} {cid} ({time.time() - t0:.0f} s): {res.line()}", flush=True)
    print(f"{'all checked rows pass' if not failed else f'{failed} row(s) failed'} "
          f"({time.time() - t_all:.0f} s)")
    return 1 if failed else 0


def fn_pattern_probe(fn, row):
    """Run a check only as far as its first `stated` call: the README row must still say the figure."""

    class Stop(Exception):
        pass

    global stated
    real = stated

    def probe(r, pattern):
        real(r, pattern)
        raise Stop()

    stated = probe
    try:
        fn(row, None, False)
    except Stop:
        pass
    finally:
        stated = real


if __name__ == "__main__":
    sys.exit(main())
