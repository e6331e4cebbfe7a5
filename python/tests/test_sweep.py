"""sweep() on a 2-worker LocalCluster against the same runs done natively."""

import json
import pathlib
import time

import bldc_drive
import pytest

from conftest import ROOT, WALL_CLOCK, cli, need, without_wall_clock

pd = need("pandas", "pandas")
distributed = need("dask.distributed", "'dask[distributed]'")

CASES = [
    dict(strategy="twelve-step-df", speed_rpm=3000, duration_s=1.2),
    dict(strategy="six-step-120", speed_rpm=1800, duration_s=0.3, load_nm=2e-4),
    dict(strategy="twelve-step-nd", speed_rpm=2500, duration_s=0.25, seed=42),
    dict(strategy="twelve-step-df", speed_rpm=3000, duration_s=0.3, config={"motor": {"resistance_ohm": 2.4}}),
    dict(strategy="twelve-step-raw", speed_rpm=2000, duration_s=0.2),
    dict(scenario={"duration_s": 0.3, "speed_rpm": [[0, 2000], [0.15, 2000], [0.15, 2600]]}, strategy="twelve-step-df"),
]


@pytest.fixture(scope="module")
def cluster():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=":0") as c:
        yield c


def plain(v):
    """Lists for arrays (Parquet gives lists back as arrays), recursively."""
    if hasattr(v, "tolist") and not isinstance(v, (int, float)):
        v = v.tolist()
    return [plain(x) for x in v] if isinstance(v, list) else v


def rows(frame):
    """The frame's rows as dicts of plain values, wall-clock figures and absent values
    (None, NaN) left out."""
    out = []
    for r in frame.to_dict("records"):
        r = {k: plain(v) for k, v in r.items() if k not in WALL_CLOCK}
        out.append({k: v for k, v in r.items() if v is not None and not (isinstance(v, float) and v != v)})
    return out


def test_sweep_on_two_workers_equals_the_native_runs(cluster, drive_bench, tmp_path):
    parquet = tmp_path / "rows.parquet"
    with distributed.Client(cluster) as client:
        frame = bldc_drive.sweep(CASES, client=client, parquet=parquet)
    assert list(frame["case"]) == list(range(len(CASES)))
    # Case k's seed is its own, else k.
    assert list(frame["seed"]) == [0, 1, 42, 3, 4, 5]
    # Each row is the run simulate() gives alone with that seed, in the case's order.
    for k, case in enumerate(CASES):
        alone = bldc_drive.simulate(**{**case, "seed": int(frame["seed"][k])}).summary
        got = frame.iloc[k].to_dict()
        for key, value in without_wall_clock(alone).items():
            if value is None:
                assert got[key] is None or got[key] != got[key], (k, key)
            elif isinstance(value, list):
                assert list(got[key]) == value, (k, key)
            else:
                assert got[key] == value, (k, key, got[key], value)
    assert frame["config.motor.resistance_ohm"][3] == 2.4
    assert set(frame["verdict"]) <= {"running", "off-speed", "lost-sync", "stalled", "not-started", "gave-up", "non-finite", "stopped", "unsettled"}
    # drive-bench sweep, on threads, writes the same rows.
    file = tmp_path / "cases.json"
    file.write_text(json.dumps(CASES))
    out = tmp_path / "native.json"
    cli(drive_bench, "sweep", file, "--json", out, "--threads", 2)
    native = json.loads(out.read_text())
    # Columns in the same order: the first row's, then those later rows add.
    assert list(native[0]) == list(frame.columns)[: len(native[0])]
    assert rows(pd.DataFrame(native)) == rows(frame)
    # The Parquet file holds the same frame.
    assert rows(pd.read_parquet(parquet)) == rows(frame)


def test_a_scheduler_address_is_used_as_it_is(cluster):
    frame = bldc_drive.sweep(CASES[:2], client=cluster.scheduler_address)
    assert list(frame["case"]) == [0, 1] and list(frame["strategy"]) == ["twelve-step-df", "six-step-120"]


def test_workers_load_the_plugins_a_sweep_names(cluster, example_plugin):
    case = dict(strategy="example-twelve-step-df", speed_rpm=2500, duration_s=0.3)
    with distributed.Client(cluster) as client:
        frame = bldc_drive.sweep([case, CASES[1]], client=client, plugins=[example_plugin])
    alone = bldc_drive.simulate(**case, seed=0, plugins=[example_plugin]).summary
    got = frame.iloc[0].to_dict()
    assert all(got[k] == v for k, v in without_wall_clock(alone).items() if not isinstance(v, list)), got
    assert list(frame["strategy"]) == ["example-twelve-step-df", "six-step-120"]


def test_a_bad_case_fails_before_any_runs():
    cases = CASES[:2] + [dict(strategy="six-step-120", speed_rpm=1000, config={"motor": {"inertia_kgm2": -1.0}})]
    t = time.perf_counter()
    with pytest.raises(ValueError) as e:
        bldc_drive.sweep(cases)
    msg = str(e.value)
    assert msg.startswith("case 2: ") and "`motor.inertia_kgm2` = -1" in msg, msg
    # No cluster was started and nothing ran: checking takes far less than one run.
    assert time.perf_counter() - t < 1.0
    with pytest.raises(ValueError, match=r"case 0: `trace_every_us` = 10 \(rule: a sweep keeps no traces"):
        bldc_drive.sweep([dict(CASES[0], trace_every_us=10)])
    with pytest.raises(ValueError, match=r"case 1: unknown key `speeed`"):
        bldc_drive.sweep([CASES[0], dict(CASES[0], speeed=1)])


def test_hundred_short_runs_scale_on_two_workers(capsys):
    """Reports the speed-up of 100 short runs on 2 workers over 1 (not asserted: CI
    machines are shared); asserts that both give the same rows."""
    cases = [dict(strategy="twelve-step-df", speed_rpm=1500 + 10 * k, duration_s=0.5) for k in range(100)]
    wall, frames = {}, {}
    for n in (1, 2):
        with distributed.LocalCluster(n_workers=n, threads_per_worker=1, dashboard_address=":0") as c:
            with distributed.Client(c) as client:
                client.wait_for_workers(n)
                t = time.perf_counter()
                frames[n] = bldc_drive.sweep(cases, client=client)
                wall[n] = time.perf_counter() - t
    assert rows(frames[1]) == rows(frames[2])
    line = (
        f"sweep of 100 runs of 0.5 s: 1 worker {wall[1]:.2f} s, 2 workers {wall[2]:.2f} s, "
        f"speed-up {wall[1] / wall[2]:.2f}x"
    )
    (pathlib.Path(ROOT) / "target").mkdir(exist_ok=True)
    (pathlib.Path(ROOT) / "target" / "python-sweep-speedup.txt").write_text(line + "\n")
    with capsys.disabled():
        print("\n" + line)
