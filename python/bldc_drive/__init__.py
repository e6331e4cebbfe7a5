"""Simulation of sensorless brushless-DC motor drives, from Python.

``simulate`` runs one drive from standstill, as ``drive-bench run`` does, and returns its
summary (the same keys and values as ``drive-bench run --json``) and, on request, its
trace. ``sweep`` runs many such cases on a Dask cluster and gathers them into one pandas
DataFrame. ``default_config`` gives every config key with its built-in value.
"""

from ._api import Result, default_config, simulate, strategies
from ._sweep import sweep
from ._native import VERSION as __version__

__all__ = ["Result", "default_config", "simulate", "strategies", "sweep", "__version__"]
