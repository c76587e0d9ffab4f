"""The Python package against the command-line tool and against itself."""

import json
import math
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import fpkbench

ROOT = pathlib.Path(__file__).resolve().parents[2]
SDOF = ROOT / "scenarios" / "sdof_duffing.toml"
CLI = os.environ.get("FPKBENCH_BIN", str(ROOT / "target" / "release" / "fpkbench"))


def _cli():
    """The command the package is compared with: skipped, saying how to build it, when it
    is not built; a wrong ``FPKBENCH_BIN`` fails."""
    if not os.path.exists(CLI):
        if "FPKBENCH_BIN" in os.environ:
            pytest.fail(f"FPKBENCH_BIN={CLI} does not exist")
        pytest.skip("the fpkbench command is not built: run `cargo build --release` (or set FPKBENCH_BIN)")
    return CLI

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
        [_cli(), "run", str(SDOF), "--method", "weak", "--no-validate", "--json", "--out", str(tmp_path)],
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


def test_noise_added_in_numpy_is_estimated_and_taken_out():
    """Sensor noise made outside fpkbench: 30 % of each column's std added in numpy to a
    DataFrame. The noise comes back within 4 of its standard errors (docs/measurement.md),
    the weak form's intervals still hold the truth, and with the correction off the cubic
    stiffness misses by far more than its standard error (-32 % on this seed)."""
    pd = pytest.importorskip("pandas")
    data = fpkbench.simulate(SDOF)
    truth = data.pop("truth")
    rng = np.random.default_rng(11)
    noisy = pd.DataFrame(data)
    for c in ("x_m1", "v_m1"):
        noisy[c] = noisy[c] + 0.3 * noisy[c].std() * rng.standard_normal(len(noisy))
    res = fpkbench.identify(noisy, MODEL, validate=False)
    sn = res.report["sensor_noise"]
    assert sn["handling"] == "estimate" and sn["corrected"], sn
    assert [c["column"] for c in sn["channels"]] == ["x_m1", "v_m1"]
    for c in sn["channels"]:
        assert c["detected"], c
        assert abs(c["std"] / c["signal_std"] - 0.3) < 4 * c["std_se"] / c["signal_std"] + 1e-3, c
    for name, est in res.estimates.items():
        assert abs(est - truth[name]) < 4 * res.std_errors[name], (name, est, truth[name])
    model = json.loads(json.dumps(MODEL))
    model["identify"]["sensor_noise"] = "ignore"
    ignored = fpkbench.identify(noisy, model, validate=False)
    assert not ignored.report["sensor_noise"]["corrected"]
    k3 = "k3[ground-m1]"
    assert abs(ignored.estimates[k3] - truth[k3]) > 6 * ignored.std_errors[k3], ignored.estimates


def test_the_terms_of_a_dataframe_are_selected_from_candidates():
    """Structure selection from Python (docs/selection.md): a model whose `[identify.select]`
    offers powers 1..5 on the stiffness and damping; the data, a DataFrame, need k1, k3 and
    c1 (19 of 20 seeds at this record; the scenario's seed is one of them), and the
    estimates are of those terms only."""
    pd = pytest.importorskip("pandas")
    data = fpkbench.simulate(SDOF)
    truth = data.pop("truth")
    model = json.loads(json.dumps(MODEL))
    model["identify"]["select"] = {"stiffness": [1, 2, 3, 4, 5], "damping": [1, 2, 3, 4, 5]}
    res = fpkbench.identify(pd.DataFrame(data), model, validate=False)
    sel = res.report["selection"]
    assert len(sel["candidates"]) == 10
    chosen = [n for n, k in zip(sel["candidates"], sel["selected"]) if k]
    assert chosen == ["k1[ground-m1]", "k3[ground-m1]", "c1[ground-m1]"], sel["path"]
    assert sorted(res.estimates) == sorted(chosen)
    for name, est in res.estimates.items():
        assert abs(est - truth[name]) < 4 * res.std_errors[name], (name, est, truth[name])


