"""lcpbench: rigid-body contact problems and the solvers of the lcpbench workbench.

A problem is a boxed LCP ``w = A f + b``, ``lo <= f <= hi`` with friction rows bounded by
``±mu f[normal]`` (the standard LCP ``0 <= f ⟂ A f + b >= 0`` when ``lo = 0``, ``hi = inf``), or
an exact Coulomb-cone problem ``u = W r + q`` (FC3D). Every answer, from these solvers or from
elsewhere, is judged by one rule: the shared natural-map residual relative to the data, within
``tol``, and the data-resolution test (:func:`judge`).

>>> import numpy as np, lcpbench
>>> r = lcpbench.solve(np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, 1.0]))
>>> r.status, round(float(r.f[0]), 6)
('converged', 0.5)
"""

from __future__ import annotations

import csv as _csv
import os as _os

import numpy as _np

from . import _lcpbench
from ._lcpbench import Judgement, LcpbenchError, SolveResult

__all__ = [
    "LcpbenchError",
    "Problem",
    "SolveResult",
    "Judgement",
    "solve",
    "solve_cone",
    "judge",
    "read",
    "write",
    "solvers",
    "simulate",
    "results",
]


def _matrix_arg(A, name):
    """A dense float64 array, or the parts of a CSR/CSC matrix as stored (other scipy formats -> CSR)."""
    fmt = getattr(A, "format", None)
    if fmt is not None and hasattr(A, "tocsr"):  # a scipy.sparse matrix or array
        if fmt not in ("csr", "csc"):
            A = A.tocsr()
            fmt = "csr"
        # Unsorted or repeated indices are put in order (and summed) on the Rust side, in one
        # pass, without changing the caller's matrix.
        return (
            fmt,
            (int(A.shape[0]), int(A.shape[1])),
            _np.asarray(A.data, dtype=_np.float64),
            A.indices,
            A.indptr,
        )
    return _np.asarray(A, dtype=_np.float64)


def _vec(x):
    return None if x is None else _np.asarray(x, dtype=_np.float64)


class Problem:
    """A contact problem: ``kind`` is ``"lcp"`` or ``"cone"``.

    Build one with :meth:`Problem.lcp` or :meth:`Problem.cone`, or read it with :func:`read`.
    ``A`` is a numpy array for dense problems and a ``scipy.sparse.csr_matrix`` for sparse ones.
    """

    __slots__ = ("_p",)

    def __init__(self, inner):
        self._p = inner

    @classmethod
    def lcp(cls, A, b, lo=None, hi=None, friction=None, name=None):
        """A boxed LCP; ``lo``/``hi`` default to 0 and +inf, ``friction`` is a sequence of
        ``(row, normal_row, mu)``."""
        return cls(
            _lcpbench.lcp_problem(
                _matrix_arg(A, "A"), _vec(b), _vec(lo), _vec(hi), friction, name
            )
        )

    @classmethod
    def cone(cls, W, q, mu, name=None):
        """A Coulomb-cone problem: rows in (normal, tangent, tangent) triples, one ``mu`` per
        contact."""
        return cls(_lcpbench.cone_problem(_matrix_arg(W, "W"), _vec(q), _vec(mu), name))

    kind = property(lambda self: self._p.kind, doc='"lcp" or "cone"')
    n = property(lambda self: self._p.n, doc="number of rows")
    name = property(lambda self: self._p.name, doc="the problem's name, if any")
    b = property(lambda self: self._p.b, doc="b (LCP) or q (cone)")
    q = b
    lo = property(lambda self: self._p.lo, doc="lower bounds (LCP)")
    hi = property(lambda self: self._p.hi, doc="upper bounds (LCP)")
    friction = property(lambda self: self._p.friction, doc="(row, normal_row, mu) rows (LCP)")
    mu = property(lambda self: self._p.mu, doc="friction coefficient per contact (cone)")

    @property
    def A(self):
        """``A`` (or ``W``): a numpy array when stored dense, else a scipy CSR matrix."""
        parts = self._p.matrix_parts()
        if parts[0] == "dense":
            return parts[1]
        try:
            import scipy.sparse as sp
        except ImportError as e:  # pragma: no cover - scipy is optional
            raise ImportError("this problem is sparse: install scipy to get A") from e
        _, shape, data, indices, indptr = parts
        return sp.csr_matrix((data, indices, indptr), shape=shape)

    W = A

    def __repr__(self):
        return repr(self._p)


def _inner(problem):
    if isinstance(problem, Problem):
        return problem._p
    raise TypeError(f"expected an lcpbench.Problem, got {type(problem).__name__}")


