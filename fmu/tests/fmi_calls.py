"""fmpy-driven call sequences: state save/restore and serialize/deserialize, reset and rerun,
two instances in one process, wrong GUID, out-of-order and bad calls (each answered with
a status and a logged message, never a crash)."""

import ctypes
import shutil
import sys
import tempfile

from fmpy import extract, read_model_description
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2Error, fmi2OK,
                       fmi2Warning)
from fmpy.fmi2 import calloc, free
from fmpy.fmi1 import FMICallException
from fmpy.logging import addLoggerProxy

from fmu_paths import FMU, check, require_built

OUTPUTS = ["speed_rpm", "speed_est_rpm", "theta_e_deg", "i_u", "i_v", "i_w", "torque_nm", "duty"]
H = 1e-3


class Log:
    """Collects (status, category, message) from the FMU's logger."""

    def __init__(self):
        self.entries = []
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(self.on_message)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(ctypes.byref(self.callbacks))

    def on_message(self, env, name, status, category, message):
        self.entries.append((status, (category or b"").decode(), message.decode()))

    def take(self):
        e, self.entries = self.entries, []
        return e


class Drive:
    """One FMU instance with raw status access (fmpy's wrappers raise on errors)."""

    def __init__(self, md, unzipdir, name="drive", guid=None):
        self.md = md
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.log = Log()
        self.fmu = FMU2Slave(guid=guid or md.guid, unzipDirectory=unzipdir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=self.log.callbacks)
        self.t = 0.0

    def init(self, **start):
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for k, v in start.items():
            self.set_real(k, v)
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def set_real(self, name, value):
        vr = (ctypes.c_uint * 1)(self.vr[name])
        val = (ctypes.c_double * 1)(value)
        return self.raw("fmi2SetReal", vr, 1, val)

    def raw(self, fn, *args):
        """Calls fmi2<fn> and returns its status (fmpy raises on Error; we want the code)."""
        try:
            return getattr(self.fmu, fn)(self.fmu.component, *args)
        except FMICallException as e:
            return e.status

    def step_to(self, t_end):
        while self.t < t_end - 1e-12:
            self.fmu.doStep(self.t, H)
            self.t += H

    def outputs(self):
        return self.fmu.getReal([self.vr[n] for n in OUTPUTS])


def run(md, unzipdir, t_end, **start):
    d = Drive(md, unzipdir)
    d.init(**start)
    d.step_to(t_end)
    out = d.outputs()
    d.fmu.terminate()
    d.fmu.freeInstance()
    return out


def errors_logged(log, needle):
    entries = log.take()
    return any(s == fmi2Error and c == "logStatusError" and needle in m for s, c, m in entries), entries


def main():
    require_built()
    md = read_model_description(FMU)
    unzipdir = extract(FMU)
    try:
        state_continuation(md, unzipdir)
        reset_and_rerun(md, unzipdir)
        two_instances(md, unzipdir)
        wrong_guid(md, unzipdir)
        bad_calls(md, unzipdir)
    finally:
        shutil.rmtree(unzipdir, ignore_errors=True)
    if check.failures:
        sys.exit(f"{check.failures} check(s) failed")


def state_continuation(md, unzipdir):
    d = Drive(md, unzipdir)
    d.init()
    d.step_to(1.0)  # running closed loop by now
    state = d.fmu.getFMUstate()
    d.set_real("load_torque_nm", 2e-4)
    d.step_to(1.2)
    first = d.outputs()

    d.fmu.setFMUstate(state)
    d.t = 1.0
    d.set_real("load_torque_nm", 2e-4)
    d.step_to(1.2)
    check(d.outputs() == first, "restored state continues bit-identically")

    data = d.fmu.serializeFMUstate(state)
    copy = d.fmu.deSerializeFMUstate(data)
    d.fmu.setFMUstate(copy)
    d.t = 1.0
    d.set_real("load_torque_nm", 2e-4)
    d.step_to(1.2)
    check(d.outputs() == first, f"deserialized state ({len(data)} bytes) continues bit-identically")

    # A state carried into a fresh instance (as after a process restart) continues too.
    e = Drive(md, unzipdir, name="other")
    s2 = e.fmu.deSerializeFMUstate(data)
    e.fmu.setFMUstate(s2)
    e.t = 1.0
    e.set_real("load_torque_nm", 2e-4)
    e.step_to(1.2)
    check(e.outputs() == first, "serialized state restored in another instance continues bit-identically")
    e.fmu.freeFMUstate(s2)
    e.fmu.terminate()
    e.fmu.freeInstance()
    d.fmu.freeFMUstate(copy)
    d.fmu.freeFMUstate(state)
    d.fmu.terminate()
    d.fmu.freeInstance()


