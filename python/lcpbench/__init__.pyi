"""Type stubs of the lcpbench Python package."""

from os import PathLike
from typing import Any, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_Vector = npt.ArrayLike
_Matrix = Any  # a 2-D array-like or any scipy.sparse matrix or array

class LcpbenchError(ValueError):
    """Bad input: the message names the file or argument, the field and the limit."""

class SolveResult:
    solver: str
    f: npt.NDArray[np.float64]
    w: npt.NDArray[np.float64]
    status: str
    reason: Optional[str]
    residual: float
    residual_rel: float
    complementarity_gap: float
    bound_violation: float
    iterations: int
    time_s: float
    relaxation: Optional[str]
    certificate: Optional[dict[str, Any]]
    history: list[Tuple[int, float, float]]
    @property
    def converged(self) -> bool: ...

class Judgement:
    status: str
    reason: Optional[str]
    residual: float
    residual_rel: float
    complementarity_gap: float
    bound_violation: float
    w: npt.NDArray[np.float64]
    unresolved: Optional[int]
    certificate: Optional[dict[str, Any]]
    @property
    def converged(self) -> bool: ...

class Problem:
    @classmethod
    def lcp(
        cls,
        A: _Matrix,
        b: _Vector,
        lo: Optional[_Vector] = ...,
        hi: Optional[_Vector] = ...,
        friction: Optional[Sequence[Tuple[int, int, float]]] = ...,
        name: Optional[str] = ...,
    ) -> Problem: ...
    @classmethod
    def cone(cls, W: _Matrix, q: _Vector, mu: _Vector, name: Optional[str] = ...) -> Problem: ...
    @property
    def kind(self) -> Literal["lcp", "cone"]: ...
    @property
    def n(self) -> int: ...
    @property
    def name(self) -> Optional[str]: ...
    @property
    def b(self) -> npt.NDArray[np.float64]: ...
    @property
    def q(self) -> npt.NDArray[np.float64]: ...
    @property
    def lo(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def hi(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def friction(self) -> Optional[list[Tuple[int, int, float]]]: ...
    @property
    def mu(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def A(self) -> Any: ...
    @property
    def W(self) -> Any: ...

def solve(
    A: Union[_Matrix, Problem],
    b: Optional[_Vector] = ...,
    lo: Optional[_Vector] = ...,
    hi: Optional[_Vector] = ...,
    friction: Optional[Sequence[Tuple[int, int, float]]] = ...,
    solver: str = ...,
    tol: float = ...,
    max_iter: Optional[int] = ...,
    time_budget: Optional[float] = ...,
    warm: Optional[_Vector] = ...,
    history: bool = ...,
) -> SolveResult: ...
def solve_cone(
    W: Union[_Matrix, Problem],
    q: Optional[_Vector] = ...,
    mu: Optional[_Vector] = ...,
    solver: str = ...,
    tol: float = ...,
    max_iter: Optional[int] = ...,
    time_budget: Optional[float] = ...,
    warm: Optional[_Vector] = ...,
    history: bool = ...,
) -> SolveResult: ...
def judge(problem: Problem, f: _Vector, tol: float = ...) -> Judgement: ...
def read(path: _Path) -> Problem: ...
def write(problem: Problem, path: _Path, overwrite: bool = ...) -> None: ...
def solvers() -> list[dict[str, Any]]: ...
def simulate(
    scene_path: _Path,
    solver: Optional[str] = ...,
    steps: Optional[int] = ...,
    tol: Optional[float] = ...,
    max_iter: Optional[int] = ...,
) -> dict[str, Any]: ...
def results(directory: _Path) -> Any: ...
