"""fmpy validate + fmpy simulate of a speed-reference profile, compared with the same
scenario run natively in Rust (target/release/native-trace)."""

import os
import subprocess
import sys
import tempfile

import numpy as np
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from fmu_paths import FMU, NATIVE_TRACE, check, require_built

STOP, STEP = 5.0, 1e-3
# Piecewise constant: 3000 rpm, then 4000 rpm at 2.5 s; a load of 0.1 mN·m from 3.5 s.
PROFILE = [
    (0.0, 3000.0, 0.0),
    (2.5, 3000.0, 0.0),
    (2.5, 4000.0, 0.0),
    (3.5, 4000.0, 0.0),
    (3.5, 4000.0, 1e-4),
    (STOP, 4000.0, 1e-4),
]
COLUMNS = ["speed_rpm", "speed_est_rpm", "theta_e_deg", "i_u", "i_v", "i_w", "torque_nm",
           "duty", "state", "restarts"]
INPUTS = ["speed_ref_rpm", "load_torque_nm"]


def mean_between(t, x, a, b):
    sel = (t >= a) & (t <= b)
    return float(np.mean(x[sel]))


def main():
    require_built()
    problems = validate_fmu(FMU)
    check(problems == [], f"fmpy validate: {len(problems)} problems {problems}")

    signals = np.array([(t, s, l, True) for t, s, l in PROFILE],
                       dtype=[("time", np.float64), ("speed_ref_rpm", np.float64),
                              ("load_torque_nm", np.float64), ("enable", np.bool_)])
    # Inputs are continuous, so fmpy interpolates the table: a constant piece can come out
    # an ulp off (3000.0000000000005), which the drive sees as a change (the plant then ends
    # its step there). The native run is given exactly what the FMU was given: fmpy sets
    # the inputs at each communication point before the step, and the FMU reads back the
    # value in force, so the input read at row k + 1 is the one applied over step k. With
    # the same inputs at the same instants the two runs are the same computation and must
    # agree bit for bit (an approximate match would hide a divergence behind the chip's
    # quantisation: one ADC code or PWM count apart, two runs part for good).
    fmi = simulate_fmu(FMU, validate=True, start_time=0.0, stop_time=STOP, output_interval=STEP,
                       input=signals, output=COLUMNS + INPUTS + ["in_sync"])
    t = fmi["time"]
    check(len(t) == round(STOP / STEP) + 1, f"fmpy simulate: {len(t)} rows")

    with tempfile.TemporaryDirectory() as d:
        prof = os.path.join(d, "profile.csv")
        with open(prof, "w") as f:
            f.write("time,speed_ref_rpm,load_torque_nm\n")
            f.writelines(f"{float(t[k])!r},{float(fmi[INPUTS[0]][k + 1])!r},"
                         f"{float(fmi[INPUTS[1]][k + 1])!r}\n"
                         for k in range(len(t) - 1))
        out = os.path.join(d, "native.csv")
        subprocess.run([NATIVE_TRACE, prof, str(STOP), str(STEP), out], check=True)
        native = np.genfromtxt(out, delimiter=",", names=True)

    check(np.allclose(native["time"], t, rtol=0, atol=1e-12), "same communication points")
    for c in COLUMNS:
        diff = float(np.max(np.abs(fmi[c] - native[c])))
        check(diff == 0.0, f"{c}: FMU vs native max |diff| = {diff:.3g}")

    s = fmi["speed_rpm"]
    m1 = mean_between(t, s, 2.0, 2.5)
    m2 = mean_between(t, s, 4.5, 5.0)
    check(abs(m1 - 3000) < 0.02 * 3000, f"reaches 3000 rpm: mean {m1:.0f} over 2.0..2.5 s")
    check(float(np.max(s[(t > 2.5) & (t < 3.5)])) > 3960, "reaches 4000 rpm within 1 s of the step")
    check(abs(m2 - 4000) < 0.02 * 4000, f"holds 4000 rpm under load: mean {m2:.0f} over 4.5..5.0 s")
    check(int(fmi["restarts"][-1]) == 0, "no restarts")
    sync = fmi["in_sync"]
    check(not bool(np.any(sync[t < 0.7])), "in_sync false while aligning")
    check(bool(np.all(sync[t >= 1.5])), "in_sync true from 1.5 s on")
    th = fmi["theta_e_deg"]
    check(bool(np.all((th >= 0) & (th < 360))), "theta_e_deg in [0, 360)")
    d = fmi["duty"]
    check(bool(np.all((d >= 0) & (d <= 1))), "duty in [0, 1]")

    if check.failures:
        sys.exit(f"{check.failures} check(s) failed")


if __name__ == "__main__":
    main()
