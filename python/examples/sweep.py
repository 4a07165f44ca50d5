"""Error against time: sweep `rays` (or any solver key) and plot the indirect irradiance's
error at points drawn uniformly by area against the wall time of the solve and the probe,
with the project's own reference (meshrad.reference, the independent path tracer).

    python python/examples/sweep.py [SCENE.toml] [--key rays --values 32,64,128,256,512]
                                    [--points 2000] [--samples 4096] [--out sweep.png]
    python python/examples/sweep.py --key final_gather --values 0,64,256,1024

The error is the README's (relative RMS over the points whose reference is above 1 % of
the mean and not noisier than 5 %), for the points lit only indirectly and for the lit
points apart, with the median and energy ratios beside it (bias). Without matplotlib the
table alone is printed. The reference is cached beside the plot (`.npz`).
"""

import argparse
import pathlib
import time

import numpy as np

import meshrad


def errors(estimate, ref, ref_se):
    """Relative RMS, median and energy ratios of `estimate` against `ref`."""
    rm = ref.mean(1)
    keep = (rm >= 0.01 * rm.mean()) & (rm > 0) & (ref_se.mean(1) <= 0.05 * rm)
    e, r = estimate[keep].astype(np.float64), ref[keep]
    if keep.sum() == 0:
        return dict(rel_rms=np.nan, median=np.nan, energy=np.nan, points=0)
    ratio = e.mean(1) / r.mean(1)
    return dict(
        rel_rms=float(np.sqrt(((e - r) ** 2).sum() / (r**2).sum())),
        median=float(np.median(ratio)),
        energy=float(e.mean(1).sum() / r.mean(1).sum()),
        points=int(keep.sum()),
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", help="scene file (default: the embedded Cornell box)")
    ap.add_argument("--key", default="rays")
    ap.add_argument("--values", default="32,64,128,256,512")
    ap.add_argument("--points", type=int, default=2000)
    ap.add_argument("--samples", type=int, default=4096, help="reference paths per point")
    ap.add_argument("--backend", default="auto")
    ap.add_argument("--out", default="sweep.png")
    a = ap.parse_args()

    scene = meshrad.load(a.scene) if a.scene else meshrad.Scene.embedded()
    points = scene.sample_points(a.points, seed=7)
    cache = pathlib.Path(a.out).with_suffix(f".ref{a.points}x{a.samples}.npz")
    if cache.exists():
        ref = dict(np.load(cache))
    else:
        t = time.perf_counter()
        ref = meshrad.reference(scene, points, samples=a.samples, progress=True)
        np.savez(cache, **ref)
        print(f"reference: {a.points} points × {a.samples} paths in {time.perf_counter() - t:.1f} s")
    indirect_only = ref["direct"].sum(1) == 0

    rows = []
    for raw in a.values.split(","):
        value = int(raw) if raw.lstrip("-").isdigit() else float(raw)
        # The time to the answer: the solve and the probe (its final gather).
        t = time.perf_counter()
        sol = meshrad.solve(scene, backend=a.backend, **{a.key: value})
        est = sol.probe(points)["indirect"]
        seconds = time.perf_counter() - t
        strata = {
            "indirect-only": errors(est[indirect_only], ref["indirect"][indirect_only], ref["indirect_se"][indirect_only]),
            "lit": errors(est[~indirect_only], ref["indirect"][~indirect_only], ref["indirect_se"][~indirect_only]),
        }
        worse = max(strata.values(), key=lambda s: s["rel_rms"] if np.isfinite(s["rel_rms"]) else -1)
        rows.append((value, seconds, strata, worse))
        print(
            f"{a.key} = {value}: {seconds:.2f} s ({sol.backend}); "
            + "; ".join(
                f"{k} {s['rel_rms'] * 100:.2f} % (median {s['median']:.3f}, energy {s['energy']:.3f}, {s['points']} points)"
                for k, s in strata.items()
            )
        )

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot")
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for name in ("indirect-only", "lit"):
        xs = [r[1] for r in rows]
        ys = [r[2][name]["rel_rms"] * 100 for r in rows]
        ax.plot(xs, ys, "o-", label=name)
        for (value, x, _, _), y in zip(rows, ys):
            ax.annotate(f"{value}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xlabel("solve + probe wall time, s")
    ax.set_ylabel("indirect irradiance, relative RMS %")
    ax.set_title(f"{scene.path}: {a.key} swept")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print(f"plot: {a.out}")


if __name__ == "__main__":
    main()
