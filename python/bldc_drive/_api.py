"""One run: the case's keys checked and passed to the native library as JSON."""

from __future__ import annotations

import json
import math
import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native

# The keys of a case, in simulate's order (the library's `case::KEYS`).
KEYS = ("strategy", "speed_rpm", "duration_s", "load_nm", "config", "scenario", "seed", "trace_every_us")


def default_config() -> Dict[str, Any]:
    """Every config key with its built-in value, as nested dicts (``drive-bench config``).

    A dict of this shape, or any part of it, is what ``simulate(config=...)`` takes.
    """
    return json.loads(_native.default_config())


def strategies(plugins: Sequence[Union[str, "os.PathLike[str]"]] = ()) -> list:
    """The names of the built-in strategies (``drive-bench list``), then those of the
    plugin libraries at the paths ``plugins`` (``drive-bench --plugin PATH list``)."""
    return list(_native.strategies(plugin_paths(plugins)))


def plugin_paths(plugins: Sequence[Union[str, "os.PathLike[str]"]]) -> List[str]:
    """Plugin paths as absolute strings: a Dask worker may run in another folder. A
    single path rather than a sequence of them is a ValueError."""
    if isinstance(plugins, (str, bytes, os.PathLike)):
        raise ValueError(f"plugins = {plugins!r} (rule: a list of paths, e.g. [path])")
    return [os.path.abspath(os.fspath(p)) for p in plugins]


class Result:
    """What one run gave.

    Attributes:
        summary: the run's summary, a dict with the keys and values of the ``summary``
            of ``drive-bench run --json`` (``wall_s`` and ``realtime_factor`` are
            wall-clock figures and differ from run to run).
        scenario: the complete scenario that ran (every config key, the seed, the
            profiles), the ``scenario`` of ``drive-bench run --json``: given back as
            ``simulate(scenario=result.scenario)`` it runs again.
        record: the whole ``drive-bench run --json`` document.
        trace: with ``trace_every_us``, the trace: a pandas DataFrame when pandas is
            installed, else a dict of NumPy arrays, with the columns of
            ``drive-bench run --trace`` (time in s, speeds in rpm, currents in A,
            voltages in V, torque in N·m); else None.
    """

    def __init__(self, record: Dict[str, Any], trace: Any) -> None:
        self.record = record
        self.summary: Dict[str, Any] = record["summary"]
        self.scenario: Dict[str, Any] = record["scenario"]
        self.trace = trace

    @property
    def verdict(self) -> str:
        """The verdict: ``running``, ``off-speed``, ``lost-sync``, ``stalled``,
        ``not-started``, ``gave-up``, ``non-finite``, ``stopped`` (told 0 rpm, at rest) or
        ``unsettled`` (the window began inside the start-up: not judged)."""
        return self.summary["verdict"]

    def __repr__(self) -> str:
        s = self.summary
        return (
            f"Result({s['strategy']} at {s['speed_ref_rpm']:.0f} rpm: {s['verdict']}: "
            f"{s['verdict_reason']})"
        )


def simulate(
    strategy: Optional[str] = None,
    speed_rpm: Optional[float] = None,
    duration_s: Optional[float] = None,
    load_nm: float = 0.0,
    config: Union[None, str, "os.PathLike[str]", Mapping[str, Any]] = None,
    scenario: Union[None, str, "os.PathLike[str]", Mapping[str, Any]] = None,
    seed: Optional[int] = None,
    trace_every_us: Optional[float] = None,
    plugins: Sequence[Union[str, "os.PathLike[str]"]] = (),
) -> Result:
    """Runs one drive from standstill and judges it, as ``drive-bench run`` does.

    Args:
        strategy: strategy name (see ``strategies()``); required without ``scenario``,
            with it, overrides the scenario's.
        speed_rpm: constant speed command [rpm], 0..16383; required without ``scenario``.
        duration_s: simulated time [s], default 3; steady state is the last third.
        load_nm: a passive (Coulomb) load on the shaft from t = 0 [N·m].
        config: a path to a TOML config file, or a dict of overrides of the built-in
            config (the shape of ``default_config()``, any subset of its keys).
        scenario: a path to a scenario file (TOML), or a dict of its keys (profiles of
            speed, load and supply, ...); it then gives the command, the duration and
            the load, so ``speed_rpm``, ``duration_s`` and ``load_nm`` are not given.
        seed: comparator-noise seed (overrides ``sensing.seed`` and the scenario's).
        trace_every_us: with a period [µs], the whole run is traced at it.
        plugins: paths of plugin libraries (see the project's README, "Plugins"), whose
            strategies ``strategy`` may then name.

    Returns:
        A ``Result``.

    Raises:
        ValueError: a value that breaks its rule (the message names the key, the value
            and the rule), before anything runs.
        RuntimeError: the run failed (the engine refused a command).

    The simulation runs with the GIL released: runs in several Python threads proceed
    in parallel.
    """
    case = {
        "strategy": strategy,
        "speed_rpm": speed_rpm,
        "duration_s": duration_s,
        # 0 is the CLI's default too: left out, a scenario may then give its own load.
        "load_nm": None if load_nm == 0.0 and scenario is not None else load_nm,
        "config": config,
        "scenario": scenario,
        "seed": seed,
        "trace_every_us": trace_every_us,
    }
    record, columns = _native.simulate(case_json(case), plugin_paths(plugins))
    trace = None
    if columns is not None:
        arrays = {name: np.frombuffer(data, dtype=dtype) for name, dtype, data in columns}
        trace = _frame(arrays)
    return Result(json.loads(record), trace)


def case_json(case: Mapping[str, Any]) -> str:
    """The case as the JSON the native library reads; paths as strings, NumPy scalars as
    numbers. A value JSON cannot hold is a ValueError naming its key."""
    return json.dumps(_plain(dict(case), ""), allow_nan=False)


def _plain(v: Any, key: str) -> Any:
    if isinstance(v, Mapping):
        return {str(k): _plain(x, f"{key}.{k}" if key else str(k)) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x, f"{key}[{k}]") for k, x in enumerate(v)]
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        # JSON cannot carry it to the library: worded here by the library's formatter.
        raise ValueError(_native.not_finite(key, v))
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    raise ValueError(_native.refusal(key, repr(v), "a number, a string, a list or a dict"))


def _frame(arrays: Dict[str, np.ndarray]) -> Any:
    try:
        import pandas as pd
    except ImportError:
        return arrays
    return pd.DataFrame(arrays)
