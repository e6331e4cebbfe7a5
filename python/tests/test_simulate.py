"""simulate() against drive-bench: the same summary, trace and errors for the same run."""

import math
import os
import threading
import tomllib

import bldc_drive
import numpy as np
import pytest

from conftest import WALL_CLOCK, cli, cli_json, need, without_wall_clock

# Short runs that end in different verdicts and exercise every input.
RUNS = [
    dict(strategy="twelve-step-df", speed_rpm=3000.0, duration_s=1.2),
    dict(strategy="six-step-120", speed_rpm=1800.0, duration_s=0.3, load_nm=2e-4, seed=11),
    dict(strategy="twelve-step-nd", speed_rpm=2500, duration_s=0.25, seed=3),
]


def cli_args(run):
    args = ["run"]
    for k, v in run.items():
        args += ["--" + k.replace("_", "-"), v]
    return args


@pytest.mark.parametrize("run", RUNS)
def test_summary_equals_drive_bench_json_bit_for_bit(drive_bench, tmp_path, run):
    want = cli_json(drive_bench, tmp_path, *cli_args(run))
    got = bldc_drive.simulate(**run)
    # Same keys in the same order, and every value identical (floats compared exactly).
    assert list(got.summary) == list(want["summary"])
    assert without_wall_clock(got.summary) == without_wall_clock(want["summary"])
    assert got.scenario == want["scenario"]
    assert got.record["schema_version"] == want["schema_version"]
    assert got.verdict == want["summary"]["verdict"]
    # A float compared with == could hide a NaN on both sides: none is there.
    assert all(not (isinstance(v, float) and math.isnan(v)) for v in got.summary.values())


def test_config_file_and_scenario_file_match_drive_bench(drive_bench, tmp_path):
    cfg = tmp_path / "drive.toml"
    cfg.write_text("[motor]\nresistance_ohm = 2.4\n[control]\nmax_restarts = 2\n")
    scenario = tmp_path / "step.toml"
    scenario.write_text(
        'strategy = "six-step-120"\nduration_s = 0.4\nseed = 5\n'
        "speed_rpm = [[0, 2000], [0.2, 2000], [0.2, 2500]]\n[load]\nfan_nms2 = 2e-10\n"
    )
    want = cli_json(drive_bench, tmp_path, "run", "--scenario", scenario, "--config", cfg, "--strategy", "twelve-step-lm")
    got = bldc_drive.simulate(scenario=scenario, config=str(cfg), strategy="twelve-step-lm")
    assert without_wall_clock(got.summary) == without_wall_clock(want["summary"])
    assert got.scenario == want["scenario"]
    assert got.scenario["config"]["motor"]["resistance_ohm"] == 2.4
    # The record's scenario, given back as a dict, is the same run.
    again = bldc_drive.simulate(scenario=got.scenario)
    assert without_wall_clock(again.summary) == without_wall_clock(got.summary)


def test_trace_equals_drive_bench_trace(drive_bench, tmp_path):
    csv = tmp_path / "trace.csv"
    cli(drive_bench, "run", "--strategy", "twelve-step-df", "--speed-rpm", 3000, "--duration-s", 0.05,
        "--trace", csv, "--trace-every-us", 20)
    lines = csv.read_text().splitlines()
    header, rows = lines[0].split(","), [line.split(",") for line in lines[1:]]
    got = bldc_drive.simulate(strategy="twelve-step-df", speed_rpm=3000, duration_s=0.05, trace_every_us=20).trace
    assert list(got.keys()) == header
    assert len(got["t_s"]) == len(rows) == 2501
    for k, name in enumerate(header):
        want = np.array([float(r[k]) for r in rows])
        np.testing.assert_array_equal(np.asarray(got[name], dtype=float), want, err_msg=name)
    assert got["state"].dtype == np.uint8 and got["restarts"].dtype == np.uint32
    pd = need("pandas", "pandas")
    assert isinstance(got, pd.DataFrame)


def test_default_config_is_drive_bench_config(drive_bench):
    want = tomllib.loads(cli(drive_bench, "config").stdout)
    cfg = bldc_drive.default_config()
    assert cfg == want
    assert cfg["motor"]["resistance_ohm"] > 0
    # Given back whole, it is the built-in drive: the same run.
    a = bldc_drive.simulate(strategy="six-step-120", speed_rpm=2000, duration_s=0.1, config=cfg)
    b = bldc_drive.simulate(strategy="six-step-120", speed_rpm=2000, duration_s=0.1)
    assert without_wall_clock(a.summary) == without_wall_clock(b.summary)


def cli_error(drive_bench, *args):
    p = cli(drive_bench, *args, check=False)
    assert p.returncode == 1, p.stderr
    return p.stderr.strip().removeprefix("drive-bench: error: ")