def reset_and_rerun(md, unzipdir):
    d = Drive(md, unzipdir)
    d.init(speed_ref_rpm=2500.0)
    d.step_to(0.9)
    first = d.outputs()
    check(d.raw("fmi2Reset") == fmi2OK, "fmi2Reset returns OK")
    d.init(speed_ref_rpm=2500.0)
    d.step_to(0.9)
    check(d.outputs() == first, "reset and rerun gives the same outputs")
    check(d.fmu.getReal([d.vr["speed_ref_rpm"]])[0] == 2500.0, "input kept its set value")
    d.fmu.reset()
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.enterInitializationMode()
    check(d.fmu.getReal([d.vr["speed_ref_rpm"]])[0] == 3000.0, "reset restores start values")
    d.fmu.exitInitializationMode()
    d.fmu.terminate()
    d.fmu.freeInstance()


def two_instances(md, unzipdir):
    solo_a = run(md, unzipdir, 0.9, speed_ref_rpm=3000.0)
    solo_b = run(md, unzipdir, 0.9, speed_ref_rpm=2000.0)
    a, b = Drive(md, unzipdir, "a"), Drive(md, unzipdir, "b")
    a.init(speed_ref_rpm=3000.0)
    b.init(speed_ref_rpm=2000.0)
    while a.t < 0.9 - 1e-12:  # interleaved steps
        a.step_to(a.t + H)
        b.step_to(b.t + H)
    check(a.outputs() == solo_a and b.outputs() == solo_b,
          "two interleaved instances match their solo runs")
    check(a.outputs() != b.outputs(), "the two instances differ")
    for x in (a, b):
        x.fmu.terminate()
        x.fmu.freeInstance()


def wrong_guid(md, unzipdir):
    log = Log()
    fmu = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=unzipdir,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="wrong")
    try:
        fmu.instantiate(callbacks=log.callbacks)
        check(False, "wrong GUID refused")
    except Exception as e:  # fmpy raises when fmi2Instantiate returns NULL
        check("instantiate" in str(e).lower(), f"wrong GUID refused ({e})")
    ok, e = errors_logged(log, "wrong GUID")
    check(ok, f"  logged with category logStatusError: {e}")


