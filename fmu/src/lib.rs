//! fmu: the drive as an FMI 2.0 co-simulation FMU (arrives with its own issue).
