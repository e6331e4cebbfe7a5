"""The drive's FMU in Python with fmpy: a speed step from 3000 to 5000 rpm at 2.5 s with a
0.2 mN·m load, the strategy set as a parameter. Prints the true and estimated speed every
0.5 s and whether the commutation stays in synchronism with the true rotor.

    cargo xtask fmu                                  # → target/fmu/BldcDrive.fmu
    python3 -m pip install fmpy numpy
    python3 examples/fmu/speed_step.py [path/to/BldcDrive.fmu]
"""

import os
import sys

import numpy as np
from fmpy import simulate_fmu

HERE = os.path.dirname(os.path.abspath(__file__))
FMU = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "..", "..", "target", "fmu",
                                                         "BldcDrive.fmu")
STOP = 5.0

# Inputs as a table; fmpy interpolates linearly, so a step is two rows at one instant.
inputs = np.array(
    [(0.0, 3000.0, 2e-4, True), (2.5, 3000.0, 2e-4, True),
     (2.5, 5000.0, 2e-4, True), (STOP, 5000.0, 2e-4, True)],
    dtype=[("time", np.float64), ("speed_ref_rpm", np.float64),
           ("load_torque_nm", np.float64), ("enable", np.bool_)])

result = simulate_fmu(
    FMU,
    stop_time=STOP,
    output_interval=1e-3,
    input=inputs,
    # Enumeration items count from 1: 8 is twelve_step_df (see modelDescription.xml).
    start_values={"strategy.name": 8, "motor.resistance_ohm": 2.4},
    output=["speed_rpm", "speed_est_rpm", "i_u", "duty", "in_sync", "verdict"],
)
# The verdict enumeration's items, in value order (from 1).
VERDICTS = ["running", "off_speed", "lost_sync", "stalled", "not_started", "gave_up",
            "non_finite", "stopped", "unsettled"]

print(" t [s]   true [rpm]   chip [rpm]   duty   in sync")
for row in result[::500]:
    print(f"{row['time']:5.2f}  {row['speed_rpm']:11.1f}  {row['speed_est_rpm']:11.1f}"
          f"  {row['duty']:5.2f}   {bool(row['in_sync'])}")
last = result[result["time"] >= STOP - 1.0]
mean = float(np.mean(last["speed_rpm"]))
verdict = VERDICTS[int(result["verdict"][-1]) - 1]
print(f"mean true speed over the last second: {mean:.1f} rpm;"
      f" in synchronism throughout: {bool(np.all(last['in_sync']))}; verdict at the end: {verdict}")
# A usable exit status for scripts: 0 when the drive ends running (within 2 % of the
# command, in synchronism with the true rotor).
sys.exit(0 if verdict == "running" and np.all(last["in_sync"]) else 1)
