"""The C SDK's example plugin in the FMU, driven by fmpy: `cargo xtask fmu --plugin
libc_six_step.so --out BldcDrive-c-six-step.fmu` packs the plugin the system C compiler
built (plugins/c-example) into the FMU's resources; the FMU passes fmpy's validation; with
`strategy.plugin` naming it relative to the resources it starts the motor from standstill
and holds the 3000 rpm command; a state serialized while it runs and deserialized into
another instance continues bit-identically to the uninterrupted run."""

import os
import subprocess
import sys

from fmpy import extract, read_model_description
from fmpy.fmi2 import fmi2OK
from fmpy.validation import validate_fmu

from fmi_calls import Drive
from fmu_paths import PLUGIN_DIR, ROOT, TARGET, check, require_built

C_PLUGIN = os.path.join(PLUGIN_DIR, "libc_six_step.so")
OUT = os.path.join(TARGET, "fmu", "BldcDrive-c-six-step.fmu")
OUTPUTS = ["speed_rpm", "speed_est_rpm", "i_u", "duty", "theta_e_deg"]
SPEED = 3000.0
# The comparators take over at ~0.3 s; saved at 0.9 s while the speed loop still pulls the
# motor up, compared at 1.3 s; judged at 2.5 s.
SAVE_S, CMP_S, END_S = 0.9, 1.3, 2.5


def outputs(d):
    return d.fmu.getReal([d.vr[n] for n in OUTPUTS]) + d.fmu.getInteger([d.vr["state"]])


def start(md, unzipdir, name):
    d = Drive(md, unzipdir, name=name)
    d.fmu.setupExperiment(startTime=0.0)
    d.fmu.enterInitializationMode()
    d.fmu.setString([d.vr["strategy.plugin"]], ["libc_six_step.so"])
    check(d.set_real("speed_ref_rpm", SPEED) == fmi2OK, f"{name}: speed_ref_rpm = {SPEED}")
    check(d.raw("fmi2ExitInitializationMode") == fmi2OK, f"{name}: the C plugin loads")
    d.t = 0.0
    return d


def main():
    require_built()
    if not os.path.exists(C_PLUGIN):
        sys.exit(f"FAIL: {C_PLUGIN} is missing: run "
                 "`cargo build --profile test -p c-example-plugin` first (it needs a C compiler)")
    cargo = os.environ.get("CARGO", "cargo")
    subprocess.run([cargo, "xtask", "fmu", "--plugin", C_PLUGIN, "--out", OUT], cwd=ROOT,
                   check=True, stdout=subprocess.DEVNULL)
    problems = validate_fmu(OUT)
    check(problems == [], f"fmpy validate {os.path.basename(OUT)}: {len(problems)} problems {problems}")
    md = read_model_description(OUT)
    unzipdir = extract(OUT)
    check(os.path.exists(os.path.join(unzipdir, "resources", "libc_six_step.so")),
          "the C plugin is packed in the resources")

    d = start(md, unzipdir, "c-plugin")
    d.step_to(SAVE_S)
    at_save = outputs(d)
    check(at_save[0] > 1000 and 1 <= at_save[-1] <= 6,
          f"commutating on its crossings at {SAVE_S} s ({at_save[0]:.0f} rpm, state {at_save[-1]})")
    state = d.fmu.getFMUstate()
    data = d.fmu.serializeFMUstate(state)
    d.fmu.freeFMUstate(state)
    d.step_to(CMP_S)
    uninterrupted = outputs(d)

    e = Drive(md, unzipdir, name="restored")
    s2 = e.fmu.deSerializeFMUstate(data)
    e.fmu.setFMUstate(s2)
    e.fmu.freeFMUstate(s2)
    e.t = SAVE_S
    e.step_to(CMP_S)
    restored = outputs(e)
    check(restored == uninterrupted,
          f"serialized at {SAVE_S} s ({len(data)} bytes), deserialized, continued to {CMP_S} s: "
          f"bit-identical ({restored} vs {uninterrupted})")

    d.step_to(END_S)
    speeds = []
    while d.t < END_S + 0.2 - 1e-12:
        d.step_to(d.t + 0.01)
        speeds.append(outputs(d)[0])
    low, high = min(speeds), max(speeds)
    check(0.98 * SPEED < low and high < 1.02 * SPEED,
          f"holds {SPEED:.0f} rpm within 2 % from {END_S} s ({low:.1f}..{high:.1f} rpm)")
    for x in (d, e):
        x.fmu.terminate()
        x.fmu.freeInstance()
    if check.failures:
        sys.exit(f"{check.failures} check(s) failed")


if __name__ == "__main__":
    main()
