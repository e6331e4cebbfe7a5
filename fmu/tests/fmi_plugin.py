"""fmpy-driven strategy plugins: `strategy.plugin` set by fmi2SetString (absolute, or
relative to the FMU's resources folder) runs the example plugin, which matches the
built-in twelve-step-df it wraps, also after a serialized state is restored (the state
names the plugin relative to the resources; an absolute path outside them is refused); bad files,
a misbehaving plugin and bad string calls give fmi2Error with a logged message, never a
crash."""

import ctypes
import os
import shutil
import sys

from fmpy import extract, read_model_description
from fmpy.fmi2 import fmi2Error, fmi2OK

from fmi_calls import Drive, errors_logged
from fmu_paths import (EXAMPLE_PLUGIN, FMU, MISBEHAVING_PLUGIN, check, require_built,
                       require_plugins)

H = 1e-3
OUTPUTS = ["speed_rpm", "i_u", "duty", "theta_e_deg"]


def set_plugin(d, path):
    vr = (ctypes.c_uint * 1)(d.vr["strategy.plugin"])
    val = (ctypes.c_char_p * 1)(path.encode())
    return d.raw("fmi2SetString", vr, 1, val)


def get_plugin(d):
    vr = (ctypes.c_uint * 1)(d.vr["strategy.plugin"])
    out = (ctypes.c_char_p * 1)()
    status = d.raw("fmi2GetString", vr, 1, out)
    return status, (out[0] or b"").decode()


def start(md, unzipdir, plugin=None, name="drive"):
    """An instance in initialization mode, with the plugin path set if given."""
    d = Drive(md, unzipdir, name=name)
    if plugin is not None:
        check(set_plugin(d, plugin) == fmi2OK, f"fmi2SetString strategy.plugin = {plugin!r}: OK")
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.enterInitializationMode()
    d.t = 0.0
    return d


def outputs(d):
    return d.fmu.getReal([d.vr[n] for n in OUTPUTS]) + d.fmu.getInteger([d.vr["state"]])


def finish(d):
    d.fmu.terminate()
    d.fmu.freeInstance()


def main():
    require_built()
    require_plugins()
    md = read_model_description(FMU)
    unzipdir = extract(FMU)
    try:
        # The FMU ships no resources; a copy of the example makes the relative case.
        os.makedirs(os.path.join(unzipdir, "resources"), exist_ok=True)
        shutil.copy(EXAMPLE_PLUGIN, os.path.join(unzipdir, "resources", "example.so"))
        runs_the_example(md, unzipdir)
        bad_files(md, unzipdir)
        misbehaving(md, unzipdir)
        bad_string_calls(md, unzipdir)
    finally:
        os.environ.pop("BLDC_TEST_MISBEHAVE", None)
        shutil.rmtree(unzipdir, ignore_errors=True)
    if check.failures:
        sys.exit(f"{check.failures} check(s) failed")


# Saved past the alignment (it ends at 0.75 s), while the drive commutates closed loop.
SAVE_S, END_S = 0.9, 1.2


def runs_the_example(md, unzipdir):
    ref = start(md, unzipdir)  # the default strategy.name is twelve-step-df
    ref.fmu.exitInitializationMode()
    ref.step_to(SAVE_S)
    at_save = outputs(ref)
    ref.step_to(END_S)
    builtin = outputs(ref)
    finish(ref)
    # The alignment ends at 0.75 s: the state is saved while the drive commutates.
    check(at_save[0] > 1000 and 1 <= at_save[-1] <= 12,
          f"built-in commutates at the save point ({at_save[0]:.0f} rpm, state {at_save[-1]})")
    check(builtin[0] > 2000 and 1 <= builtin[-1] <= 12,
          f"built-in runs closed loop ({builtin[0]:.0f} rpm, state {builtin[-1]})")

    inside = os.path.join(unzipdir, "resources", "example.so")
    for path in (EXAMPLE_PLUGIN, "example.so", inside):
        d = start(md, unzipdir, path)
        # six-step-120-df: ignored when a plugin is named, so a match proves the plugin ran.
        d.fmu.setInteger([d.vr["strategy.name"]], [1])
        check(d.raw("fmi2ExitInitializationMode") == fmi2OK, f"plugin {path!r} loads")
        check(get_plugin(d) == (fmi2OK, path), f"fmi2GetString returns {path!r}")
        d.step_to(SAVE_S)
        check(outputs(d) == at_save, f"plugin {path!r} matches the built-in at {SAVE_S} s")
        state = d.fmu.getFMUstate()
        if path == EXAMPLE_PLUGIN:
            # Outside the resources: a serialized state would have to hold an absolute path.
            d.log.take()
            size = ctypes.c_size_t()
            status = d.raw("fmi2SerializedFMUstateSize", state, ctypes.byref(size))
            ok, e = errors_logged(d.log, "outside the FMU's resources folder")
            check(status == fmi2Error and ok, f"absolute plugin path: no serialized state ({e})")
            data = None
        else:
            data = d.fmu.serializeFMUstate(state)
            check(inside.encode() not in bytes(data) and b"example.so" in bytes(data),
                  f"the serialized state names {path!r} relative to the resources")
        d.step_to(END_S)
        check(outputs(d) == builtin, f"plugin {path!r} matches the built-in at {END_S} s")

        if data is not None:
            # Deserialized (the plugin loaded again) in another instance: continues
            # bit-identically, with the name relative to the resources.
            e = Drive(md, unzipdir, name="restored")
            s2 = e.fmu.deSerializeFMUstate(data)
            e.fmu.setFMUstate(s2)
            e.t = SAVE_S
            e.step_to(END_S)
            check(outputs(e) == builtin, f"deserialized plugin state ({len(data)} bytes) continues bit-identically")
            check(get_plugin(e) == (fmi2OK, "example.so"), "the state carries strategy.plugin")
            e.fmu.freeFMUstate(s2)
            finish(e)
        d.fmu.freeFMUstate(state)
        finish(d)


