#!/usr/bin/env python3
"""Cycles against one timing key, from Python: the same rays traced on the timed device with a preset and one key
varied (ray_slots by default; any key of `rtusim config`, e.g. cache_kib), camera rays and incoherent rays, and
a plot of cycles per ray. The hits do not depend on the timing; the script checks that they stay the same.

    PYTHONPATH=build/default/python /usr/bin/python3 examples/timing_sweep.py out/slots.png [--key ray_slots]
        [--values 1,2,4,8,16,32,64] [--config rdna2] [--scene builtin:seed] [--rays N]
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

import rtu  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="PNG to write")
    ap.add_argument("--key", default="ray_slots")
    ap.add_argument("--values", default="1,2,4,8,16,32,64")
    ap.add_argument("--config", default="rdna2")
    ap.add_argument("--scene", default="builtin:seed")
    ap.add_argument("--rays", type=int, default=20000)
    a = ap.parse_args()

    scene = rtu.load_scene(a.scene)
    ray_sets = {"camera": rtu.rays(scene, f"primary:{a.rays}"), "incoherent": rtu.rays(scene, f"incoherent:{a.rays}")}
    rows = []
    for kind, rays in ray_sets.items():
        first = None
        for v in a.values.split(","):
            r = rtu.trace(scene, rays, "timed", config=a.config, set={a.key: v})
            if first is None:
                first = r.hits
            assert np.array_equal(first, r.hits), "the timing changed the hits"
            t = r.stats["timing"]
            rows.append({"rays": kind, a.key: float(v), "cycles": r.cycles, "cycles_per_ray": r.cycles / len(rays),
                         "bound": t["lower_bound"]["limited_by"]})
    df = pd.DataFrame(rows)
    print(df.to_string(index=False))
    fig, ax = plt.subplots(figsize=(6, 4))
    for kind, sub in df.groupby("rays"):
        ax.plot(sub[a.key], sub["cycles_per_ray"], marker="o", label=f"{kind} rays")
    ax.set_xscale("log", base=2)
    ax.set_xlabel(a.key)
    ax.set_ylabel(f"cycles per ray ({a.config})")
    ax.set_title(f"{a.scene}: cycles against {a.key}")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print(f"-> {a.out}")


if __name__ == "__main__":
    main()
