#!/usr/bin/env bash
# Does the working tree give the same results as a base revision, bit for bit? For a change
# meant to change no behaviour (a refactoring, a split of files): builds drive-bench and the
# FMU's `state-bytes` at BASE (in a worktree of its own) and at the working tree, runs both
# on the same fixed runs and compares every output byte for byte (cmp).
#
#   scripts/bit-identity.sh [BASE]     # BASE: a revision; default the merge-base of HEAD and main
#
# The runs: `drive-bench run --json` summaries of the default drive, twelve-step-df loaded
# at 1500 rpm, six-step-120 at 3000 and 8000 rpm, twelve-step-lm, a trapezoidal and a
# harmonic back-EMF (the RK4 path), dead time with strong noise and ringing, the supply-sag
# and load-step scenarios, and a short traced run (its CSV trace); each run's exit status
# (its verdict) too. The summaries' wall time and real-time factor are left out (the
# machine's, not the drive's). Then `state-bytes` (fmu/src/bin/state-bytes.rs): outputs
# and serialized FMU states of three FMU runs, and a continuation from a restored state.
# The working tree's `state-bytes.rs` is used for both builds, so only the library differs.
#
# Release builds: they are what users run, and what scripts/seed-spread.sh and
# scripts/instructions.sh measure, so the working tree's build is shared with theirs. (f64
# results do not depend on the optimisation level in Rust: no fast-math, no contraction into
# FMA; a debug build would give the same bytes, slower.) BASE builds in a target directory
# of its own, TARGET/bit-identity (CARGO_TARGET_DIR honoured), seeded from TARGET/release on
# first use: its binaries never replace the working tree's, and later runs rebuild only the
# workspace's crates. Exit status: 0 identical, 1 a difference or a failure, 2 bad usage.
set -euo pipefail
usage() {
    echo "usage: scripts/bit-identity.sh [BASE]   (BASE: a git revision; default: git merge-base HEAD main)" >&2
}
case "${1:-}" in
    -h | --help) usage; exit 0 ;;
