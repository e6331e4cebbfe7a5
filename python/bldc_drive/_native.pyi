"""Type stubs of the native part of bldc_drive (python/src/lib.rs)."""

from typing import List, Optional, Tuple

VERSION: str

def default_config() -> str:
    """The built-in config as a JSON object."""

def not_finite(key: str, value: float) -> str:
    """The refusal of ``key`` = ``value`` (NaN or infinite), as every door words it."""

def refusal(key: str, value: str, rule: str) -> str:
    """The refusal of ``key`` = ``value`` (as written) for breaking ``rule``."""

def strategies(plugins: List[str] = ...) -> List[str]:
    """The built-in strategies' names, then the plugins' (paths of plugin libraries)."""

def simulate(
    case_json: str, plugins: List[str] = ...
) -> Tuple[str, Optional[List[Tuple[str, str, bytes]]]]:
    """Runs a case (a JSON object), whose strategy may be one of ``plugins``: the run's
    record as JSON, and with ``trace_every_us`` the trace's columns as (name, NumPy
    dtype, bytes)."""

def sweep_seeds(cases_json: str, plugins: List[str] = ...) -> List[int]:
    """Checks every case of a JSON list; each case's seed."""

def sweep_row(index: int, case_json: str, plugins: List[str] = ...) -> str:
    """Runs case ``index`` of a sweep; its row as a JSON object."""
