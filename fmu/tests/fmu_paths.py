"""Paths shared by the FMU test scripts (run by scripts/test.sh after `cargo xtask fmu`)."""

import os
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
FMU = os.path.join(TARGET, "fmu", "BldcDrive.fmu")
# The profile `cargo xtask fmu` built with (xtask's FMU_PROFILE, default release).
_PROFILE = os.environ.get("FMU_PROFILE", "release")
_PROFILE_DIR = {"dev": "debug", "test": "debug", "bench": "release"}.get(_PROFILE, _PROFILE)
NATIVE_TRACE = os.path.join(TARGET, _PROFILE_DIR, "native-trace")
# Built by scripts/test.sh (`cargo build --profile test -p example-plugin -p misbehaving-plugin
# -p c-example-plugin`).
PLUGIN_DIR = os.path.join(TARGET, "debug")
EXAMPLE_PLUGIN = os.path.join(PLUGIN_DIR, "libexample_plugin.so")
MISBEHAVING_PLUGIN = os.path.join(PLUGIN_DIR, "libmisbehaving_plugin.so")


def require_built():
    """Fails (never skips) when the FMU has not been packaged."""
    for path in (FMU, NATIVE_TRACE):
        if not os.path.exists(path):
            sys.exit(f"FAIL: {path} is missing: run `cargo xtask fmu` first")


def require_plugins():
    """Fails (never skips) when the plugin crates have not been built."""
    for path in (EXAMPLE_PLUGIN, MISBEHAVING_PLUGIN):
        if not os.path.exists(path):
            sys.exit(f"FAIL: {path} is missing: run "
                     "`cargo build --profile test -p example-plugin -p misbehaving-plugin` first")


def check(cond, what):
    """Counts a failed check and says what it was; the script exits non-zero at the end."""
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        check.failures += 1


check.failures = 0
