#!/usr/bin/env bash
# Is a change that moves results in the last digits within the noise? The comparator noise's
# seed moves every summary figure of `drive-bench run`; a change is accepted when its figures
# move by no more than the seed moves them.
#
#   scripts/seed-spread.sh record SPREAD.json [BIN]   # the reference tree: seeds 1..8
#   scripts/seed-spread.sh check  SPREAD.json [BIN]   # the changed tree: seed 1 only
#
# Operating points: the default drive at 3000 rpm and at 1500 rpm, six-step-120 at 3000 rpm,
# and the default drive at 3000 rpm with a 1 mN·m load (one the drive carries).
# Rule: for each operating point and each numeric summary figure, the changed tree's seed-1
# value lies within [min − 10 % of range, max + 10 % of range] of the reference's seeds 1..8
# (a figure the seed does not move must be equal); the verdict must be the same string.
# Figures of the run's setup or of the machine (wall time, real-time factor, the command, the
# steady window) are not compared. BIN defaults to the release drive-bench
# (CARGO_TARGET_DIR honoured); `cargo build --release` first.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:?usage: seed-spread.sh record|check SPREAD.json [BIN]}
file=${2:?usage: seed-spread.sh record|check SPREAD.json [BIN]}
bin=${3:-${CARGO_TARGET_DIR:-target}/release/drive-bench}
[ -x "$bin" ] || { echo "error: $bin not found; cargo build --release first" >&2; exit 1; }
points=("default-3000|--speed-rpm 3000" "default-1500|--speed-rpm 1500"
    "six-step-120-3000|--strategy six-step-120 --speed-rpm 3000"
    "default-3000-load-1e-3|--speed-rpm 3000 --load-nm 1e-3")
case "$mode" in record) seeds="1 2 3 4 5 6 7 8" ;; check) seeds=1 ;;
    *) echo "error: mode is record or check" >&2; exit 2 ;; esac
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for p in "${points[@]}"; do
    name=${p%%|*}
    for s in $seeds; do
        # shellcheck disable=SC2086 # the point's options are split on purpose
        "$bin" run ${p#*|} --seed "$s" --json "$tmp/$name.$s.json" >/dev/null || true
    done
done
python3 - "$mode" "$file" "$tmp" <<'EOF'
import glob, json, os, sys
mode, path, tmp = sys.argv[1:]
skip = {"wall_s", "realtime_factor", "speed_ref_rpm", "torque_lowpass_hz", "steady_from_s", "sim_s"}
runs = {}
for f in sorted(glob.glob(os.path.join(tmp, "*.json"))):
    name, seed, _ = os.path.basename(f).rsplit(".", 2)
    runs.setdefault(name, {})[int(seed)] = json.load(open(f))["summary"]
if mode == "record":
    spread = {}
    for name, by_seed in runs.items():
        figs = {}
        for k, v in by_seed[1].items():
            if k in skip or not isinstance(v, (int, float)) or isinstance(v, bool):
                continue
            vals = [s[k] for s in by_seed.values()]
            figs[k] = {"min": min(vals), "max": max(vals), "seed1": v}
        spread[name] = {"verdict": by_seed[1]["verdict"], "figures": figs}
    json.dump(spread, open(path, "w"), indent=1)
    print(f"recorded {len(runs)} operating points, seeds {sorted(next(iter(runs.values())))} -> {path}")
    sys.exit(0)
spread = json.load(open(path))
bad = 0
for name, ref in spread.items():
    new = runs[name][1]
    bad_before = bad
    if new["verdict"] != ref["verdict"]:
        print(f"FAIL {name}: verdict {new['verdict']} (reference {ref['verdict']})"); bad += 1
    worst = (0.0, None)
    for k, r in ref["figures"].items():
        v = new.get(k)
        rng = r["max"] - r["min"]
        lo, hi = r["min"] - 0.1 * rng, r["max"] + 0.1 * rng
        if v is None or not (lo <= v <= hi):
            print(f"FAIL {name}: {k} = {v} outside [{lo}, {hi}] (seed 1 was {r['seed1']})"); bad += 1
        elif rng > 0:
            # How far the change moved the figure, in units of the seed's range.
            moved = abs(v - r["seed1"]) / rng
            if moved > worst[0]: worst = (moved, k)
    changed = sum(1 for k, r in ref["figures"].items() if new.get(k) != r["seed1"])
    w = f"largest move {worst[0]:.2g} of the seeds' range ({worst[1]})" if worst[1] else "no figure moved"
    print(f"{'ok  ' if bad == bad_before else 'FAIL'}{name}: {changed} of {len(ref['figures'])} figures differ from the reference's seed 1; {w}")
print("seed spread: " + ("FAIL" if bad else "pass"))
sys.exit(1 if bad else 0)
EOF