def bad_calls(md, unzipdir):
    d = Drive(md, unzipdir)
    log = d.log
    vr = d.vr
    one = lambda t, x: (t * 1)(x)  # noqa: E731
    dbl, uint = ctypes.c_double, ctypes.c_uint

    # Out of order.
    check(d.raw("fmi2DoStep", 0.0, H, 1) == fmi2Error, "doStep before initialization: Error")
    ok, e = errors_logged(log, "fmi2DoStep")
    check(ok, f"  logged with category logStatusError: {e}")
    out = one(dbl, 0.0)
    check(d.raw("fmi2GetReal", one(uint, vr["speed_rpm"]), 1, out) == fmi2Error,
          "getReal of an output before initialization: Error")
    check(d.raw("fmi2Terminate") == fmi2Error, "terminate before initialization: Error")
    check(d.raw("fmi2ExitInitializationMode") == fmi2Error, "exitInitializationMode first: Error")
    log.take()

    # Parameter outside its declared range: refused when set, naming it and the rule.
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.enterInitializationMode()
    check(d.set_real("motor.resistance_ohm", -2.0) == fmi2Error, "negative resistance: Error when set")
    ok, e = errors_logged(log, "`motor.resistance_ohm` = -2")
    check(ok and any("rule" in m for _, _, m in e), f"  message names the parameter and rule: {e}")
    bad_int = one(ctypes.c_int, -3)
    check(d.raw("fmi2SetInteger", one(uint, vr["motor.poles"]), 1, bad_int) == fmi2Error,
          "negative pole count: Error when set")
    ok, e = errors_logged(log, "motor.poles")
    check(ok, f"  message names the parameter: {e}")
    # All or nothing: a valid resistance next to a load beyond 1 N.m is not applied either.
    two = (uint * 2)(vr["motor.resistance_ohm"], vr["load_torque_nm"])
    check(d.raw("fmi2SetReal", two, 2, (dbl * 2)(3.3, 5.0)) == fmi2Error,
          "set of a valid and an invalid value: Error")
    ok, e = errors_logged(log, "`load_torque_nm` = 5")
    check(ok and any("none of the 2 was applied" in m for _, _, m in e),
          f"  message names the variable and says nothing was applied: {e}")
    check(d.fmu.getReal([vr["motor.resistance_ohm"]])[0] != 3.3, "  the valid value was not applied")
    # A rule tying two parameters is checked when the drive is built.
    check(d.set_real("motor.mutual_inductance_h", 0.9) == fmi2OK, "mutual inductance within its range: OK")
    check(d.raw("fmi2ExitInitializationMode") == fmi2Error, "mutual above self inductance: Error at exit")
    ok, e = errors_logged(log, "inductance")
    check(ok, f"  message names the parameter: {e}")
    d.set_real("motor.mutual_inductance_h", 0.0)
    check(d.raw("fmi2ExitInitializationMode") == fmi2OK, "fixed values: exit OK")

    # A damaged serialized state: refused with a logged reason, nothing built.
    state = d.fmu.getFMUstate()
    data = bytearray(d.fmu.serializeFMUstate(state))
    d.fmu.freeFMUstate(state)
    data[len(data) // 2] ^= 0x10
    copy = ctypes.c_void_p()
    buf = (ctypes.c_char * len(data)).from_buffer(data)
    check(d.raw("fmi2DeSerializeFMUstate", buf, len(data), ctypes.byref(copy)) == fmi2Error,
          "bit-flipped serialized state: Error")
    ok, e = errors_logged(log, "checksum")
    check(ok, f"  logged as a checksum mismatch: {e}")

    # Bad values, references, steps.
    check(d.set_real("speed_ref_rpm", float("nan")) == fmi2Error, "NaN input: Error")
    check(d.set_real("load_torque_nm", float("inf")) == fmi2Error, "infinite input: Error")
    check(d.set_real("speed_ref_rpm", 1e6) == fmi2Warning, "speed command beyond 16383: Warning")
    check(any(c == "logStatusWarning" for _, c, _ in log.take()), "  logged as a warning")
    d.set_real("speed_ref_rpm", 3000.0)
    check(d.set_real("motor.resistance_ohm", 3.0) == fmi2Error, "parameter after init: Error")
    check(d.raw("fmi2GetReal", one(uint, 99999), 1, out) == fmi2Error, "unknown value reference: Error")
    check(d.raw("fmi2GetReal", one(uint, vr["state"]), 1, out) == fmi2Error,
          "Integer read as Real: Error")
    check(d.raw("fmi2GetReal", one(uint, vr["speed_rpm"]), 1, None) == fmi2Error,
          "NULL value array: Error")
    check(d.raw("fmi2DoStep", 0.0, -H, 1) == fmi2Error, "negative step: Error")
    check(d.raw("fmi2DoStep", 0.0, float("nan"), 1) == fmi2Error, "NaN step: Error")
    check(d.raw("fmi2DoStep", 0.0, float("inf"), 1) == fmi2Error, "infinite step: Error")
    check(d.raw("fmi2DoStep", 0.5, H, 1) == fmi2Error, "wrong communication point: Error")
    check(d.raw("fmi2CancelStep") == fmi2Error, "cancelStep (unsupported): Error")
    check(d.raw("fmi2GetDirectionalDerivative", None, 0, None, 0, None, None) == fmi2Error,
          "getDirectionalDerivative (unsupported): Error")
    check(d.raw("fmi2SetFMUstate", ctypes.c_void_p(12345)) == fmi2Error, "foreign FMU state: Error")
    check(d.raw("fmi2DeSerializeFMUstate", b"garbage", 7, ctypes.byref(ctypes.c_void_p())) == fmi2Error,
          "garbage serialized state: Error")
    entries = log.take()
    # The 12 refusals since the warning check, each logged once as an error, plus the
    # all-or-nothing summary of the refused fmi2SetReal.
    check(len(entries) == 13 and all(s == fmi2Error and c == "logStatusError" for s, c, _ in entries),
          f"every refusal logged with its category ({len(entries)} messages)")

    # Sub-tick steps (7 ns) and ulp jitter are fine; the instance still works after errors.
    t = 0.0
    for k in range(1, 101):
        check_status = d.raw("fmi2DoStep", t, 7e-9, 1)
        if check_status != fmi2OK:
            break
        t = k * 7e-9
    check(check_status == fmi2OK, "100 steps of 7 ns: OK")
    check(d.raw("fmi2DoStep", t * (1 + 1e-15), 1e-3, 1) == fmi2OK, "ulp jitter in the point: OK")
    check(d.raw("fmi2Terminate") == fmi2OK, "terminate: OK")
    check(d.raw("fmi2DoStep", t + 1e-3, H, 1) == fmi2Error, "doStep after terminate: Error")
    d.fmu.freeInstance()
    d.fmu.fmi2FreeInstance(None)  # NULL is ignored
    check(True, "freeInstance(NULL) did not crash")


if __name__ == "__main__":
    main()
