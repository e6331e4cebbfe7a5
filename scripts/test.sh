#!/usr/bin/env bash
# Runs every test of the workspace. Installs nothing beyond the Rust toolchain today; tools
# needed by later test suites (e.g. a Python venv for FMU validation) are set up here too.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v cargo >/dev/null 2>&1; then
    echo "error: cargo not found; install the Rust toolchain (https://rustup.rs) and retry" >&2
    exit 1
fi
cargo test --workspace --all-targets --locked "$@"
