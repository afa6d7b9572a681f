#!/usr/bin/env python3
"""Error against cost of fixed-point formats, from Python: a design sweep (rtu.sweep, the rows of `rtusim sweep`)
into a DataFrame, and its Pareto fronts (rtu.pareto_front, the rule of `rtusim pareto`) against simulated cycles
and against the unit's area, drawn with matplotlib.

    PYTHONPATH=build/default/python /usr/bin/python3 examples/pareto.py out/pareto.png [--scene builtin:seed] [--rays N]
"""
import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import rtu  # noqa: E402

FORMATS = ["default", "compact", "packed"] + [f"default:coord_bits={b}" for b in (8, 10, 12, 14, 16, 20)]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="PNG to write")
    ap.add_argument("--scene", default="builtin:seed")
    ap.add_argument("--rays", type=int, default=5000, help="camera rays and as many incoherent rays per point")
    ap.add_argument("--error", default="t_rel_error_mean", choices=["t_rel_error_mean", "hit_disagreement"],
                    help="the error axis: mean relative t error or hit disagreement with float")
    ap.add_argument("--csv", help="also write the sweep's rows here")
    a = ap.parse_args()

    df = rtu.sweep(a.scene, formats=FORMATS, bvh_widths=[4, 8], configs=["rdna2"], rays=a.rays, image_width=0)
    if a.csv:
        df.to_csv(a.csv, index=False)
    # A zero is drawn as rtusim pareto draws it on the log axis: a hit disagreement at "fewer than one ray in the
    # sample", a t error at 1e-10.
    df["error"] = df[a.error].clip(lower=1.0 / (2 * a.rays) if a.error == "hit_disagreement" else 1e-10)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
    for ax, cost, label in ((axes[0], "cycles", "cycles (rdna2)"), (axes[1], "area_mm2", "unit area (mm^2, 45 nm)")):
        front = rtu.pareto_front(df, cost, "error")
        for w, marker in ((4, "o"), (8, "s")):
            sub = df[df["bvh_width"] == w]
            ax.scatter(sub[cost], sub["error"], marker=marker, label=f"BVH{w}", alpha=0.7)
        f = df[front].sort_values(cost)
        ax.step(f[cost], f["error"], where="post", color="black", lw=1, label="Pareto front")
        for _, r in f.iterrows():
            ax.annotate(f"{r['format']}/w{r['bvh_width']}", (r[cost], r["error"]), fontsize=6,
                        xytext=(3, 3), textcoords="offset points")
        ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel(a.error.replace("_", " ") + " (against float)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{a.scene}: {2 * a.rays} rays per point ({len(df)} points)")
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print(f"{len(df)} points, {int(rtu.pareto_front(df, 'cycles', 'error').sum())} on the cycles front -> {a.out}")
    print(df[["format", "bvh_width", "hit_disagreement", "t_rel_error_mean", "cycles", "area_mm2"]].to_string(index=False))


if __name__ == "__main__":
    main()
