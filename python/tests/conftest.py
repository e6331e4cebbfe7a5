"""Shared helpers: the drive-bench binary the Python results are checked against, and
the optional packages a test needs (a missing one fails with how to install it)."""

import importlib
import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]

# Wall-clock figures: the only summary keys that differ between two runs of one case.
WALL_CLOCK = ("wall_s", "realtime_factor")


def need(module: str, pip_name: str):
    """The module, or a failure saying how to install it (never a silent skip)."""
    try:
        return importlib.import_module(module)
    except ImportError:
        pytest.fail(f"{module} is missing: pip install {pip_name}")


def _target() -> pathlib.Path:
    """The cargo target folder: $CARGO_TARGET_DIR, else target/."""
    return pathlib.Path(os.environ.get("CARGO_TARGET_DIR") or ROOT / "target")


def _plugin(file: str, build: str) -> pathlib.Path:
    """A plugin library the test command builds into the test profile's folder; `build`
    says how when it is missing."""
    lib = _target() / "debug" / file
    if not lib.is_file():
        pytest.fail(f"{lib} not found: build it ({build})")
    return lib


@pytest.fixture(scope="session")
def drive_bench() -> pathlib.Path:
    """The drive-bench binary: $DRIVE_BENCH, else the newest one under the target folder
    ($CARGO_TARGET_DIR or target/)."""
    if os.environ.get("DRIVE_BENCH"):
        return pathlib.Path(os.environ["DRIVE_BENCH"])
    target = _target()
    found = [p for p in (target / d / "drive-bench" for d in ("debug", "release", "wheel")) if p.is_file()]
    if not found:
        pytest.fail(
            f"drive-bench not found under {target}: build it (cargo build --profile test --bin drive-bench) "
            "or set DRIVE_BENCH"
        )
    return max(found, key=lambda p: p.stat().st_mtime)


@pytest.fixture(scope="session")
def example_plugin() -> pathlib.Path:
    """The example plugin library (strategy ``example-twelve-step-df``), built by the
    test command with the Rust tests' profile."""
    return _plugin("libexample_plugin.so", "cargo build --profile test -p example-plugin")


@pytest.fixture(scope="session")
def c_plugin() -> pathlib.Path:
    """The C SDK's example plugin (strategy ``c-six-step``), compiled by the system C
    compiler when the test command builds plugins/c-example."""
    return _plugin("libc_six_step.so",
                   "cargo build --profile test -p c-example-plugin; it needs a C compiler: apt-get install gcc")


def cli(binary, *args, check=True):
    """Runs drive-bench; the completed process."""
    p = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)
    if check and p.returncode not in (0, 3, 4, 5, 6, 7, 8, 9):
        pytest.fail(f"drive-bench {' '.join(map(str, args))} failed ({p.returncode}): {p.stderr}")
    return p


def cli_json(binary, tmp_path, *args):
    """The document `drive-bench ... --json FILE` writes."""
    out = tmp_path / f"out-{len(list(tmp_path.iterdir()))}.json"
    cli(binary, *args, "--json", out)
    return json.loads(out.read_text())


def without_wall_clock(summary: dict) -> dict:
    return {k: v for k, v in summary.items() if k not in WALL_CLOCK}