def test_bad_values_raise_the_cli_s_value_error(drive_bench, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[motor]\nresistance_ohm = -1.0\n")
    # The same message as drive-bench, naming the key, the value and the rule.
    with pytest.raises(ValueError) as e:
        bldc_drive.simulate(strategy="six-step-120", speed_rpm=1000, config=str(bad))
    assert str(e.value) == cli_error(drive_bench, "run", "--strategy", "six-step-120", "--speed-rpm", 1000, "--config", bad)
    assert "`motor.resistance_ohm` = -1" in str(e.value)
    with pytest.raises(ValueError) as e:
        bldc_drive.simulate(strategy="six-step-120", speed_rpm=20000)
    assert str(e.value) == cli_error(drive_bench, "run", "--strategy", "six-step-120", "--speed-rpm", 20000)
    assert "`speed_rpm[0]` = 20000" in str(e.value) and "16383" in str(e.value)
    with pytest.raises(ValueError) as e:
        bldc_drive.simulate(strategy="nine-step", speed_rpm=1000)
    assert str(e.value) == cli_error(drive_bench, "run", "--strategy", "nine-step", "--speed-rpm", 1000)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(config={"motor": {"resistance_ohm": -1.0}}), ["`motor.resistance_ohm` = -1", "must be"]),
        (dict(config={"motr": {"x": 1}}), ["motr"]),
        (dict(duration_s=0.0), ["`duration_s` = 0", "must be > 0"]),
        (dict(speed_rpm=float("nan")), ["`speed_rpm` = NaN (rule: must be finite)"]),
        (dict(load_nm=-1.0), ["load.coulomb_nm", "-1"]),
        (dict(seed=-1), ["`seed` = -1", "whole number"]),
        (dict(trace_every_us=0.001), ["`trace_every_us` = 0.001", "0.02"]),
        (dict(scenario={"duration_s": 1, "speed_rpm": 1000}, speed_rpm=None, duration_s=None, load_nm=1e-3), ["`load_nm` = 0.001", "not with `scenario`"]),
    ],
)
def test_bad_config_raises_a_clear_value_error(kwargs, words):
    base = dict(strategy="six-step-120", speed_rpm=1000, duration_s=0.1)
    with pytest.raises(ValueError) as e:
        bldc_drive.simulate(**{**base, **kwargs})
    for w in words:
        assert w in str(e.value), str(e.value)


def test_the_gil_is_released_while_simulating():
    # A Python thread counting while another simulates: with the GIL held by the run it
    # could not count at all until the run ended.
    done, counted = threading.Event(), [0]

    def run():
        bldc_drive.simulate(strategy="twelve-step-df", speed_rpm=3000, duration_s=1.0)
        done.set()

    t = threading.Thread(target=run)
    t.start()
    while not done.is_set():
        counted[0] += 1
    t.join()
    assert counted[0] > 10_000, counted[0]


def test_numpy_scalars_and_paths_are_accepted():
    a = bldc_drive.simulate(strategy="six-step-120", speed_rpm=np.float64(1500), duration_s=0.1, seed=np.int64(2))
    b = bldc_drive.simulate(strategy="six-step-120", speed_rpm=1500.0, duration_s=0.1, seed=2)
    assert without_wall_clock(a.summary) == without_wall_clock(b.summary)
    assert set(WALL_CLOCK) <= set(a.summary)


def test_a_plugin_strategy_runs_as_drive_bench_runs_it(drive_bench, tmp_path, example_plugin):
    name = "example-twelve-step-df"
    assert bldc_drive.strategies(plugins=[example_plugin])[-1] == name
    assert name not in bldc_drive.strategies()
    run = dict(strategy=name, speed_rpm=2500, duration_s=0.3, seed=3)
    want = cli_json(drive_bench, tmp_path, "--plugin", example_plugin, *cli_args(run))
    got = bldc_drive.simulate(**run, plugins=[str(example_plugin)])
    assert without_wall_clock(got.summary) == without_wall_clock(want["summary"])
    assert got.summary["strategy"] == name


def test_the_c_plugin_starts_the_motor_and_holds_the_command(drive_bench, tmp_path, c_plugin):
    # Written in C against strategy-abi/include/bldc_strategy.h: from standstill (align,
    # ramp, then its own zero crossings) to 3000 rpm, judged running, as drive-bench says.
    assert "c-six-step" in bldc_drive.strategies(plugins=[c_plugin])
    run = dict(strategy="c-six-step", speed_rpm=3000, duration_s=3.0, seed=1)
    got = bldc_drive.simulate(**run, plugins=[str(c_plugin)])
    assert got.verdict == "running", got.summary
    assert abs(got.summary["speed_mean_rpm"] - 3000) < 30, got.summary
    want = cli_json(drive_bench, tmp_path, "--plugin", c_plugin, *cli_args(run))
    assert without_wall_clock(got.summary) == without_wall_clock(want["summary"])


def test_bad_plugins_raise_a_value_error_naming_them(tmp_path):
    fake = tmp_path / "libnot_a_plugin.so"
    fake.write_text("not a library")
    for plugins in ([fake], [tmp_path / "missing.so"]):
        with pytest.raises(ValueError, match=r"plugins: .*" + os.path.basename(plugins[0])):
            bldc_drive.simulate(strategy="six-step-120", speed_rpm=1000, duration_s=0.01, plugins=plugins)
    # One path where a list of them is asked for.
    with pytest.raises(ValueError, match=r"rule: a list of paths"):
        bldc_drive.strategies(plugins=str(fake))
    # A plugin's strategy without the plugin is an unknown strategy.
    with pytest.raises(ValueError, match="example-twelve-step-df"):
        bldc_drive.simulate(strategy="example-twelve-step-df", speed_rpm=1000, duration_s=0.01)