def test_a_dataframes_friction_is_identified_with_its_own_term(tmp_path):
    """Terms beyond powers from Python (docs/scenario.md, "Terms"): a friction-damped rig's
    record as a pandas DataFrame with its own column names, a model whose damping lists the
    linear term and Coulomb friction (`"sign"`, as a string beside the power 1). Every
    estimate is within 4 standard errors of the truth, and the powers-only comparison's
    damping curve is off by more than a fifth of it where the samples are (34 % on this
    record)."""
    pd = pytest.importorskip("pandas")
    scenario = tmp_path / "friction.toml"
    src = (ROOT / "scenarios" / "friction_sdof.toml").read_text()
    scenario.write_text(src.replace("record_length = 3125.0", "record_length = 1250.0"))
    data = fpkbench.simulate(scenario)
    truth = data.pop("truth")
    rig = pd.DataFrame({"run": data["trajectory"], "time": data["t"], "pos": data["x_m1"], "vel": data["v_m1"]})
    model = json.loads(json.dumps(MODEL))
    model["identify"]["links"]["ground-m1"]["damping"] = [1, "sign"]
    model["identify"]["compare"] = {"powers": {"links": {"ground-m1": {"stiffness": [1, 3], "damping": [1, 3]}}}}
    model["data"] = {"time": "time", "record": "run", "columns": {"x_m1": "pos", "v_m1": "vel"}}
    res = fpkbench.identify(rig, model, validate=False)
    assert sorted(res.estimates) == sorted(["k1[ground-m1]", "k3[ground-m1]", "c1[ground-m1]", "csign[ground-m1]"])
    for name, est in res.estimates.items():
        assert abs(est - truth[name]) < 4 * res.std_errors[name], (name, est, truth[name])
    powers = next(m for m in res.report["methods"] if m["method"] == "weak [powers]")
    assert powers["outcome"] == "estimated", powers
    # Measured data have no truth to grade curves against: the powers' damping, evaluated
    # here, against the true friction damper over the observed speeds.
    est = {p["name"]: p["estimate"] for p in powers["parameters"]}
    w = np.asarray(data["v_m1"])[::50]
    fitted = est["c1[ground-m1]"] * w + est["c3[ground-m1]"] * w**3
    true = truth["c1[ground-m1]"] * w + truth["csign[ground-m1]"] * np.sign(w)
    assert np.sqrt(np.mean((fitted - true) ** 2) / np.mean(true**2)) > 0.2


def test_displacement_noise_added_in_numpy_is_found_and_differenced_against(tmp_path):
    """A rig with a displacement sensor only, made outside fpkbench: the SDOF oscillator
    sampled every 0.01 s, a DataFrame of the run, the time and the displacement with white
    noise of 5 % of its std added in numpy. The model file derives the velocity
    (docs/data.md, "Velocities from a noisy displacement"): the noise is found within 10 %,
    the stencil widens, and the estimates are within 4 standard errors of the truth; with
    the noise ignored, the velocity's noise reads as stiffness: k1 more than 2 % and 3
    standard errors high (+3.3 %, 4.7 standard errors on this seed; +3.4 % on docs/data.md's
    record, four times longer)."""
    pd = pytest.importorskip("pandas")
    fine = tmp_path / "sdof_fine.toml"
    fine.write_text(SDOF.read_text().replace("sample_interval = 0.1\n", "sample_interval = 0.01\n"))
    data = fpkbench.simulate(fine)
    truth = data.pop("truth")
    rng = np.random.default_rng(7)
    pos = data["x_m1"] + 0.05 * data["x_m1"].std() * rng.standard_normal(len(data["x_m1"]))
    rig = pd.DataFrame({"run": data["trajectory"], "time": data["t"], "pos": pos})
    model = json.loads(json.dumps(MODEL))
    model["data"] = {"time": "time", "record": "run", "derive": True, "columns": {"x_m1": "pos"}}
    res = fpkbench.identify(rig, model, validate=False)
    sn = res.report["sensor_noise"]
    assert sn["corrected"], sn
    x = sn["channels"][0]
    assert x["column"] == "x_m1" and x["detected"], x
    assert abs(x["std"] / (0.05 * data["x_m1"].std()) - 1) < 0.1, x
    assert any("least-squares cubic" in n for n in res.report["data_notes"]), res.report["data_notes"]
    for name, est in res.estimates.items():
        assert abs(est - truth[name]) < 4 * res.std_errors[name], (name, est, truth[name])
    model["identify"]["sensor_noise"] = "ignore"
    ignored = fpkbench.identify(rig, model, validate=False)
    k1 = "k1[ground-m1]"
    bias = ignored.estimates[k1] - truth[k1]
    assert bias > 3 * ignored.std_errors[k1] and bias > 0.02 * truth[k1], ignored.estimates


