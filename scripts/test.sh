#!/usr/bin/env bash
# Runs every test of the workspace: the Rust tests, then the fmpy checks of the packaged FMU.
# Everything beyond the Rust toolchain and python3 is installed here when missing.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each stage's start, with the seconds since the script began: where CI's time goes.
stage() { echo "== [${SECONDS} s] $*"; }
if ! command -v cargo >/dev/null 2>&1; then
    echo "error: cargo not found; install the Rust toolchain (https://rustup.rs) and retry" >&2
    exit 1
fi
# Formatting first: it takes a second, and an unformatted change fails here, not in review.
if ! cargo fmt --version >/dev/null 2>&1; then
    echo "error: rustfmt not found; install it (rustup component add rustfmt) and retry" >&2
    exit 1
fi
cargo fmt --all --check

# FMU tests need a Python venv with fmpy (pinned), and the `fmi` crate (a dev-dependency of
# fmu/) needs libclang for bindgen: the PyPI wheel `libclang` (pinned) in the venv, with gcc's
# builtin headers, unless LIBCLANG_PATH names another. Both are installed here when missing.
# The wheel rather than a system libclang: the same one on every machine, where Debian's
# packages may ship libclang without its headers, or only libclang-cpp.
venv=target/venv
if ! "$venv/bin/python" -c "import fmpy, clang" >/dev/null 2>&1; then
    if ! command -v python3 >/dev/null 2>&1; then
        echo "error: python3 not found; install it (apt-get install python3 python3-venv) and retry" >&2
        exit 1
    fi
    python3 -m venv "$venv" || { echo "error: python3 -m venv failed; apt-get install python3-venv" >&2; exit 1; }
    "$venv/bin/pip" install --quiet fmpy==0.3.32 libclang==18.1.1
fi
if [ -z "${LIBCLANG_PATH:-}" ]; then
    LIBCLANG_PATH=$("$venv/bin/python" -c "import clang, os; print(os.path.join(os.path.dirname(clang.__file__), 'native'))")
    export LIBCLANG_PATH
    export BINDGEN_EXTRA_CLANG_ARGS="-I$(gcc -print-file-name=include)"
fi
# The FMU is built with the dev profile, which the test profile inherits unchanged
# (Cargo.toml): the workspace is compiled once for the FMU, the tests and the Python wheel,
# and the fmu crate's tests package the same build (xtask reads FMU_PROFILE). What ships
# (`cargo xtask fmu`) is the release profile's, with fat LTO.
export FMU_PROFILE=dev
stage "FMU (profile $FMU_PROFILE)"
cargo xtask fmu >/dev/null
# The Python package's tests need maturin, pytest, Dask, pandas, NumPy, pyarrow and
# matplotlib (for the examples) in the same venv: pinned, installed when missing.
if ! "$venv/bin/python" -c "import maturin, pytest, distributed, pandas, numpy, pyarrow, matplotlib" >/dev/null 2>&1; then
    "$venv/bin/pip" install --quiet maturin==1.16.0 pytest==9.2.0 "dask[distributed]==2026.8.0" \
        pandas==3.1.1 numpy==2.4.6 pyarrow==26.0.1 matplotlib==3.11.2
fi

# The Python extension (bldc-drive-py) has no Rust tests (python/tests are its tests, run
# below against the wheel): built here it only made a test executable with no test in it,
# and compiled PyO3 a second time.
stage "cargo test"
cargo test --workspace --exclude bldc-drive-py --all-targets --locked "$@"
# The API docs build without warnings (units in doc comments are written \[V\], not links).
stage "cargo doc"
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --locked --quiet
# The plugins fmu/tests/fmi_plugin.py, fmi_c_plugin.py and the Python tests load (the same
# build the Rust tests make; c-example-plugin's build script compiles the C plugins with the
# system C compiler and fails, saying how to install one, when there is none).
cargo build --profile test --locked -p example-plugin -p misbehaving-plugin -p c-example-plugin

for t in fmu/tests/*.py; do
    [ "$(basename "$t")" = fmu_paths.py ] && continue
    stage "$t"
    "$venv/bin/python" "$t"
done
# The README's examples keep working: the FMU from Python here; the library's
# (examples/library.rs) ran in `cargo test` above, as a test without harness.
stage "examples/fmu/quickstart.py"
"$venv/bin/python" examples/fmu/quickstart.py target/fmu/BldcDrive.fmu
stage "examples/fmu/speed_step.py"
"$venv/bin/python" examples/fmu/speed_step.py target/fmu/BldcDrive.fmu

# The Python package: its wheel, installed into the venv; its examples, tiny; then its
# tests (against the drive-bench built above). The wheel is built with the dev profile,
# like everything above, so only PyO3 and the extension are compiled here. (`--profile
# test` would not do: cargo builds the selected crate in test mode under that name, which
# makes the extension a test executable that Python cannot load.)
stage "python: wheel"
wheels=target/python-wheels
rm -rf "$wheels"
"$venv/bin/maturin" build --quiet --locked --profile dev -m python/Cargo.toml \
    -i "$venv/bin/python" -o "$wheels"
"$venv/bin/pip" install --quiet --force-reinstall --no-deps "$wheels"/bldc_drive-*.whl
for ex in "startup_montecarlo.py --samples 1 --duration-s 1.0" "speed_load_grid.py --speeds 2 --loads 2 --duration-s 0.5"; do
    stage "python/examples/$ex"
    # shellcheck disable=SC2086 # the example's options are split on purpose
    "$venv/bin/python" python/examples/$ex --out "target/python-${ex%%.py*}.png" >/dev/null
done
# Every python block of README.md and python/README.md, saved and run as a script.
stage "README python snippets"
"$venv/bin/python" scripts/readme_snippets.py
stage "python: pytest"
DRIVE_BENCH="${CARGO_TARGET_DIR:-target}/debug/drive-bench" "$venv/bin/python" -m pytest -q python/tests
stage "done"
