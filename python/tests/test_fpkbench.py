"""The Python package against the command-line tool and against itself."""

import json
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

import fpkbench

ROOT = pathlib.Path(__file__).resolve().parents[2]
SDOF = ROOT / "scenarios" / "sdof_duffing.toml"
CLI = os.environ.get("FPKBENCH_BIN", str(ROOT / "target" / "release" / "fpkbench"))

# The SDOF Duffing system as a model for its simulated data: the link to identify has no values.
MODEL = {
    "name": "sdof-model",
    "mass": [{"name": "m1", "value": 1.0}],
    "link": [{"ends": ["ground", "m1"]}],
    "excitation": [{"kind": "white", "sigma": 1.0, "acts_on": ["m1"]}],
    "identify": {"methods": ["weak"], "links": {"ground-m1": {"stiffness": [1, 3], "damping": [1]}}},
    "data": {"time": "t", "record": "trajectory", "columns": {"x_m1": "x_m1", "v_m1": "v_m1"}},
}


def test_run_equals_the_command_line_tools_report(tmp_path):
    res = fpkbench.run(SDOF, methods=["weak"], validate=False)
    out = subprocess.run(
        [CLI, "run", str(SDOF), "--method", "weak", "--no-validate", "--json", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
    )
    cli = json.loads(out.stdout)
    assert [p["estimate"] for p in cli["methods"][0]["parameters"]] == list(res.estimates.values())
    assert res.report["passed"] == cli["passed"]
    assert set(res.estimates) == {"k1[ground-m1]", "k3[ground-m1]", "c1[ground-m1]"}
    for name, (lo, hi) in res.intervals.items():
        assert lo < res.estimates[name] < hi


def test_simulate_then_identify_recovers_the_truth():
    data = fpkbench.simulate(SDOF)
    assert data["x_m1"].shape == data["t"].shape == (100_000,)
    res = fpkbench.identify(data, MODEL, validate=False)
    for name, est in res.estimates.items():
        truth = data["truth"][name]
        # 1e4 s of record: the weak form's errors are ≈ 1–3 % (docs/results.md).
        assert abs(est - truth) / truth < 0.1, (name, est, truth)
        assert res.std_errors[name] > 0
    # No truth in a model: nothing graded.
    assert res.report["methods"][0]["threshold"] is None


def test_a_dataframe_and_a_dict_give_the_same_result():
    pd = pytest.importorskip("pandas")
    data = fpkbench.simulate(SDOF)
    data.pop("truth")
    a = fpkbench.identify(data, MODEL, validate=False)
    b = fpkbench.identify(pd.DataFrame(data), MODEL, validate=False)
    assert a.estimates == b.estimates and a.std_errors == b.std_errors


def test_bad_data_raise_with_the_tools_messages():
    data = fpkbench.simulate(SDOF)
    data.pop("truth")
    bad = dict(data)
    bad["x_m1"] = data["x_m1"].copy()
    bad["x_m1"][10] = math.nan
    with pytest.raises(ValueError, match=r"row 11, column \"x_m1\": NaN"):
        fpkbench.identify(bad, MODEL)
    missing = {k: v for k, v in data.items() if k != "v_m1"}
    with pytest.raises(ValueError, match=r"no column \"v_m1\""):
        fpkbench.identify(missing, MODEL)
    with pytest.raises(ValueError, match="cannot be separated"):
        fpkbench.run(_sigma_unknown())
    with pytest.raises(ValueError, match="unknown method"):
        fpkbench.identify(data, MODEL, methods=["fast"])


def _sigma_unknown():
    """sdof_duffing with its intensity unknown: refused before any simulation."""
    import tomllib

    s = tomllib.loads(SDOF.read_text())
    s["identify"]["unknown_intensities"] = ["m1"]
    return s
