"""Start-up tolerance Monte-Carlo: the share of drives that start, per strategy, when the
motor and supply parameters spread by ±10 % (uniform) and the comparator offsets by
±5 mV, each sample with its own noise seed. Runs on a Dask cluster (a LocalCluster
unless --scheduler names one) and plots the shares with their 95 % intervals.

    python startup_montecarlo.py --samples 200 --out startup.png
"""

import argparse

import numpy as np

import bldc_drive

# The parameters spread, as config paths (section, key).
SPREAD = [
    ("motor", "resistance_ohm"),
    ("motor", "self_inductance_h"),
    ("motor", "mutual_inductance_h"),
    ("motor", "flux_linkage_wb"),
    ("motor", "inertia_kgm2"),
    ("motor", "viscous_friction_nms"),
    ("motor", "coulomb_friction_nm"),
    ("power_stage", "supply_v"),
]


def sampled_config(base, rng, relative=0.10, offset_v=5e-3):
    """Overrides of the built-in config for one sample."""
    cfg = {"motor": {}, "power_stage": {}, "sensing": {"comparator": {"offset_v": {}}}}
    for section, key in SPREAD:
        cfg[section][key] = base[section][key] * (1 + relative * rng.uniform(-1, 1))
    # The model needs L_self > M.
    m = cfg["motor"]
    m["mutual_inductance_h"] = min(m["mutual_inductance_h"], 0.95 * m["self_inductance_h"])
    for phase in "uvw":
        cfg["sensing"]["comparator"]["offset_v"][phase] = offset_v * rng.uniform(-1, 1)
    return cfg


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=100, help="samples per strategy (default 100)")
    ap.add_argument("--duration-s", type=float, default=1.5, help="length of each start [s] (default 1.5)")
    ap.add_argument("--rpm", type=float, default=3000.0, help="speed command [rpm] (default 3000)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the parameter draws (default 1)")
    ap.add_argument("--scheduler", help="a Dask scheduler address (default: a LocalCluster)")
    ap.add_argument("--out", default="startup_montecarlo.png", help="the plot (PNG)")
    a = ap.parse_args()

    base = bldc_drive.default_config()
    rng = np.random.default_rng(a.seed)
    names = bldc_drive.strategies()
    cases = []
    for name in names:
        for _ in range(a.samples):
            cases.append(dict(strategy=name, speed_rpm=a.rpm, duration_s=a.duration_s, config=sampled_config(base, rng)))
    frame = bldc_drive.sweep(cases, client=a.scheduler)
    # Started: the rotor followed the commutation for two electrical turns (the verdict's
    # rule); running: and it ended in synchronism within 2 % of the command.
    frame["started"] = frame["started_at_s"].notna()
    frame["running"] = frame["verdict"] == "running"
    share = frame.groupby("strategy", sort=False)[["started", "running"]].mean().reindex(names)
    n = a.samples
    half = 1.96 * np.sqrt(share["started"] * (1 - share["started"]) / n)
    for name, row in share.iterrows():
        print(f"{name:16} started {100 * row.started:5.1f} %, running at the end {100 * row.running:5.1f} %")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8.5, 3.5))
    x = np.arange(len(names))
    ax.bar(x - 0.2, 100 * share["started"], 0.4, yerr=100 * half, capsize=3, label="started")
    ax.bar(x + 0.2, 100 * share["running"], 0.4, label="running at the end")
    ax.set_xticks(x, names, rotation=15)
    ax.set_ylabel("share of drives [%]")
    ax.set_ylim(0, 105)
    ax.set_title(f"Start-up over ±10 % parameter spread, {n} samples each, {a.rpm:.0f} rpm")
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    print(f"plot: {a.out}")


if __name__ == "__main__":
    main()
