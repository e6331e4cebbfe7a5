"""Sweeps on Dask: many cases, one row each, in the order of the cases."""

from __future__ import annotations

import json
import os
from typing import Any, List, Mapping, Optional, Sequence, Union

from . import _native
from ._api import case_json, plugin_paths


def _row(index: int, case: str, plugins: List[str]) -> dict:
    """Runs case ``index`` (JSON) on a worker; its row as a dict in column order."""
    return json.loads(_native.sweep_row(index, case, plugins))


def sweep(
    cases: Sequence[Mapping[str, Any]],
    client: Union[None, str, Any] = None,
    parquet: Union[None, str, "os.PathLike[str]"] = None,
    plugins: Sequence[Union[str, "os.PathLike[str]"]] = (),
):
    """Runs every case on a Dask cluster and gathers the results into one DataFrame.

    Args:
        cases: dicts of ``simulate``'s keyword arguments (without ``trace_every_us``:
            a sweep keeps no traces).
        client: a ``dask.distributed.Client``; a scheduler address (``"tcp://host:8786"``),
            to which a client is connected; or None, to start a ``LocalCluster`` on this
            machine (one single-threaded worker process a core) for this
            call alone.
        parquet: a path to also write the DataFrame to as Parquet (needs pyarrow).
        plugins: paths of plugin libraries whose strategies the cases may name; every
            worker loads them from the same absolute path, so on a remote cluster they
            must be there too.

    Returns:
        A pandas DataFrame, one row per case in the order of ``cases``: ``case`` (the
        index), ``seed``, the case's inputs (dicts flattened into dotted columns such as
        ``config.motor.resistance_ohm``), then the summary's keys as in
        ``simulate(...).summary`` (``strategy``, ``verdict``, ``verdict_reason``, the
        metrics). The same columns as ``drive-bench sweep``.

    Seeds: case ``k`` runs with its own ``seed`` when it gives one, else with seed ``k``,
    so each row is the same whatever the scheduling and ``simulate(**case, seed=row.seed)``
    runs it again alone.

    Every case is checked before any runs: a bad one is a ValueError naming the case's
    index, the key, the value and the rule.
    """
    import pandas as pd

    texts = [case_json(c) for c in cases]
    # Checks all cases (and their seeds) at once, before a cluster is started.
    libs = plugin_paths(plugins)
    _native.sweep_seeds("[" + ",".join(texts) + "]", libs)
    if parquet is not None:
        _check_parquet(parquet)
    rows = _gather(texts, libs, client)
    frame = pd.DataFrame(rows)
    if parquet is not None:
        frame.to_parquet(parquet)
    return frame


def _gather(texts: List[str], libs: List[str], client: Union[None, str, Any]) -> List[dict]:
    from dask.distributed import Client, LocalCluster

    if client is None:
        # The dashboard on a free port: 8787 may be taken by another cluster.
        with LocalCluster(n_workers=os.cpu_count() or 1, threads_per_worker=1, dashboard_address=":0") as cluster:
            with Client(cluster) as c:
                return _map(c, texts, libs)
    if isinstance(client, str):
        with Client(client) as c:
            return _map(c, texts, libs)
    return _map(client, texts, libs)


def _map(client: Any, texts: List[str], libs: List[str]) -> List[dict]:
    # pure=False: a case submitted twice runs twice rather than being taken for the same
    # task; the results come back in the order of the cases.
    futures = client.map(_row, list(range(len(texts))), texts, plugins=libs, pure=False)
    return client.gather(futures)


def _check_parquet(path: Union[str, "os.PathLike[str]"]) -> None:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        raise ValueError(
            f"parquet = {os.fspath(path)!r}: writing Parquet needs pyarrow (rule: pip install pyarrow)"
        ) from None
    folder = os.path.dirname(os.path.abspath(os.fspath(path)))
    if not os.path.isdir(folder):
        raise ValueError(
            f"parquet = {os.fspath(path)!r}: folder {folder} does not exist (rule: create it first)"
        )
