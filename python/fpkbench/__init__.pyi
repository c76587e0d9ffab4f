import os
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

Spec = Union[str, os.PathLike[str], Mapping[str, Any]]
Progress = Union[None, bool, Callable[[str, int, int], Any]]

__version__: str

class Error(ValueError):
    column: Optional[str]
    row: Optional[int]
    key: Optional[str]
    report: Optional[dict]

class ScenarioError(Error): ...
class DataError(Error): ...
class IdentifiabilityError(Error): ...
class SimulationError(Error): ...

class Result:
    report: dict
    method: str
    estimates: dict[str, float]
    std_errors: dict[str, float]
    intervals: dict[str, Optional[Tuple[float, float]]]
    diagnostics: dict[str, Optional[dict]]
    def rows(self) -> list[dict[str, Any]]: ...
    def to_pandas(self) -> Any: ...
    def _repr_html_(self) -> str: ...

def simulate(scenario: Spec, progress: Progress = ...) -> dict[str, Any]: ...
def identify(
    data: Any,
    model: Spec,
    methods: Optional[Sequence[str]] = ...,
    validate: bool = ...,
    progress: Progress = ...,
) -> Result: ...
def run(
    scenario: Spec,
    methods: Optional[Sequence[str]] = ...,
    validate: bool = ...,
    progress: Progress = ...,
) -> Result: ...
