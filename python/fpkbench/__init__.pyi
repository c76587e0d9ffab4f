import os
from typing import Any, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

Spec = Union[str, os.PathLike[str], Mapping[str, Any]]

__version__: str

class Result:
    report: dict
    method: str
    estimates: dict[str, float]
    std_errors: dict[str, float]
    intervals: dict[str, Optional[Tuple[float, float]]]
    diagnostics: dict[str, Optional[dict]]

def simulate(scenario: Spec) -> dict[str, Any]: ...
def identify(data: Any, model: Spec, methods: Optional[Sequence[str]] = ..., validate: bool = ...) -> Result: ...
def run(scenario: Spec, methods: Optional[Sequence[str]] = ..., validate: bool = ...) -> Result: ...
