"""Speed × load grid: one strategy's true mean speed error and phase-current RMS over a
grid of speed commands and Coulomb loads, each point judged by its verdict, on a Dask
cluster (a LocalCluster unless --scheduler names one); plots both as heat maps with the
failed points marked.

    python speed_load_grid.py --speeds 8 --loads 6 --out grid.png
"""

import argparse

import numpy as np

import bldc_drive


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strategy", default="twelve-step-df")
    ap.add_argument("--speeds", type=int, default=8, help="speed points, 1000..6000 rpm (default 8)")
    ap.add_argument("--loads", type=int, default=6, help="load points, 0..1 mN·m (default 6)")
    ap.add_argument("--duration-s", type=float, default=2.0, help="length of each run [s] (default 2)")
    ap.add_argument("--scheduler", help="a Dask scheduler address (default: a LocalCluster)")
    ap.add_argument("--out", default="speed_load_grid.png", help="the plot (PNG)")
    a = ap.parse_args()

    speeds = np.linspace(1000, 6000, a.speeds)
    loads = np.linspace(0, 1e-3, a.loads)
    cases = [
        dict(strategy=a.strategy, speed_rpm=float(s), load_nm=float(l), duration_s=a.duration_s)
        for l in loads
        for s in speeds
    ]
    frame = bldc_drive.sweep(cases, client=a.scheduler)
    shape = (len(loads), len(speeds))
    error = (100 * (frame["speed_mean_rpm"] - frame["speed_ref_rpm"]) / frame["speed_ref_rpm"]).to_numpy().reshape(shape)
    current = frame["current_rms_a"].to_numpy().reshape(shape)
    failed = (frame["verdict"] != "running").to_numpy().reshape(shape)
    print(frame[["speed_rpm", "load_nm", "verdict", "speed_mean_rpm", "current_rms_a"]].to_string(index=False))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    extent = dict(x=speeds, y=loads * 1e3)
    for ax, z, title, unit in [
        (axes[0], error, "mean speed error", "%"),
        (axes[1], current, "phase-current RMS", "A"),
    ]:
        m = ax.pcolormesh(extent["x"], extent["y"], z, shading="nearest")
        fig.colorbar(m, ax=ax, label=unit)
        ys, xs = np.nonzero(failed)
        ax.plot(speeds[xs], loads[ys] * 1e3, "rx", label="not running")
        ax.set_xlabel("speed command [rpm]")
        ax.set_ylabel("load [mN·m]")
        ax.set_title(f"{a.strategy}: {title}")
    if failed.any():
        axes[0].legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print(f"plot: {a.out}")


if __name__ == "__main__":
    main()
