"""The FMU binary exports exactly the 34 FMI 2.0 co-simulation functions, nothing else."""

import shutil
import subprocess
import sys
import tempfile
import zipfile

from fmu_paths import FMU, check, require_built

# FMI 2.0.5, section 2.3 / 4.2: 25 common functions plus 9 co-simulation functions.
EXPECTED = sorted("""
fmi2GetTypesPlatform fmi2GetVersion fmi2SetDebugLogging fmi2Instantiate fmi2FreeInstance
fmi2SetupExperiment fmi2EnterInitializationMode fmi2ExitInitializationMode fmi2Terminate
fmi2Reset fmi2GetReal fmi2GetInteger fmi2GetBoolean fmi2GetString fmi2SetReal fmi2SetInteger
fmi2SetBoolean fmi2SetString fmi2GetFMUstate fmi2SetFMUstate fmi2FreeFMUstate
fmi2SerializedFMUstateSize fmi2SerializeFMUstate fmi2DeSerializeFMUstate
fmi2GetDirectionalDerivative fmi2SetRealInputDerivatives fmi2GetRealOutputDerivatives
fmi2DoStep fmi2CancelStep fmi2GetStatus fmi2GetRealStatus fmi2GetIntegerStatus
fmi2GetBooleanStatus fmi2GetStringStatus
""".split())


def main():
    require_built()
    if shutil.which("nm") is None:
        sys.exit("FAIL: `nm` not found: install binutils (apt-get install binutils)")
    check(len(EXPECTED) == 34, "34 functions in the expected list")
    with tempfile.TemporaryDirectory() as d, zipfile.ZipFile(FMU) as z:
        names = z.namelist()
        check(sorted(names) == ["binaries/linux64/bldc_drive.so", "modelDescription.xml"],
              f"archive entries {names}")
        so = z.extract("binaries/linux64/bldc_drive.so", d)
        out = subprocess.run(["nm", "-D", "--defined-only", so], check=True,
                             capture_output=True, text=True).stdout
    exported = sorted(line.split()[-1] for line in out.splitlines() if line.strip())
    check(exported == EXPECTED, f"exported symbols are exactly the FMI functions "
                                f"(extra {sorted(set(exported) - set(EXPECTED))}, "
                                f"missing {sorted(set(EXPECTED) - set(exported))})")
    if check.failures:
        sys.exit(f"{check.failures} check(s) failed")


if __name__ == "__main__":
    main()