def solve(A, b=None, lo=None, hi=None, friction=None, solver="lemke", tol=1e-8,
          max_iter=None, time_budget=None, warm=None, history=False):
    """Solve the boxed LCP ``w = A f + b``, ``lo <= f <= hi`` (friction rows ``(row,
    normal_row, mu)`` bounded by ``±mu f[normal_row]``) with ``solver``.

    ``A`` is a numpy array or any scipy.sparse matrix (CSR and CSC are read without
    conversion), or an :class:`Problem` (then leave ``b``, ``lo``, ``hi``, ``friction`` out).
    Returns a :class:`SolveResult`; its ``status`` is ``"converged"`` only when the shared
    residual of ``f`` is within ``tol``. The GIL is released during the solve.
    """
    if isinstance(A, Problem):
        if b is not None or lo is not None or hi is not None or friction is not None:
            raise LcpbenchError("solve(problem, ...): b, lo, hi and friction come from the problem")
        p = A._p
    else:
        if b is None:
            raise LcpbenchError("solve(A, b, ...): b is missing")
        p = _lcpbench.lcp_problem(_matrix_arg(A, "A"), _vec(b), _vec(lo), _vec(hi), friction)
    return _lcpbench.solve(p, solver, tol, max_iter, time_budget, _vec(warm), history)


def solve_cone(W, q=None, mu=None, solver="nsgs-cone", tol=1e-8, max_iter=None,
               time_budget=None, warm=None, history=False):
    """Solve the Coulomb-cone problem ``u = W r + q`` (contacts in (normal, tangent, tangent)
    row triples, ``mu`` per contact) with a cone solver. ``W`` may be a :class:`Problem` of
    kind ``"cone"`` (or an LCP whose rows are such triples)."""
    if isinstance(W, Problem):
        p = W._p
    else:
        if q is None or mu is None:
            raise LcpbenchError("solve_cone(W, q, mu, ...): q and mu are required")
        p = _lcpbench.cone_problem(_matrix_arg(W, "W"), _vec(q), _vec(mu))
    return _lcpbench.solve(p, solver, tol, max_iter, time_budget, _vec(warm), history)


def judge(problem, f, tol=1e-8):
    """Judge the answer ``f`` to ``problem`` by lcpbench's own rule (the shared residual, the
    data-resolution test, the status), whatever computed it. Returns a :class:`Judgement`."""
    return _lcpbench.judge(_inner(problem), _vec(f), tol)


def read(path):
    """Read a JSON, Siconos ``.dat`` or FCLIB HDF5 problem file. Raises ``OSError`` when the
    file cannot be read and :class:`LcpbenchError` naming the field when its data are bad."""
    return Problem(_lcpbench.read(_os.fspath(path)))


def write(problem, path, overwrite=False):
    """Write ``problem`` as JSON, or FCLIB HDF5 for ``.hdf5``/``.h5``; an existing file is
    kept unless ``overwrite``."""
    _lcpbench.write(_inner(problem), _os.fspath(path), overwrite)


def solvers():
    """The solver catalogue of ``lcpbench solvers``: a list of dicts with ``name``, ``level``
    (matrix, body, cone), ``summary``, ``warm``, ``iterations_count``, ``problem_classes``,
    ``parameters``."""
    return _lcpbench.solvers()


def simulate(scene_path, solver=None, steps=None, tol=None, max_iter=None):
    """Step the scene file at ``scene_path`` as ``lcpbench simulate`` does (its own stepping
    mode; ``solver`` replaces the scene's, ``NAME+warm`` warm-starts from the previous step).

    Returns a dict of per-step values: ``status``, ``solver`` (lists), ``residual_rel`` (NaN
    where not measured), ``iterations``, ``contacts``, ``rows``, ``solve_time_s``,
    ``step_time_s``, ``time`` (numpy arrays), ``positions`` (steps × bodies × 3),
    ``orientations`` (steps × bodies × 4, quaternion ``w, x, y, z``) and ``bodies`` (names).
    """
    return _lcpbench.simulate(_os.fspath(scene_path), solver, steps, tol, max_iter)


def _number(text):
    if text == "":
        return None
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text


def results(directory):
    """The rows of a sweep's ``results.csv`` in ``directory``: a pandas DataFrame when pandas
    is installed, else a list of dicts (numbers converted, empty cells ``None``)."""
    path = _os.path.join(_os.fspath(directory), "results.csv")
    try:
        import pandas as pd
    except ImportError:
        pd = None
    if pd is not None:
        return pd.read_csv(path)
    with open(path, newline="", encoding="utf-8") as fh:
        return [{k: _number(v) for k, v in row.items()} for row in _csv.DictReader(fh)]