esac
if [ $# -gt 1 ]; then usage; exit 2; fi
cd "$(dirname "$0")/.."
root=$(pwd)
if [ $# -eq 1 ]; then
    base=$1
else
    base=$(git merge-base HEAD main) || { echo "error: no merge-base of HEAD and main; name BASE" >&2; usage; exit 2; }
fi
rev=$(git rev-parse --verify --quiet "$base^{commit}") || {
    echo "error: '$base' is not a revision" >&2
    usage
    exit 2
}
target=$(realpath -m -- "${CARGO_TARGET_DIR:-target}")
own="$target/bit-identity"
tree="$own/tree"
mkdir -p "$own"
# One run at a time: the base's worktree and target directory are fixed paths (so that its
# crates keep their build hashes from run to run).
exec 9>"$own/lock"
flock -n 9 || { echo "error: another bit-identity run holds $own/lock" >&2; exit 1; }
tmp=$(mktemp -d)
drop_tree() {
    git -C "$root" worktree remove --force "$tree" >/dev/null 2>&1 || rm -rf "$tree"
    git -C "$root" worktree prune
}
trap 'drop_tree; rm -rf "$tmp"' EXIT
drop_tree
git worktree add --quiet --detach "$tree" "$rev"
cp fmu/src/bin/state-bytes.rs "$tree/fmu/src/bin/state-bytes.rs"
if [ ! -d "$own/release" ] && [ -d "$target/release" ]; then
    echo "seeding $own from $target/release (once)"
    cp -a "$target/release" "$own/"
fi

# The same inputs for both trees: the working tree's scenarios, and configs written here.
in="$tmp/inputs"
mkdir -p "$in"
cp examples/scenarios/supply-sag.toml examples/scenarios/load-step.toml "$in/"
printf '[motor.back_emf]\nkind = "trapezoidal"\nflat_top_deg = 120.0\n' >"$in/trapezoidal.toml"
printf '[motor.back_emf]\nkind = "harmonic"\nthird = 0.1\nfifth = 0.03\n' >"$in/harmonic.toml"
printf '[power_stage]\ndead_time_s = 1e-6\n\n[sensing.comparator]\nnoise_v = 0.02\nring_gain = 0.1\n' \
    >"$in/noisy.toml"
# name|drive-bench run options (@OUT@: the tree's output folder)
runs=(
    "default|"
    "twelve-step-df-1500-loaded|--strategy twelve-step-df --speed-rpm 1500 --load-nm 1e-3"
    "six-step-120|--strategy six-step-120"
    "six-step-120-8000|--strategy six-step-120 --speed-rpm 8000"
    "twelve-step-lm-6000|--strategy twelve-step-lm --speed-rpm 6000"
    "trapezoidal|--config $in/trapezoidal.toml"
    "harmonic-six-step-120|--config $in/harmonic.toml --strategy six-step-120"
    "dead-time-noisy-nd|--config $in/noisy.toml --strategy twelve-step-nd --seed 7"
    "supply-sag|--scenario $in/supply-sag.toml"
    "load-step|--scenario $in/load-step.toml"
    "traced|--duration-s 0.5 --trace @OUT@/traced.csv --trace-every-us 7"
)

# build TREE TARGET NAME: builds TREE's binaries into TARGET and runs them into $tmp/NAME.
build_and_run() {
    local src=$1 tgt=$2 name=$3 t0=$SECONDS
    local out="$tmp/$name" bin="$tmp/bin-$name"
    mkdir -p "$out" "$bin"
    (cd "$src" && CARGO_TARGET_DIR="$tgt" cargo build --release --locked --quiet \
        -p bldc-drive -p fmu --bin drive-bench --bin state-bytes)
    # Copied at once: nothing later can swap them.
    cp "$tgt/release/drive-bench" "$tgt/release/state-bytes" "$bin/"
    echo "$name: built in $((SECONDS - t0)) s"
    for r in "${runs[@]}"; do
        local run=${r%%|*} opts=${r#*|}
        opts=${opts//@OUT@/$out}
        local status=0
        # shellcheck disable=SC2086 # the run's options are split on purpose
        (cd "$tmp" && "$bin/drive-bench" run $opts --json "$out/$run.json") >/dev/null 2>"$out/$run.stderr" ||
            status=$?
        echo "$status" >"$out/$run.status"
        if [ -f "$out/$run.json" ]; then
            sed -i -E '/^ *"(wall_s|realtime_factor)":/d' "$out/$run.json"
        fi
    done
    "$bin/state-bytes" "$out/fmu" || { echo "error: $name: state-bytes failed" >&2; exit 1; }
    echo "$name: ran in $((SECONDS - t0)) s in all"
}

build_and_run "$tree" "$own" "base"
build_and_run "$root" "$target" "head"

n=0
differ=()
while IFS= read -r f; do
    n=$((n + 1))
    if [ ! -e "$tmp/head/$f" ]; then
        differ+=("$f: missing in the working tree's outputs")
    elif ! msg=$(cmp -- "$tmp/base/$f" "$tmp/head/$f" 2>&1); then
        differ+=("$f: ${msg//$tmp\//}")
    fi
done < <(cd "$tmp/base" && find . -type f ! -name '*.stderr' | sed 's|^\./||' | sort)
while IFS= read -r f; do
    [ -e "$tmp/base/$f" ] || { n=$((n + 1)); differ+=("$f: missing in the base's outputs"); }
done < <(cd "$tmp/head" && find . -type f ! -name '*.stderr' | sed 's|^\./||' | sort)

short=$(git rev-parse --short "$rev")
if [ ${#differ[@]} -eq 0 ]; then
    echo "identical: $n outputs of the working tree and of $short ($base) agree byte for byte"
    exit 0
fi
echo "DIFFERENT: ${#differ[@]} of $n outputs of the working tree and of $short ($base) differ:"
printf '  %s\n' "${differ[@]}"
exit 1