def test_accelerometer_noise_added_in_numpy_is_integrated_and_taken_out(tmp_path):
    """An accelerometer rig made outside fpkbench: the SDOF oscillator sampled every 0.01 s,
    a DataFrame of the run, the time and the acceleration only, with white noise of 5 % of
    the acceleration's std added in numpy. The model file derives the velocity and the
    displacement by integration (docs/data.md, "Accelerations only"). With the noise stated,
    or estimated from the integrated displacement's spectrum below the mode (within 10 %;
    docs/measurement.md, "An accelerometer's noise"), the estimates are within 4 standard
    errors of the truth plus the drift removal's loss (about 1 % of the displacement's
    variance, which k1 reads as stiffness); with it ignored, the cubic stiffness misses by
    more than 6 standard errors."""
    pd = pytest.importorskip("pandas")
    fine = tmp_path / "sdof_fine.toml"
    fine.write_text(SDOF.read_text().replace("sample_interval = 0.1\n", "sample_interval = 0.01\n"))
    data = fpkbench.simulate(fine)
    assert len(data["t"]) == 1_000_000
    truth = data.pop("truth")
    rng = np.random.default_rng(5)
    acc = data["a_m1"] + 0.05 * data["a_m1"].std() * rng.standard_normal(len(data["a_m1"]))
    rig = pd.DataFrame({"run": data["trajectory"], "time": data["t"], "acc": acc})
    model = json.loads(json.dumps(MODEL))
    model["data"] = {"time": "time", "record": "run", "derive": True, "columns": {"a_m1": "acc"}}
    model["measurement"] = {"noise": "relative", "acceleration": 0.05}
    model["identify"]["sensor_noise"] = "given"
    res = fpkbench.identify(rig, model, validate=False)
    assert res.report["sensor_noise"]["corrected"], res.report["sensor_noise"]
    assert any("integrated from a_m1" in n for n in res.report["data_notes"]), res.report["data_notes"]
    for name, est in res.estimates.items():
        allowed = 4 * res.std_errors[name] + 0.015 * abs(truth[name])
        assert abs(est - truth[name]) < allowed, (name, est, truth[name], res.std_errors[name])
    del model["measurement"]
    model["identify"]["sensor_noise"] = "estimate"
    found = fpkbench.identify(rig, model, validate=False)
    a = next(c for c in found.report["sensor_noise"]["channels"] if c["column"] == "a_m1")
    assert a["detected"] and abs(a["std"] / (0.05 * data["a_m1"].std()) - 1) < 0.1, a
    for name, est in found.estimates.items():
        allowed = 4 * found.std_errors[name] + 0.015 * abs(truth[name])
        assert abs(est - truth[name]) < allowed, (name, est, truth[name], found.std_errors[name])
    model["identify"]["sensor_noise"] = "ignore"
    ignored = fpkbench.identify(rig, model, validate=False)
    k3 = "k3[ground-m1]"
    assert truth[k3] - ignored.estimates[k3] > 6 * ignored.std_errors[k3], ignored.estimates


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


def _sdof_data():
    """The SDOF log as a rig would write it: one record after another (32 of 3125 rows)."""
    data = fpkbench.simulate(SDOF)
    data.pop("truth")
    order = np.argsort(data["trajectory"], kind="stable")
    return {k: v[order] for k, v in data.items()}