def refused_at_init(md, unzipdir, path, needle, what):
    """exitInitializationMode gives Error naming the file; the instance stays usable."""
    d = start(md, unzipdir, path)
    d.log.take()
    check(d.raw("fmi2ExitInitializationMode") == fmi2Error, f"{what}: fmi2Error")
    ok, e = errors_logged(d.log, needle)
    check(ok and any(path in m for _, _, m in e), f"  logged as logStatusError naming the file: {e}")
    check(set_plugin(d, "") == fmi2OK and d.raw("fmi2ExitInitializationMode") == fmi2OK,
          "  back to the built-in strategy, the instance initializes")
    finish(d)


def bad_files(md, unzipdir):
    refused_at_init(md, unzipdir, "/nonexistent/plugin.so", "no file at", "non-existent path")
    refused_at_init(md, unzipdir, "missing.so", os.path.join("resources", "missing.so"),
                    "relative path not in resources")
    text = os.path.join(unzipdir, "resources", "notes.so")
    with open(text, "w") as f:
        f.write("a text file, not a library\n")
    refused_at_init(md, unzipdir, text, "not a loadable shared library", "a non-library file")


def misbehaving(md, unzipdir):
    for mode, needle in [("magic", "bad magic"), ("major", "majors must be equal"),
                         ("null-header", "null header"), ("create-error", "create-error")]:
        os.environ["BLDC_TEST_MISBEHAVE"] = mode
        refused_at_init(md, unzipdir, MISBEHAVING_PLUGIN, needle, f"misbehaving plugin ({mode})")

    # Faults while stepping (from tick 64 000, 1.28 ms): the step fails, nothing crashes.
    for mode, needle in [("panic", "deliberate panic"), ("shoot-through", "shoot-through")]:
        os.environ["BLDC_TEST_MISBEHAVE"] = mode
        if mode == "panic":
            print("(the plugin's panic message on stderr is expected)", flush=True)
        d = start(md, unzipdir, MISBEHAVING_PLUGIN)
        check(d.raw("fmi2ExitInitializationMode") == fmi2OK, f"misbehaving plugin ({mode}) loads")
        d.log.take()
        status = fmi2OK
        while status == fmi2OK and d.t < 0.01:
            status = d.raw("fmi2DoStep", d.t, H, 1)
            d.t += H
        check(status == fmi2Error, f"plugin fault ({mode}) during a step: fmi2Error")
        ok, e = errors_logged(d.log, needle)
        check(ok and any(MISBEHAVING_PLUGIN in m for _, _, m in e),
              f"  logged as logStatusError naming the file: {e}")
        check(d.raw("fmi2DoStep", d.t, H, 1) == fmi2Error, "  no further steps after the fault")
        check(d.raw("fmi2Reset") == fmi2OK, "  fmi2Reset recovers the instance")
        d.fmu.freeInstance()
    os.environ.pop("BLDC_TEST_MISBEHAVE", None)


def bad_string_calls(md, unzipdir):
    d = Drive(md, unzipdir)
    uint = ctypes.c_uint
    vr = (uint * 1)(d.vr["strategy.plugin"])
    check(d.raw("fmi2SetString", vr, 1, None) == fmi2Error, "fmi2SetString, NULL value array: Error")
    check(d.raw("fmi2SetString", vr, 1, (ctypes.c_char_p * 1)(None)) == fmi2Error,
          "fmi2SetString, a NULL string: Error")
    ok, e = errors_logged(d.log, "NULL")
    check(ok, f"  logged as logStatusError: {e}")
    real = (uint * 1)(d.vr["motor.resistance_ohm"])
    check(d.raw("fmi2SetString", real, 1, (ctypes.c_char_p * 1)(b"x")) == fmi2Error,
          "fmi2SetString of a Real: Error")
    check(d.raw("fmi2SetString", (uint * 1)(99999), 1, (ctypes.c_char_p * 1)(b"x")) == fmi2Error,
          "fmi2SetString of an unknown value reference: Error")
    check(d.raw("fmi2SetString", vr, 1, (ctypes.c_char_p * 1)(b"\xff.so")) == fmi2Error,
          "fmi2SetString of bytes that are not UTF-8: Error")
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.enterInitializationMode()
    check(d.raw("fmi2GetString", vr, 1, None) == fmi2Error, "fmi2GetString, NULL value array: Error")
    check(get_plugin(d) == (fmi2OK, ""), "start value is the empty string")
    # The string is copied: the caller's buffer may change or go away after the call.
    buf = ctypes.create_string_buffer(b"/tmp/first.so")
    d.raw("fmi2SetString", vr, 1, (ctypes.c_char_p * 1)(ctypes.addressof(buf)))
    ctypes.memmove(buf, b"/tmp/other.so", 13)
    check(get_plugin(d) == (fmi2OK, "/tmp/first.so"), "fmi2SetString copies the string")
    set_plugin(d, "")
    d.fmu.exitInitializationMode()
    check(set_plugin(d, EXAMPLE_PLUGIN) == fmi2Error, "strategy.plugin after initialization: Error")
    ok, e = errors_logged(d.log, "fixed parameter")
    check(ok, f"  logged as logStatusError: {e}")
    finish(d)


if __name__ == "__main__":
    main()
