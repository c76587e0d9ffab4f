"""fpkbench from Python: simulate a scenario, identify measured data with a model, or run
the bench's main job — the same library as the ``fpkbench`` command, called in-process.

    import fpkbench
    data = fpkbench.simulate("scenarios/sdof_duffing.toml")      # dict of numpy arrays
    res = fpkbench.identify(data, "my_model.toml")                # or a pandas DataFrame
    res.estimates, res.std_errors, res.intervals, res.report

A scenario or model is a path to its TOML file or a dict with the same structure. Errors
raise ``ValueError`` with the command-line tool's message.
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native

__version__ = _native.__version__
__all__ = ["simulate", "identify", "run", "Result"]

Spec = Union[str, "os.PathLike[str]", Mapping[str, Any]]


def _spec(spec: Spec) -> Tuple[str, str, bool]:
    """(text, label, is_json) of a path or a dict."""
    if isinstance(spec, Mapping):
        return json.dumps(spec), "<dict>", True
    path = os.fspath(spec)
    with open(path, encoding="utf-8") as f:
        return f.read(), path, False


@dataclass
class Result:
    """One identification: the first method's estimates, standard errors and 95 %
    intervals by parameter name, every method's diagnostics, and the whole report (the
    content of ``report.json``)."""

    report: dict
    method: str = ""
    estimates: dict = field(default_factory=dict)
    std_errors: dict = field(default_factory=dict)
    intervals: dict = field(default_factory=dict)
    diagnostics: dict = field(default_factory=dict)

    @classmethod
    def _of(cls, report_json: str) -> "Result":
        report = json.loads(report_json)
        # As the command exits 2: a gated method refused (the data cannot separate its
        # unknowns) or failed raises, naming it and why; the report, with every other
        # method's estimates, is on the exception.
        undecided = [m for m in report["methods"] if m.get("gated") and m.get("outcome") in ("refused", "failed")]
        if undecided:
            e = ValueError("; ".join(f"{m['method']} {m['outcome']}: {m.get('error')}" for m in undecided))
            e.report = report
            raise e
        methods = [m for m in report["methods"] if m.get("parameters")]
        r = cls(report=report)
        if methods:
            first = methods[0]
            r.method = first["method"]
            for p in first["parameters"]:
                se = p["std_error"]
                r.estimates[p["name"]] = p["estimate"]
                r.std_errors[p["name"]] = float("nan") if se is None else se
                r.intervals[p["name"]] = tuple(p["ci95"]) if p["ci95"] else None
        r.diagnostics = {m["method"]: m["diagnostics"] for m in report["methods"]}
        return r


def simulate(scenario: Spec) -> dict:
    """Simulate a scenario in memory: ``{"trajectory", "t", <column>…}`` as numpy arrays
    (one entry per sample; columns ``x_<mass>``, ``v_<mass>``, ``a_<mass>``,
    ``p_<excitation>`` as in the log) and ``"truth"``, the true parameters by name."""
    text, label, is_json = _spec(scenario)
    columns, traj, t, values, truth = _native.simulate_scenario(text, label, is_json)
    table = np.frombuffer(values, dtype="<f8").reshape(len(t), len(columns))
    out = {"trajectory": np.asarray(traj, dtype=np.uint32), "t": np.asarray(t, dtype=np.float64)}
    for k, c in enumerate(columns):
        out[c] = table[:, k].copy()
    out["truth"] = dict(truth)
    return out


def _numeric(name: str, values: Any) -> np.ndarray:
    """A column as float64. Times (numpy or pandas datetime64, with or without a time
    zone, and timedelta64) become seconds since the column's first value: read as numbers
    they would be nanoseconds, a sample interval 1e9 times too long."""
    dtype = getattr(values, "dtype", None)
    if getattr(dtype, "kind", "") == "M" and hasattr(values, "dt") and values.dt.tz is not None:
        values = values.dt.tz_convert("UTC").dt.tz_localize(None)
    raw = np.asarray(values)
    if raw.dtype.kind in "mM":
        if raw.size and np.isnat(raw).any():
            row = int(np.flatnonzero(np.isnat(raw))[0]) + 1
            raise ValueError(f"row {row}, column {name!r}: not a time (NaT)")
        if raw.size == 0:
            return raw.astype(np.float64)
        return (raw - raw[0]) / np.timedelta64(1, "s")
    try:
        return np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"column {name!r}: not numbers ({raw.dtype}): {e}") from None


def identify(
    data: Any,
    model: Spec,
    methods: Optional[Sequence[str]] = None,
    validate: bool = True,
) -> Result:
    """Identify ``data`` — a mapping of column name to array (a dict of numpy arrays, a
    pandas DataFrame) — with a model (path or dict) whose ``[data]`` section maps the
    model's quantities onto those columns (see docs/data.md). Bad data raise
    ``ValueError`` naming the row and column (units that do not fit together: the column
    and the factor); warnings about the data (sampling too coarse to differentiate) are
    issued as ``UserWarning`` and kept in ``report["data_notes"]``."""
    text, label, is_json = _spec(model)
    names, columns = [], []
    for name in (data.columns if hasattr(data, "columns") else data.keys()):
        if name == "truth":
            continue
        col = _numeric(name, data[name])
        if col.ndim != 1:
            raise ValueError(f"column {name!r}: one value per sample expected, got shape {col.shape}")
        names.append(str(name))
        columns.append(np.ascontiguousarray(col, dtype="<f8").tobytes())
    report = _native.identify_table(text, label, is_json, names, columns, list(methods or []), validate)
    result = Result._of(report)
    # What reading the data found that a user must see (coarse sampling, units).
    for note in result.report.get("data_notes", []):
        if note.startswith("WARNING"):
            warnings.warn(note, UserWarning, stacklevel=2)
    return result


def run(scenario: Spec, methods: Optional[Sequence[str]] = None, validate: bool = True) -> Result:
    """Simulate, log (to a temporary file), identify and grade, as ``fpkbench run`` does
    (no report files are written)."""
    text, label, is_json = _spec(scenario)
    return Result._of(_native.run_scenario(text, label, is_json, list(methods or []), validate))
