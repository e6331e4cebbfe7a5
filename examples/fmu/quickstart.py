# The FMU in 15 lines of Python: 4000 rpm from standstill on a warm winding, with fmpy.
import sys
from fmpy import simulate_fmu

fmu = sys.argv[1] if len(sys.argv) > 1 else "target/fmu/BldcDrive.fmu"  # cargo xtask fmu
r = simulate_fmu(fmu, stop_time=4.0, output_interval=1e-3,
                 start_values={"speed_ref_rpm": 4000.0, "motor.resistance_ohm": 2.4},
                 output=["speed_rpm", "speed_est_rpm", "in_sync", "verdict"])
for row in r[::500]:  # every 0.5 s: true speed, the chip's estimate, synchronism
    print(f"{row['time']:4.1f} s  {row['speed_rpm']:7.1f} rpm  "
          f"chip {row['speed_est_rpm']:7.1f} rpm  in sync: {bool(row['in_sync'])}")
verdicts = ["running", "off_speed", "lost_sync", "stalled", "not_started", "gave_up",
            "non_finite", "stopped", "unsettled"]  # the `verdict` enumeration's items, from 1
print("verdict:", verdicts[r["verdict"][-1] - 1])
sys.exit(0 if r["verdict"][-1] == 1 else 1)