def _with(data, name, values):
    out = dict(data)
    out[name] = values
    return out


@pytest.mark.parametrize(
    "case, message",
    [
        ("inf", r"row 6, column \"v_m1\": inf"),
        ("time backwards", r"record 0, row 4, t = .* s: the time does not increase"),
        ("irregular time", r"row 8, t = .* s: time step .* evenly spaced"),
        ("gap between records", r"record 0, row 3126, t = 412.6 s: a gap of 100.1 s where the sampling is every 0.1 s; set `split_gaps = true`"),
        ("constant column", r"column \"x_m1\" is constant"),
        ("misspelt column", r"no column \"v_m1\" .* did you mean \"V_m1\""),
        ("too few samples", r"250 samples for 3 unknowns: at least 100 per unknown"),
    ],
)
def test_each_bad_data_case_raises_naming_the_place(case, message):
    data = _sdof_data()
    if case == "inf":
        v = data["v_m1"].copy()
        v[5] = math.inf
        data = _with(data, "v_m1", v)
    elif case == "time backwards":
        t = data["t"].copy()
        t[3] = t[1]
        data = _with(data, "t", t)
    elif case == "irregular time":
        t = data["t"].copy()
        t[7:] += 0.01
        data = _with(data, "t", t)
    elif case == "gap between records":
        # Two records glued into one without telling the record column: the time jumps.
        data = {k: v[:6250].copy() for k, v in data.items()}
        data["trajectory"][:] = 0
        data["t"][3125:] += 412.5
    elif case == "constant column":
        data = _with(data, "x_m1", np.full_like(data["x_m1"], 0.25))
    elif case == "misspelt column":
        data["V_m1"] = data.pop("v_m1")
    elif case == "too few samples":
        data = {k: v[:250] for k, v in data.items()}
    with pytest.raises(ValueError, match=message):
        fpkbench.identify(data, MODEL, validate=False)


def test_units_that_do_not_fit_together_are_refused():
    """A velocity in degrees per second beside a displacement in radians: refused, naming
    the column and the factor, never estimates with the wrong units."""
    data = _sdof_data()
    data["v_m1"] = data["v_m1"] * 57.29578  # degrees per second against radians
    with pytest.raises(ValueError, match=r"the units do not fit together: v_m1 .*57.3: degrees against radians"):
        fpkbench.identify(data, MODEL, validate=False)


def test_validation_compares_the_response_spectra():
    data = _sdof_data()
    res = fpkbench.identify(data, MODEL)
    rows = {r["variable"]: r for r in res.report["validation"]["rows"]}
    sp = rows["x_m1"]["spectrum"]
    # The right model: the spectra differ by what the averaging alone gives.
    assert sp["rms_log_difference"] < 1.3 * sp["averaging_alone"], sp


def _sigma_unknown():
    """sdof_duffing with its intensity unknown: refused before any simulation."""
    import tomllib

    s = tomllib.loads(SDOF.read_text())
    s["identify"]["unknown_intensities"] = ["m1"]
    return s


def test_a_refused_method_raises_and_carries_the_other_methods_estimates():
    """duffing2dof with the intensity on m2 unknown: the weak form cannot separate it from
    the damping (as the command, which exits 2), the product of marginals gives numbers."""
    import tomllib

    s = tomllib.loads((ROOT / "scenarios" / "duffing2dof.toml").read_text())
    s["identify"]["unknown_intensities"] = ["m2"]
    s["identify"]["methods"] = ["weak", "strong-marginals"]
    s["simulation"]["record_length"] = 200.0
    with pytest.raises(ValueError, match="weak refused: the unknowns cannot be separated") as e:
        fpkbench.run(s, validate=False)
    rows = {m["method"]: m for m in e.value.report["methods"]}
    assert rows["weak"]["outcome"] == "refused" and not rows["weak"]["parameters"]
    assert rows["strong-marginals"]["outcome"] == "estimated" and rows["strong-marginals"]["parameters"]


