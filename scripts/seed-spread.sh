#!/usr/bin/env bash
# Is a change that moves results in the last digits within the noise? The comparator noise's
# seed moves every summary figure of `drive-bench run`; a change is accepted when its figures
# move by no more than the seed moves them.
#
#   scripts/seed-spread.sh record SPREAD.json [BIN]   # the reference tree: seeds 1..16
#   scripts/seed-spread.sh check  SPREAD.json [BIN]   # the changed tree: seeds 1..8
#
# Operating points: the default drive at 3000 rpm and at 1500 rpm, six-step-120 at 3000 rpm,
# and the default drive at 3000 rpm with a 1 mN·m load (one the drive carries).
# Rule, for each operating point and each numeric summary figure: the changed tree's seed-1
# value lies within [min − 10 % of range, max + 10 % of range] of the reference's seeds
# (a figure the seed does not move must be equal); or, where a change redraws a chaotic
# trajectory (seed 1 is then a new draw, which falls outside the range of 16 earlier draws
# with probability 2/17 per figure), the mean over the changed tree's seeds 1..8 is the
# reference's mean within Welch's |t| ≤ 3.5. Every changed seed's verdict must be one the
# reference's seeds reached. Every seed of every point must run and give finite figures
# (a crash or a non-finite figure fails, in either mode).
# Figures of the run's setup or of the machine (wall time, real-time factor, the command, the
# steady window) are not compared. BIN defaults to the release drive-bench
# (CARGO_TARGET_DIR honoured); `cargo build --release` first.
set -euo pipefail
mode=${1:?usage: seed-spread.sh record|check SPREAD.json [BIN]}
file=${2:?usage: seed-spread.sh record|check SPREAD.json [BIN]}
# Paths as given, from where the script was called; then to the repository's root.
file=$(realpath -m -- "$file")
if [ -n "${3:-}" ]; then bin=$(realpath -m -- "$3"); fi
cd "$(dirname "$0")/.."
bin=${bin:-${CARGO_TARGET_DIR:-target}/release/drive-bench}
[ -x "$bin" ] || { echo "error: $bin not found; cargo build --release first" >&2; exit 1; }
points=("default-3000|--speed-rpm 3000" "default-1500|--speed-rpm 1500"
    "six-step-120-3000|--strategy six-step-120 --speed-rpm 3000"
    "default-3000-load-1e-3|--speed-rpm 3000 --load-nm 1e-3")
case "$mode" in record) n_seeds=16 ;; check) n_seeds=8 ;;
    *) echo "error: mode is record or check, got '$mode'" >&2; exit 2 ;; esac
if [ "$mode" = check ] && [ ! -r "$file" ]; then
    echo "error: reference $file not readable; record one from the reference tree first" >&2
    exit 2
fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for p in "${points[@]}"; do
    name=${p%%|*}
    for s in $(seq 1 "$n_seeds"); do
        # The exit status is the verdict (non-zero for a failed drive), judged below; a
        # run that wrote no summary fails the check there.
        # shellcheck disable=SC2086 # the point's options are split on purpose
        "$bin" run ${p#*|} --seed "$s" --json "$tmp/$name.$s.json" >/dev/null || true
    done
done
python3 - "$mode" "$file" "$tmp" "$n_seeds" "${points[@]%%|*}" <<'PY'
import glob, json, math, os, sys
mode, path, tmp, n_seeds, *points = sys.argv[1:]
want_seeds = set(range(1, int(n_seeds) + 1))
T_MAX = 3.5
skip = {"wall_s", "realtime_factor", "speed_ref_rpm", "torque_lowpass_hz", "steady_from_s", "sim_s"}
runs = {}
for f in sorted(glob.glob(os.path.join(tmp, "*.json"))):
    name, seed, _ = os.path.basename(f).rsplit(".", 2)
    runs.setdefault(name, {})[int(seed)] = json.load(open(f))["summary"]
# Every point's every seed must have run: a crash is not a draw to leave out.
missing = {p: sorted(want_seeds - set(runs.get(p, {}))) for p in points}
missing = {p: m for p, m in missing.items() if m}
if missing:
    print(f"FAIL: runs without a summary (crashed or refused): {missing}")
    sys.exit(1)

def numeric(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)

def mean_var(xs):
    m = sum(xs) / len(xs)
    return m, sum((x - m) ** 2 for x in xs) / (len(xs) - 1)

if mode == "record":
    spread = {}
    for name, by_seed in sorted(runs.items()):
        seeds = sorted(by_seed)
        figs = {}
        for k, v in by_seed[1].items():
            if k in skip or isinstance(v, (str, bool, list, dict)):
                continue
            vals = [by_seed[s].get(k) for s in seeds]
            if all(x is None for x in vals):
                # Absent at every seed (no synchronism lost, say): nothing to compare.
                continue
            if not all(numeric(x) for x in vals):
                # serde_json writes a non-finite figure as null: no reference to keep.
                print(f"error: {name}: {k} is not a finite number at every seed: {vals}")
                sys.exit(1)
            figs[k] = {"min": min(vals), "max": max(vals), "seed1": v, "values": vals}
        spread[name] = {"verdict": by_seed[1]["verdict"],
                        "verdicts": sorted({by_seed[s]["verdict"] for s in seeds}),
                        "seeds": seeds, "figures": figs}
    json.dump(spread, open(path, "w"), indent=1)
    print(f"recorded {len(runs)} operating points, seeds {sorted(next(iter(runs.values())))} -> {path}")
    sys.exit(0)

spread = json.load(open(path))
bad = 0
for name in points:
    if name not in spread:
        print(f"FAIL {name}: not in the reference {path}; record it again"); bad += 1; continue
    ref, by_seed = spread[name], runs[name]
    new = by_seed[1]
    bad_before = bad
    verdicts = ref.get("verdicts", [ref["verdict"]])
    strange = sorted({s["verdict"] for s in by_seed.values()} - set(verdicts))
    if strange:
        print(f"FAIL {name}: verdicts {strange} (reference {verdicts})"); bad += 1
    worst, redrawn = (0.0, None), []
    for k, r in ref["figures"].items():
        v = new.get(k)
        if not numeric(v):
            print(f"FAIL {name}: {k} = {v} (rule: a finite number, as in the reference)"); bad += 1
            continue
        rng = r["max"] - r["min"]
        lo, hi = r["min"] - 0.1 * rng, r["max"] + 0.1 * rng
        if v is not None and lo <= v <= hi:
            if rng > 0 and abs(v - r["seed1"]) / rng > worst[0]:
                # How far the change moved the figure, in units of the seed's range.
                worst = (abs(v - r["seed1"]) / rng, k)
            continue
        # Seed 1 fell outside: a shift, or a new draw of the same distribution?
        xs = [s.get(k) for s in by_seed.values()]
        if not all(numeric(x) for x in xs):
            print(f"FAIL {name}: {k} is not a finite number at every seed: {xs}"); bad += 1
            continue
        if rng == 0 or "values" not in r or len(xs) < 2:
            print(f"FAIL {name}: {k} = {v} outside [{lo}, {hi}] (seed 1 was {r['seed1']})"); bad += 1
            continue
        (m1, v1), (m0, v0) = mean_var(xs), mean_var(r["values"])
        se = math.sqrt(v1 / len(xs) + v0 / len(r["values"]))
        t = abs(m1 - m0) / se if se > 0 else math.inf
        if t > T_MAX:
            print(f"FAIL {name}: {k} = {v} outside [{lo}, {hi}], and over seeds 1..{len(xs)} "
                  f"its mean {m1:.6g} against {m0:.6g} is |t| = {t:.2f} > {T_MAX}"); bad += 1
        else:
            redrawn.append(f"{k} (|t| = {t:.2f})")
    changed = sum(1 for k, r in ref["figures"].items() if new.get(k) != r["seed1"])
    w = f"largest move {worst[0]:.2g} of the seeds' range ({worst[1]})" if worst[1] else "no figure moved"
    print(f"{'ok  ' if bad == bad_before else 'FAIL'} {name}: {changed} of {len(ref['figures'])} figures "
          f"differ from the reference's seed 1; {w}")
    if redrawn:
        print(f"      seed 1 redrawn, means over seeds unmoved: {', '.join(redrawn)}")
print("seed spread: " + ("FAIL" if bad else "pass"))
sys.exit(1 if bad else 0)
PY
