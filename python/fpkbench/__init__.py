"""fpkbench from Python: simulate a scenario, identify measured data with a model, or run
the bench's main job — the same library as the ``fpkbench`` command, called in-process.

    import fpkbench
    data = fpkbench.simulate("scenarios/sdof_duffing.toml")        # dict of numpy arrays
    res = fpkbench.identify(data, "scenarios/models/sdof_duffing.toml")  # or a DataFrame
    res.estimates, res.std_errors, res.intervals, res.report
    res.to_pandas()                                                 # one row per parameter

A scenario or model is a path to its TOML file or a dict with the same structure. Errors
raise a subclass of ``fpkbench.Error`` (a ``ValueError``) with the command-line tool's
message: ``ScenarioError`` (its ``key``), ``DataError`` (its ``column`` and ``row``),
``IdentifiabilityError``, ``SimulationError``. Ctrl-C interrupts a call within a fraction
of a second; long calls show a progress bar when tqdm is installed.
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native

__version__ = _native.__version__
__all__ = [
    "simulate",
    "identify",
    "run",
    "Result",
    "Error",
    "ScenarioError",
    "DataError",
    "IdentifiabilityError",
    "SimulationError",
]


class Error(ValueError):
    """An fpkbench error; the message is the command's. ``column``, ``row`` and ``key``
    name what it is about where known (else ``None``); ``report`` is the whole report
    where one was made (a method refused or failed)."""

    column: Optional[str] = None
    row: Optional[int] = None
    key: Optional[str] = None
    report: Optional[dict] = None


class ScenarioError(Error):
    """A scenario or model that is not valid: ``key`` is the key path (``data.scale.phi``),
    for a file also with its line in the message."""


class DataError(Error):
    """Measured data that cannot be used as they are: ``column`` and, where it is one
    value, ``row`` (1-based) name the place."""


class IdentifiabilityError(Error):
    """The data cannot separate the unknowns: the message names them, the direction they
    move together along and the singular values."""


class SimulationError(Error):
    """The simulation diverged: the message says when, where and the likely cause."""

Spec = Union[str, "os.PathLike[str]", Mapping[str, Any]]


def _spec(spec: Spec) -> Tuple[str, str, bool]:
    """(text, label, is_json) of a path or a dict."""
    if isinstance(spec, Mapping):
        return json.dumps(spec), "<dict>", True
    path = os.fspath(spec)
    with open(path, encoding="utf-8") as f:
        return f.read(), path, False


@dataclass(repr=False)
class Result:
    """One identification: the first method's estimates, standard errors and 95 %
    intervals by parameter name, every method's diagnostics, and the whole report (the
    content of ``report.json``). ``to_pandas()`` gives every method's parameters as a
    table; in a notebook the result shows as that table."""

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
            kind = IdentifiabilityError if all(m["outcome"] == "refused" for m in undecided) else Error
            e = kind("; ".join(f"{m['method']} {m['outcome']}: {m.get('error')}" for m in undecided))
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

    truth: dict = field(default_factory=dict)
    """True values by parameter name where the caller knows them (``identify`` takes them
    from the data's ``"truth"`` entry, as ``simulate`` gives it)."""

    COLUMNS = (
        "method",
        "parameter",
        "estimate",
        "std_error",
        "cramer_rao_std",
        "ci95_low",
        "ci95_high",
        "true_value",
        "error",
        "z",
        "rel_error",
    )

    def rows(self) -> list:
        """Every method's parameters, one dict per (method, parameter): ``method``,
        ``parameter``, ``estimate``, ``std_error``, ``cramer_rao_std`` (the Cramér–Rao bound
        of continuous observation on its standard deviation, where it applies),
        ``ci95_low``, ``ci95_high``; where the
        truth is known (the report's, or ``truth``) ``true_value``, ``error`` (estimate −
        truth) and ``z`` (error over the standard error); ``rel_error`` the bench's graded
        error where it grades (the report's, docs/methods.md). NaN where not known."""
        nan = float("nan")

        def num(x):
            return nan if x is None else float(x)

        out = []
        for m in self.report["methods"]:
            for p in m.get("parameters") or []:
                lo, hi = p["ci95"] if p.get("ci95") else (nan, nan)
                true = num(p.get("true_value"))
                if true != true:
                    true = num(self.truth.get(p["name"]))
                se = num(p.get("std_error"))
                error = p["estimate"] - true
                out.append(
                    {
                        "method": m["method"],
                        "parameter": p["name"],
                        "estimate": p["estimate"],
                        "std_error": se,
                        "cramer_rao_std": num(p.get("cramer_rao_std")),
                        "ci95_low": lo,
                        "ci95_high": hi,
                        "true_value": true,
                        "error": error,
                        "z": error / se if se > 0 else nan,
                        "rel_error": num(p.get("rel_error")),
                    }
                )
        return out

    def to_pandas(self):
        """``rows()`` as a pandas DataFrame indexed by (method, parameter)."""
        import pandas as pd

        return pd.DataFrame(self.rows(), columns=list(self.COLUMNS)).set_index(["method", "parameter"])

    def _summary(self) -> str:
        r = self.report
        methods = ", ".join(f"{m['method']} {m.get('outcome', '')}".strip() for m in r["methods"])
        return f"{len(self.estimates)} parameters by {self.method or 'no method'}; methods: {methods}"

    def __repr__(self) -> str:
        return f"<fpkbench.Result {self._summary()}>"

    def _repr_html_(self) -> str:
        from html import escape

        head = "".join(
            f"<th>{escape(c)}</th>"
            for c in ("method", "parameter", "estimate", "std. error", "95 % interval", "true", "z")
        )
        def num(x):
            return "" if x != x else f"{x:.6g}"

        body = []
        for row in self.rows():
            interval = "" if row["ci95_low"] != row["ci95_low"] else f"[{row['ci95_low']:.6g}, {row['ci95_high']:.6g}]"
            z = "" if row["z"] != row["z"] else f"{row['z']:+.2f}"
            cells = [
                escape(row["method"]),
                escape(row["parameter"]),
                num(row["estimate"]),
                num(row["std_error"]),
                interval,
                num(row["true_value"]),
                z,
            ]
            body.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
        return (
            f"<p><b>fpkbench.Result</b>: {escape(self._summary())}</p>"
            f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"
        )


Progress = Union[None, bool, Callable[[str, int, int], Any]]


class _Bar:
    """The ``progress`` argument as the native call's callback: a user's callable as it
    is, ``None`` a tqdm bar when tqdm is installed (shown only for calls longer than a
    second), ``False`` nothing."""

    def __init__(self, progress: Progress):
        self.user = progress if callable(progress) else None
        self.bar = None
        self.stage = None
        self.tqdm = None
        if progress is None:
            try:
                from tqdm.auto import tqdm

                self.tqdm = tqdm
            except ImportError:
                pass

    def callback(self):
        if self.user is not None:
            return self.user
        return self._tqdm if self.tqdm is not None else None

    def _tqdm(self, stage: str, done: int, total: int) -> None:
        if stage != self.stage:
            self.close()
            self.stage = stage
            self.bar = self.tqdm(total=total, desc=stage, unit="samples", unit_scale=True, delay=1.0, leave=False)
        # `update`, not `refresh`: a refresh would show a bar before its delay.
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _data_error(message: str, column: str, row: Optional[int] = None) -> DataError:
    e = DataError(message)
    e.column, e.row = column, row
    return e


def simulate(scenario: Spec, progress: Progress = None) -> dict:
    """Simulate a scenario in memory: ``{"trajectory", "t", <column>…}`` as numpy arrays
    (one entry per sample; columns ``x_<mass>``, ``v_<mass>``, ``a_<mass>``,
    ``p_<excitation>`` as in the log) and ``"truth"``, the true parameters by name.
    ``progress``: ``None`` a tqdm bar if tqdm is installed, ``False`` none, or a callable
    ``progress(stage, done, total)`` called from this thread as the work goes on."""
    text, label, is_json = _spec(scenario)
    with _Bar(progress) as bar:
        columns, traj, t, values, truth = _native.simulate_scenario(text, label, is_json, bar.callback())
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
            raise _data_error(f"row {row}, column {name!r}: not a time (NaT)", name, row)
        if raw.size == 0:
            return raw.astype(np.float64)
        return (raw - raw[0]) / np.timedelta64(1, "s")
    try:
        return np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise _data_error(f"column {name!r}: not numbers ({raw.dtype}): {e}", name) from None


def identify(
    data: Any,
    model: Spec,
    methods: Optional[Sequence[str]] = None,
    validate: bool = True,
    progress: Progress = None,
) -> Result:
    """Identify ``data`` — a mapping of column name to array (a dict of numpy arrays, a
    pandas DataFrame) — with a model (path or dict) whose ``[data]`` section maps the
    model's quantities onto those columns (see docs/data.md). Bad data raise
    ``DataError`` naming the row and column (units that do not fit together: the column
    and the factor); warnings about the data (sampling too coarse to differentiate) are
    issued as ``UserWarning`` and kept in ``report["data_notes"]``. ``progress`` as for
    ``simulate``."""
    text, label, is_json = _spec(model)
    names, columns = [], []
    for name in (data.columns if hasattr(data, "columns") else data.keys()):
        if name == "truth":
            continue
        col = _numeric(name, data[name])
        if col.ndim != 1:
            raise _data_error(f"column {name!r}: one value per sample expected, got shape {col.shape}", name)
        names.append(str(name))
        columns.append(np.ascontiguousarray(col, dtype="<f8").tobytes())
    with _Bar(progress) as bar:
        report = _native.identify_table(
            text, label, is_json, names, columns, list(methods or []), validate, bar.callback()
        )
    result = Result._of(report)
    truth = data.get("truth") if isinstance(data, Mapping) else None
    if isinstance(truth, Mapping):
        result.truth = dict(truth)
    # What reading the data found that a user must see (coarse sampling, units).
    for note in result.report.get("data_notes", []):
        if note.startswith("WARNING"):
            warnings.warn(note, UserWarning, stacklevel=2)
    return result


def run(
    scenario: Spec,
    methods: Optional[Sequence[str]] = None,
    validate: bool = True,
    progress: Progress = None,
) -> Result:
    """Simulate, log (to a temporary file), identify and grade, as ``fpkbench run`` does
    (no report files are written). ``progress`` as for ``simulate``."""
    text, label, is_json = _spec(scenario)
    with _Bar(progress) as bar:
        report = _native.run_scenario(text, label, is_json, list(methods or []), validate, bar.callback())
    return Result._of(report)