def test_a_datetime_time_column_is_seconds_since_the_first_sample():
    """pandas datetime64 times (as a logger's export has them) give the estimates of the
    same times in seconds: never nanoseconds read as seconds."""
    import pandas as pd

    data = _sdof_data()
    seconds = fpkbench.identify(data, MODEL, validate=False)
    frame = pd.DataFrame(data)
    frame["t"] = pd.Timestamp("2026-01-01 12:00:00", tz="Europe/Warsaw") + pd.to_timedelta(frame["t"], unit="s")
    stamped = fpkbench.identify(frame, MODEL, validate=False)
    for name, value in seconds.estimates.items():
        assert stamped.estimates[name] == pytest.approx(value, rel=1e-9), name
    frame["x_m1"] = frame["x_m1"].astype(str).where(frame.index != 5, "n/a")
    with pytest.raises(ValueError, match="column 'x_m1': not numbers"):
        fpkbench.identify(frame, MODEL)


def _model_toml(extra):
    """The shipped model for these samples (models/sdof_duffing.toml), with ``extra``
    lines added to its [data] section."""
    text = (ROOT / "models" / "sdof_duffing.toml").read_text()
    return text.replace('record = "trajectory"', 'record = "trajectory"\n' + extra, 1)


def _cli_estimates(tmp_path, name, extra, csv):
    model = tmp_path / f"{name}.toml"
    model.write_text(_model_toml(extra))
    out = subprocess.run(
        [_cli(), "identify", "--model", str(model), "--data", str(csv), "--no-validate", "--json",
         "--out", str(tmp_path / name)],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stderr
    report = json.loads(out.stdout)
    return {p["name"]: p["estimate"] for p in report["methods"][0]["parameters"]}, out


def test_a_spreadsheet_csv_gives_the_estimates_of_a_plain_one(tmp_path):
    """A table as a European spreadsheet or logger exports it with pandas — `;` between
    fields, decimal commas, a byte-order mark, text run ids and zoned date-times — reads
    as the plain CSV of the same samples."""
    import pandas as pd

    frame = pd.DataFrame(_sdof_data())
    plain = tmp_path / "plain.csv"
    frame.to_csv(plain, index=False, float_format="%.17g")
    expected, _ = _cli_estimates(tmp_path, "plain", "", plain)

    euro = frame.copy()
    euro["trajectory"] = [f"run-{int(j):02d}" for j in euro["trajectory"]]
    # Each run on its own clock, as a logger stamps them: wall-clock times in Warsaw.
    start = pd.Timestamp("2026-03-01 08:00:00", tz="Europe/Warsaw")
    euro["t"] = start + pd.to_timedelta(frame["t"] + 1000.0 * frame["trajectory"], unit="s")
    sheet = tmp_path / "sheet.csv"
    euro.to_csv(sheet, index=False, sep=";", decimal=",", encoding="utf-8-sig", float_format="%.17g")
    assert sheet.read_bytes().startswith(b"\xef\xbb\xbf")
    got, _ = _cli_estimates(tmp_path, "sheet", 'decimal = ","', sheet)
    assert got.keys() == expected.keys()
    for name, value in expected.items():
        assert got[name] == pytest.approx(value, rel=1e-6), name

    # Without the decimal key the comma is named, with what to set.
    model = tmp_path / "nodecimal.toml"
    model.write_text(_model_toml(""))
    out = subprocess.run(
        [_cli(), "identify", "--model", str(model), "--data", str(sheet), "--no-validate", "--out", str(tmp_path / "x")],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2 and 'decimal = ","' in out.stderr and "line 2" in out.stderr, out.stderr


def test_errors_are_classed_and_point_at_what_they_are_about():
    """Each kind of mistake raises its own class, a ValueError, with the column, row or key
    it is about; a dict's mistake is named by its key path, not by a line of TOML the user
    never wrote."""
    data = _sdof_data()
    bad = _with(data, "x_m1", data["x_m1"].copy())
    bad["x_m1"][10] = math.nan
    with pytest.raises(fpkbench.DataError) as e:
        fpkbench.identify(bad, MODEL)
    assert isinstance(e.value, ValueError) and (e.value.column, e.value.row) == ("x_m1", 11)
    frame_error = {**data, "x_m1": np.array(["n/a"] * len(data["t"]))}
    with pytest.raises(fpkbench.DataError) as e:
        fpkbench.identify(frame_error, MODEL)
    assert e.value.column == "x_m1"

    typo = json.loads(json.dumps(MODEL))
    typo["data"]["scale"] = {"X_m1": 2.0}
    with pytest.raises(fpkbench.ScenarioError) as e:
        fpkbench.identify(data, typo)
    assert e.value.key == "data.scale.X_m1" and str(e.value).startswith("<dict>, key `data.scale.X_m1`: ")
    assert not any(f"<dict>:{n}:" in str(e.value) for n in range(1, 40)), str(e.value)
    nested = json.loads(json.dumps(MODEL))
    nested["identify"]["links"]["ground-m1"]["stiffness"] = [1, "three"]
    with pytest.raises(fpkbench.ScenarioError) as e:
        fpkbench.identify(data, nested)
    assert e.value.key and e.value.key.startswith("identify.links"), (e.value.key, str(e.value))

    with pytest.raises(fpkbench.IdentifiabilityError, match="cannot be separated"):
        fpkbench.run(_sigma_unknown())
    with pytest.raises(fpkbench.ScenarioError, match="unknown method"):
        fpkbench.identify(data, MODEL, methods=["fast"])


def test_a_record_split_at_its_gaps_gives_the_records_estimates():
    """A logger's table with one clock and dropouts: with ``split_gaps`` each piece between
    gaps is a record, and the estimates equal those of the pieces given as records; the
    report names the pieces."""
    import pandas as pd

    frame = pd.DataFrame(_sdof_data()).iloc[: 3125 * 4].copy()
    records = fpkbench.identify(frame, MODEL, validate=False)
    # One record on one clock, 12.3 s lost between the runs.
    glued = frame.copy()
    glued["t"] = glued["t"] + (312.5 + 12.3) * glued["trajectory"]
    glued["trajectory"] = 7
    with pytest.raises(fpkbench.DataError, match=r"record 7, row 3126, t = 324.9\d* s: a gap of 12.4 s") as e:
        fpkbench.identify(glued, MODEL, validate=False)
    assert e.value.column == "t" and e.value.row == 3126
    split = json.loads(json.dumps(MODEL))
    split["data"]["split_gaps"] = True
    pieces = fpkbench.identify(glued, split, validate=False)
    assert pieces.estimates == records.estimates
    assert pieces.std_errors == records.std_errors
    note = [n for n in pieces.report["data_notes"] if "split at" in n]
    assert note and note[0].startswith("record 7 split at 3 time gap(s) into 4 records: piece 1 from t = 0.1 s"), note
    assert pieces.report["records"]["count"] == 4, pieces.report["records"]


def test_ctrl_c_interrupts_a_call_within_a_second(tmp_path):
    """SIGINT in the middle of a long simulation and of a long identification: each call
    raises KeyboardInterrupt within a second, and the next call runs normally."""
    script = tmp_path / "interrupt.py"
    script.write_text(
        """
import os, signal, sys, threading, time
import fpkbench
# Ctrl-C's handler as in a terminal: a shell starts background jobs with SIGINT ignored,
# and Python then installs none.
signal.signal(signal.SIGINT, signal.default_int_handler)
spec = {"mass": [{"name": "m1", "value": 1.0}],
        "link": [{"ends": ["ground", "m1"], "stiffness": {"1": 10.0, "3": 20.0}, "damping": {"1": 0.5}}],
        "excitation": [{"kind": "white", "sigma": 1.0, "acts_on": ["m1"]}],
        "simulation": {"dt": 1e-3, "record_length": 100000.0, "sample_interval": 0.1, "trajectories": 64, "seed": 1}}
sent = []
def fire(after):
    time.sleep(after)
    sent.append(time.monotonic())
    os.kill(os.getpid(), signal.SIGINT)
for call in ("simulate", "run"):
    sent.clear()
    threading.Thread(target=fire, args=(1.5,), daemon=True).start()
    try:
        getattr(fpkbench, call)(spec, progress=False)
        print(call, "not interrupted")
    except KeyboardInterrupt:
        print(call, "interrupted after", time.monotonic() - sent[0])
small = dict(spec, simulation=dict(spec["simulation"], record_length=100.0, trajectories=8))
print("then", len(fpkbench.simulate(small, progress=False)["t"]))
"""
    )
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    for call, line in zip(("simulate", "run"), lines):
        assert line.startswith(f"{call} interrupted after "), out.stdout
        assert float(line.split()[-1]) < 1.0, out.stdout
    assert lines[2] == "then 8000", out.stdout


def test_progress_goes_to_a_callback():
    """A run long enough to be looked at several times: the simulation's samples, then the
    identification's passes, each within its total, the last call the finished state."""
    import tomllib

    s = tomllib.loads(SDOF.read_text())
    s["simulation"].update(record_length=20000.0, trajectories=64)
    seen = []
    fpkbench.run(s, methods=["weak"], validate=False, progress=lambda *a: seen.append(a))
    stages = [stage for stage, _, _ in seen]
    assert stages[0] == "simulate" and stages[-1] == "identify, pass 2", stages
    assert all(0 <= done <= total for _, done, total in seen), seen
    assert seen[-1][1] == seen[-1][2] == 64 * 200_000, seen[-1]


def test_a_long_call_shows_a_tqdm_bar_by_default(capsys):
    pytest.importorskip("tqdm")
    import tomllib

    s = tomllib.loads(SDOF.read_text())
    s["simulation"].update(record_length=40000.0, trajectories=64)
    fpkbench.run(s, methods=["weak"], validate=False)
    assert "identify, pass 2" in capsys.readouterr().err


def test_a_result_is_short_in_a_terminal_and_a_table_in_pandas_and_notebooks():
    pd = pytest.importorskip("pandas")
    data = fpkbench.simulate(SDOF)
    res = fpkbench.identify(data, MODEL, validate=False)
    assert len(repr(res)) < 200 and repr(res).startswith("<fpkbench.Result 3 parameters by weak"), repr(res)
    table = res.to_pandas()
    assert isinstance(table, pd.DataFrame) and list(table.index.names) == ["method", "parameter"]
    row = table.loc[("weak", "k3[ground-m1]")]
    assert row["true_value"] == 20.0 and row["error"] == pytest.approx(row["estimate"] - 20.0)
    assert row["z"] == pytest.approx(row["error"] / row["std_error"])
    assert row["ci95_low"] < row["estimate"] < row["ci95_high"]
    # The Cramér–Rao bound beside the standard error (white force, known mass and intensity).
    assert 0 < row["cramer_rao_std"] < 3 * row["std_error"]
    html = res._repr_html_()
    assert html.count("<tr>") == 4 and "k3[ground-m1]" in html


def test_the_readmes_python_example_runs_as_written():
    readme = (ROOT / "README.md").read_text()
    block = readme.split("```python\n", 1)[1].split("```", 1)[0]
    cwd = os.getcwd()
    os.chdir(ROOT)
    try:
        exec(compile(block, "README.md", "exec"), {})
    finally:
        os.chdir(cwd)


@pytest.mark.parametrize(
    "case, column, message",
    [
        ("lost decimal point", "v_m1", r"row 813, column \"v_m1\": -28000000000000000 lies .* a lost decimal point"),
        ("swapped", "v_m1", r"x_m1 \(column \"v_m1\"\) and v_m1 \(column \"x_m1\"\) look swapped"),
        ("sign", "v_m1", r"v_m1 \(column \"v_m1\"\) is the negative of the rate of change of x_m1"),
    ],
)
def test_bad_columns_are_named_not_reported_as_inseparable_unknowns(case, column, message):
    """Once "the unknowns cannot be separated": a lost decimal point, the displacement
    and velocity columns swapped in the mapping, a velocity sensor mounted the other way.
    Each is now named by its column (and row), with what to check."""
    data = _sdof_data()
    model = json.loads(json.dumps(MODEL))
    if case == "lost decimal point":
        v = data["v_m1"].copy()
        v[812] = -2.8e16
        data = _with(data, "v_m1", v)
    elif case == "swapped":
        model["data"]["columns"] = {"x_m1": "v_m1", "v_m1": "x_m1"}
    else:
        data = _with(data, "v_m1", -data["v_m1"])
    with pytest.raises(fpkbench.DataError, match=message) as e:
        fpkbench.identify(data, model, validate=False)
    assert e.value.column == column


def _numpy_rig(hysteresis, seed, trajectories=64, record=400.0, burn_in=50.0, dt=2e-3, every=50):
    """A rig simulated in numpy, outside fpkbench: m = 1, k = 4, c = 0.2, white force of
    intensity 1, and, with ``hysteresis``, a Bouc–Wen element (k_z 6, A 1, β 1.5, γ 0.5,
    n 1); without, a spring of 6 in its place (the element's slope at the origin), so the
    two rigs differ only by the loop. Semi-implicit Euler, sampled every ``every`` steps."""
    rng = np.random.default_rng(seed)
    x = np.zeros(trajectories)
    v = np.zeros(trajectories)
    z = np.zeros(trajectories)
    burn = int(round(burn_in / dt))
    steps = int(round(record / dt))
    rows = []
    for n in range(burn + steps):
        hyst = 6.0 * z if hysteresis else 6.0 * x
        v = v + dt * (-4.0 * x - 0.2 * v - hyst) + np.sqrt(dt) * rng.standard_normal(trajectories)
        x = x + dt * v
        z = z + dt * (v - 1.5 * np.abs(v) * z - 0.5 * v * np.abs(z))
        if n >= burn and (n - burn + 1) % every == 0:
            rows.append((x - 0.5 * dt * v, v.copy()))
    xs = np.stack([r[0] for r in rows], axis=1)
    vs = np.stack([r[1] for r in rows], axis=1)
    k = xs.shape[1]
    t = (np.arange(k) + 1) * dt * every
    return xs.ravel(), vs.ravel(), np.repeat(np.arange(trajectories), k), np.tile(t, trajectories)


def test_a_hysteretic_rig_made_in_numpy_is_flagged_by_the_validation():
    """The one-argument assumption on data made outside fpkbench (docs/results.md, "The
    one-argument assumption"): a Bouc–Wen mount simulated in numpy, its record as a
    DataFrame, identified with cubic spring and damper. The validation's verdict says the
    model does not reproduce the data and names the displacement's spectrum; the same rig
    with a plain spring in place of the loop is reproduced. On this seed the displacement
    spectrum's RMS log ratio is 9.2 times what the averaging alone gives (threshold 1.6),
    the plain rig's 1.06; the cubic fit (k1 8.01, k3 -1.19, c1 0.584) agrees with what
    fpkbench's own simulation of this rig gives (medians 8.00, -1.10, 0.573 over 10 seeds):
    the two simulators agree on the loop."""
    pd = pytest.importorskip("pandas")
    model = json.loads(json.dumps(MODEL))
    model["identify"]["links"]["ground-m1"] = {"stiffness": [1, 3], "damping": [1, 3]}
    model["data"] = {"time": "time", "record": "run", "columns": {"x_m1": "pos", "v_m1": "vel"}}
    verdicts = {}
    for hysteresis in (True, False):
        x, v, run, t = _numpy_rig(hysteresis, seed=5)
        rig = pd.DataFrame({"run": run, "time": t, "pos": x, "vel": v})
        res = fpkbench.identify(rig, model, validate=True)
        verdicts[hysteresis] = res.report["validation"]
    bw = verdicts[True]
    assert bw["reproduces"] is False, bw
    assert any(m["statistic"] == "spectrum" and m["variable"] == "x_m1" for m in bw["misfits"]), bw["misfits"]
    assert verdicts[False]["reproduces"] is True, verdicts[False]
