#!/usr/bin/env bash
# Instructions per simulated second of the default drive in steady state (the second from
# 2 s to 3 s of `examples/profile.rs`), counted by callgrind. Unlike wall time, which on the
# CI's VMs varies by a third between days for the same binary, the count is repeatable: it
# is the figure to compare builds by.
# Usage: scripts/instructions.sh [speed_rpm [strategy [load_nm]]], e.g. `1500`,
# `3000 six-step-120`, `3000 twelve-step-df 1e-3` (a load the default drive carries; at
# 2.5e-3 N·m it stalls and runs backwards). Honours CARGO_TARGET_DIR.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v valgrind >/dev/null 2>&1; then
    echo "error: valgrind not found; install it (apt-get install valgrind) and retry" >&2
    exit 1
fi
cargo build --release --quiet --example profile
bin="${CARGO_TARGET_DIR:-target}/release/examples/profile"
out=$(mktemp)
trap 'rm -f "$out" "$out.log"' EXIT
status=0
valgrind --tool=callgrind --callgrind-out-file="$out" --collect-atstart=no \
    --toggle-collect='profile::steady_second' "$bin" "$@" \
    >/dev/null 2>"$out.log" || status=$?
n=$(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$out.log")
if [ "$status" -ne 0 ] || [ -z "$n" ]; then
    grep -v '^==' "$out.log" >&2 || true
    echo "error: the profiled run failed (exit $status) or callgrind reported no count" >&2
    exit 1
fi
# CALLGRIND_OUT=file keeps the profile for callgrind_annotate.
if [ -n "${CALLGRIND_OUT:-}" ]; then cp "$out" "$CALLGRIND_OUT"; fi
echo "$n instructions per simulated second (${2:-default drive}${1:+ at $1 rpm}${3:+, load $3 N·m}, steady state 2–3 s)"
