"""Tests of the lcpbench Python package against analytic answers and an independent numpy
natural-map residual."""

import os
import pathlib
import threading

import numpy as np
import pytest

import lcpbench

sp = pytest.importorskip("scipy.sparse")

ROOT = pathlib.Path(__file__).resolve().parents[2]
SICONOS = ROOT / "tests" / "data" / "siconos" / "lcp_CPS_1.dat"
SPIN = ROOT / "tests" / "data" / "spin" / "tower_10_60hz_pyramid_step30.json"
FCLIB = ROOT / "bench_scenes" / "fclib" / "Box_Stacks-i0122-82-5.hdf5"


def natural_map(A, b, f, lo, hi):
    """max_i |f_i - mid(lo_i, f_i - w_i, hi_i)| with w = A f + b: zero exactly at a solution of
    the boxed LCP (computed here without lcpbench)."""
    w = A @ f + b
    return np.max(np.abs(f - np.clip(f - w, lo, hi)))


def spd_problem(n, seed):
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, n))
    M = X.T @ X + 0.5 * np.eye(n)
    M[np.abs(M) < 0.8] = 0.0  # sparse, still symmetric; the diagonal keeps it positive
    M += n * np.eye(n)
    return M, rng.standard_normal(n)


def test_two_by_two_analytic_answer():
    A = np.array([[2.0, 1.0], [1.0, 2.0]])
    b = np.array([-1.0, 1.0])
    for solver in ("lemke", "pgs", "dantzig", "newton-fb"):
        r = lcpbench.solve(A, b, solver=solver)
        assert r.status == "converged" and r.converged, (solver, r.reason)
        np.testing.assert_allclose(r.f, [0.5, 0.0], atol=1e-8)
        np.testing.assert_allclose(r.w, A @ r.f + b, atol=1e-12)
        assert r.reason is None and r.certificate is None
        assert isinstance(r.iterations, int) and r.time_s >= 0.0


@pytest.mark.parametrize("fmt", ["csr", "csc", "coo", "dok", "lil"])
def test_scipy_formats_match_dense(fmt):
    M, b = spd_problem(12, seed=7)
    dense = lcpbench.solve(M, b, solver="lemke")
    assert dense.converged
    A = sp.csr_matrix(M).asformat(fmt)
    r = lcpbench.solve(A, b, solver="lemke")
    assert r.converged
    np.testing.assert_allclose(r.f, dense.f, atol=1e-10)
    assert natural_map(M, b, r.f, 0.0, np.inf) < 1e-9


def test_csr_with_unsorted_and_duplicate_entries():
    # (0,0) given twice (summed: 2), columns of row 1 out of order.
    A = sp.csr_matrix(
        (np.array([1.0, 1.0, 2.0, 1.0, 1.0]), np.array([0, 0, 1, 1, 0]), np.array([0, 3, 5])),
        shape=(2, 2),
    )
    assert not A.has_canonical_format
    r = lcpbench.solve(A, [-1.0, 1.0])
    np.testing.assert_allclose(r.f, [0.5, 0.0], atol=1e-10)


def test_boxed_with_friction_rows():
    # One contact: normal row 0, friction row 1 bounded by ±mu f0; A = I.
    A = np.eye(2)
    b = np.array([-1.0, 0.8])
    r = lcpbench.solve(A, b, lo=[0.0, -np.inf], hi=[np.inf, np.inf], friction=[(1, 0, 0.5)],
                       solver="lemke")
    assert r.converged, r.reason
    # Sliding: f0 = 1, f1 = -mu f0 = -0.5 (clamped), w1 = 0.3 > 0 at the lower bound.
    np.testing.assert_allclose(r.f, [1.0, -0.5], atol=1e-9)


def test_solve_cone_single_contact_sticks():
    # W = I: u = r + q. q_T within the cone of -q_N, so the contact sticks: r = -q.
    r = lcpbench.solve_cone(np.eye(3), np.array([-1.0, 0.1, 0.0]), np.array([0.5]))
    assert r.converged, r.reason
    np.testing.assert_allclose(r.f, [1.0, -0.1, 0.0], atol=1e-8)
    assert r.solver == "nsgs-cone"


def test_judge_exact_and_perturbed():
    M, b = spd_problem(10, seed=3)
    p = lcpbench.Problem.lcp(sp.csr_matrix(M), b)
    exact = lcpbench.solve(p, solver="lemke")
    assert exact.converged
    j = lcpbench.judge(p, exact.f)
    assert j.status == "converged" and j.unresolved is None
    np.testing.assert_allclose(j.w, M @ exact.f + b, atol=1e-12)
    bad = exact.f + 1e-3
    k = lcpbench.judge(p, bad)
    assert k.status == "stalled" and not k.converged
    assert k.residual_rel > 1e-8
    # The shared residual's absolute part is the natural map, computed independently here.
    assert k.residual == pytest.approx(natural_map(M, b, bad, 0.0, np.inf), rel=1e-12)
    # A looser tolerance accepts what the tight one refused.
    assert lcpbench.judge(p, bad, tol=0.5).status == "converged"
    nan = lcpbench.judge(p, np.full(10, np.nan))
    assert nan.status == "numerical_failure" and "f[0]" in nan.reason


def test_judge_agrees_with_solver_status():
    # Strongly coupled rows: one PGS sweep gives f = (1, 0.1), far from f = (1, 1) / 1.9.
    M, b = np.array([[1.0, 0.9], [0.9, 1.0]]), np.array([-1.0, -1.0])
    r = lcpbench.solve(M, b, solver="pgs", max_iter=1)
    j = lcpbench.judge(lcpbench.Problem.lcp(M, b), r.f, tol=1e-8)
    assert r.status == "iteration_limit"
    assert not j.converged
    assert j.residual_rel == pytest.approx(r.residual_rel, rel=1e-12)
    exact = lcpbench.judge(lcpbench.Problem.lcp(M, b), np.full(2, 1.0 / 1.9))
    assert exact.converged


def test_read_siconos_and_solve_against_numpy_residual():
    p = lcpbench.read(SICONOS)
    assert p.kind == "lcp"
    A = p.A.toarray() if sp.issparse(p.A) else p.A
    r = lcpbench.solve(p, solver="lemke")
    assert r.converged, r.reason
    assert natural_map(A, p.b, r.f, p.lo, p.hi) < 1e-8 * max(1.0, np.abs(p.b).max())


def test_read_sparse_json_file():
    p = lcpbench.read(SPIN)
    assert p.kind == "lcp" and p.n == 240
    A = p.A
    assert sp.issparse(A) and A.shape == (240, 240)
    r = lcpbench.solve(p, solver="nsgs", max_iter=5000)
    np.testing.assert_allclose(r.w, A @ r.f + p.b, rtol=1e-10, atol=1e-12)
    j = lcpbench.judge(p, r.f)
    assert j.status == r.status or r.status in ("iteration_limit", "time_limit")


def test_read_fclib_and_cone_solve():
    p = lcpbench.read(FCLIB)
    assert p.n % 3 == 0
    r = lcpbench.solve(p, solver="nsgs-cone", tol=1e-6, max_iter=2000)
    assert r.status in ("converged", "iteration_limit", "stalled")
    assert np.all(np.isfinite(r.f))


def test_write_round_trip_and_no_overwrite(tmp_path):
    M, b = spd_problem(5, seed=1)
    p = lcpbench.Problem.lcp(M, b, name="five")
    path = tmp_path / "five.json"
    lcpbench.write(p, path)
    q = lcpbench.read(path)
    assert q.name == "five"
    np.testing.assert_array_equal(q.A, M)
    np.testing.assert_array_equal(q.b, b)
    with pytest.raises(FileExistsError):
        lcpbench.write(p, path)
    lcpbench.write(p, path, overwrite=True)
    c = lcpbench.Problem.cone(np.eye(3), [-1.0, 0.1, 0.0], [0.5])
    cone_path = tmp_path / "cone.json"
    lcpbench.write(c, cone_path)
    assert lcpbench.read(cone_path).kind == "cone"


def test_solvers_is_the_catalogue():
    cat = lcpbench.solvers()
    names = [s["name"] for s in cat]
    assert len(names) == len(set(names))
    assert {"lemke", "pgs", "nsgs-cone", "clarabel-socp"} <= set(names)
    assert {s["level"] for s in cat} == {"matrix", "body", "cone"}
    lemke = cat[names.index("lemke")]
    assert lemke["warm"] is False and lemke["problem_classes"]
    # every matrix and cone solver of the catalogue solves the 3-row contact problem by name
    for s in cat:
        if s["level"] == "body":
            continue
        r = lcpbench.solve_cone(np.eye(3), [-1.0, 0.1, 0.0], [0.5], solver=s["name"])
        assert r.solver == s["name"]


@pytest.mark.parametrize(
    "call, field",
    [
        (lambda: lcpbench.solve(np.ones((2, 3)), [1.0, 2.0]), "square"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, np.nan]), "b[1]"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, 1.0], lo=[1.0, 0.0], hi=[0.0, 1.0]), "bounds"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, 1.0], solver="nope"), "unknown solver"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, 1.0, 1.0]), "b has length 3"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, 1.0], tol=2.0), "tol"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, 1.0], warm=[1.0]), "warm"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, 1.0], friction=[(5, 0, 0.5)]), "friction"),
        (lambda: lcpbench.solve(np.eye(2), [1.0, 1.0], solver="si"), "simulate"),
        (lambda: lcpbench.solve_cone(np.eye(2), [1.0, 1.0], [0.5]), "W"),
    ],
)
def test_bad_input_raises_with_field(call, field):
    with pytest.raises(lcpbench.LcpbenchError) as e:
        call()
    assert field in str(e.value)
    assert isinstance(e.value, ValueError)


def test_bad_sparse_parts_are_refused():
    A = sp.csr_matrix(np.eye(3))
    A.indices[1] = 7  # a column outside the matrix
    with pytest.raises(lcpbench.LcpbenchError, match="indices"):
        lcpbench.solve(A, [1.0, 1.0, 1.0])


def _parts(fmt, n, data, indices, indptr):
    """The tuple the package hands its extension for a scipy matrix, built by hand so that the
    parts can be malformed (scipy itself refuses some of them)."""
    return (fmt, (n, n), np.asarray(data, dtype=np.float64), np.asarray(indices),
            np.asarray(indptr))


@pytest.mark.parametrize(
    "parts, field",
    [
        # NaN stored at A[1][0], data entry 1.
        (_parts("csr", 2, [1.0, np.nan, 1.0], [0, 0, 1], [0, 1, 3]), "A[1][0] (A.data[1])"),
        # Two finite entries of A[0][0] whose sum overflows.
        (_parts("csr", 2, [1e308, 1e308, 1.0], [0, 0, 1], [0, 2, 3]), "A[0][0]"),
        (_parts("csr", 2, [1.0, 1.0], [0, -1], [0, 1, 2]), "A.indices[1] = -1 (row 1) is negative"),
        (_parts("csr", 2, [1.0, 1.0], [0, 2], [0, 1, 2]), "A.indices[1] = 2 (row 1)"),
        (_parts("csc", 2, [1.0, 1.0], [0, 9], [0, 1, 2]), "A.indices[1] = 9 (column 1)"),
        (_parts("csr", 2, [1.0, 1.0], [0, 1], [0, 2, 1]), "A.indptr decreases at row 1"),
        (_parts("csr", 2, [1.0, 1.0], [0, 1], [1, 1, 2]), "A.indptr[0] is 1"),
        (_parts("csr", 2, [1.0, 1.0], [0, 1], [0, 1, 3]), "A.indptr[2] = 3 exceeds the 2"),
        (_parts("csr", 2, [1.0, 1.0], [0, 1], [0, 2]), "A.indptr has 2 entries for 2 rows"),
        (_parts("csr", 2, [1.0], [0, 1], [0, 1, 2]), "A.indices has 2 entries but A.data has 1"),
        (_parts("csr", 2, [1.0, 1.0], [0.0, 1.0], [0, 1, 2]), "A.indices must be an array of int"),
    ],
)
def test_malformed_sparse_parts_name_the_part(parts, field):
    with pytest.raises(lcpbench.LcpbenchError) as e:
        lcpbench._lcpbench.lcp_problem(parts, np.array([-1.0, -1.0]), None, None, None, None)
    assert field in str(e.value)


@pytest.mark.parametrize("fmt", ["csr", "csc"])
@pytest.mark.parametrize("widths", [(np.int32, np.int32), (np.int64, np.int64),
                                    (np.int32, np.int64), (np.int64, np.int32)])
def test_unsorted_repeated_parts_in_every_index_width(fmt, widths):
    # Random triplets with repeats, stored in random order: the problem equals the dense sum.
    rng = np.random.default_rng(11)
    n = 9
    rows, cols = rng.integers(0, n, 60), rng.integers(0, n, 60)
    vals = rng.integers(-8, 8, 60) / 4.0  # exact sums in any order
    M = np.zeros((n, n))
    np.add.at(M, (rows, cols), vals)
    M += 40.0 * np.eye(n)
    rows = np.concatenate([rows, np.arange(n)])
    cols = np.concatenate([cols, np.arange(n)])
    vals = np.concatenate([vals, np.full(n, 40.0)])
    major, minor = (rows, cols) if fmt == "csr" else (cols, rows)
    order = np.argsort(major, kind="stable")  # grouped by major line, unsorted inside
    indptr = np.searchsorted(major[order], np.arange(n + 1))
    parts = (fmt, (n, n), vals[order], minor[order].astype(widths[1]), indptr.astype(widths[0]))
    b = rng.standard_normal(n)
    p = lcpbench.Problem(lcpbench._lcpbench.lcp_problem(parts, b, None, None, None, None))
    np.testing.assert_array_equal(p.A.toarray(), M)
    r = lcpbench.solve(p, solver="pgs")
    assert r.converged, r.reason
    assert natural_map(M, b, r.f, 0.0, np.inf) < 1e-8 * np.abs(b).max()


def test_strided_sparse_parts_are_read():
    # Non-contiguous numpy views (not what scipy hands over, but accepted): read through a copy.
    data = np.array([2.0, -1.0, 1.0, -1.0, 2.0, -1.0])[::2]  # 2, 1, 2
    indices = np.array([0, 7, 1, 7, 2, 7], dtype=np.int32)[::2]
    p = lcpbench.Problem(lcpbench._lcpbench.lcp_problem(
        ("csr", (3, 3), data, indices, np.arange(4)), np.array([-2.0, -1.0, 2.0]),
        None, None, None, None))
    np.testing.assert_array_equal(p.A.toarray(), np.diag([2.0, 1.0, 2.0]))
    r = lcpbench.solve(p, solver="pgs")
    np.testing.assert_allclose(r.f, [1.0, 1.0, 0.0], atol=1e-12)


def test_sparse_cone_parts_are_checked():
    W = sp.csc_matrix(np.eye(3))
    r = lcpbench.solve_cone(W, np.array([-1.0, 0.1, 0.0]), np.array([0.5]))
    assert r.converged, r.reason
    W.data[2] = np.inf
    with pytest.raises(lcpbench.LcpbenchError, match=r"cone problem \(W, q, mu\): A\[2\]\[2\]"):
        lcpbench.solve_cone(W, np.array([-1.0, 0.1, 0.0]), np.array([0.5]))


def test_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        lcpbench.read(tmp_path / "missing.json")
    with pytest.raises(OSError):
        lcpbench.read(tmp_path)  # a directory
    bad = tmp_path / "bad.json"
    bad.write_text('{"A": [[1, 2], [3]], "b": [1, 2]}')
    with pytest.raises(lcpbench.LcpbenchError, match="bad.json"):
        lcpbench.read(bad)
    # A declared size far beyond memory: refused before allocation, never a crash.
    huge = tmp_path / "huge.json"
    huge.write_text('{"A": {"n": 1000000000000, "triplets": [[0, 0, 1.0]]}, "b": [1.0]}')
    with pytest.raises(lcpbench.LcpbenchError, match="huge.json"):
        lcpbench.read(huge)
    fh = open(bad)
    fh.close()
    with pytest.raises(TypeError):
        lcpbench.read(fh)


def test_solves_run_in_threads():
    # The GIL is released during a solve: threads solving at once all finish with the answer.
    M, b = spd_problem(30, seed=5)
    out = [None] * 4

    def work(k):
        out[k] = lcpbench.solve(M, b, solver="lemke").f

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for f in out:
        np.testing.assert_array_equal(f, out[0])


def test_results_reads_a_sweep_csv(tmp_path):
    (tmp_path / "results.csv").write_text(
        "case,solver,status,residual_rel,iterations\nbox,pgs,converged,1e-9,12\n"
        "box,lemke,converged,,3\n"
    )
    rows = lcpbench.results(tmp_path)
    if not isinstance(rows, list):  # pandas installed
        rows = rows.to_dict("records")
        assert np.isnan(rows[1]["residual_rel"])
    else:
        assert rows[1]["residual_rel"] is None
    assert rows[0]["solver"] == "pgs" and rows[0]["iterations"] == 12
    assert rows[0]["residual_rel"] == pytest.approx(1e-9)
    with pytest.raises(FileNotFoundError):
        lcpbench.results(tmp_path / "nowhere")


def test_simulate_box_on_ground_rests():
    out = lcpbench.simulate(ROOT / "bench_scenes" / "box_on_ground.toml", solver="lemke", steps=20)
    assert len(out["status"]) == 20 and out["positions"].shape[0] == 20
    assert out["positions"].shape == (20, len(out["bodies"]), 3)
    assert out["orientations"].shape == (20, len(out["bodies"]), 4)
    np.testing.assert_allclose(np.linalg.norm(out["orientations"], axis=2), 1.0, atol=1e-9)
    assert set(out["solver"]) == {"lemke"}
    assert np.all(np.diff(out["time"]) > 0)
    # The 1 m box rests on the ground: its centre stays at 0.5 m, within the contact margin.
    box = out["bodies"].index("box")
    np.testing.assert_allclose(out["positions"][:, box, 2], 0.5, atol=1e-2)


def test_simulate_bad_input():
    with pytest.raises(FileNotFoundError):
        lcpbench.simulate(ROOT / "no_such_scene.toml")
    with pytest.raises(lcpbench.LcpbenchError, match="solver"):
        lcpbench.simulate(ROOT / "bench_scenes" / "box_on_ground.toml", solver="nope", steps=2)
    with pytest.raises(lcpbench.LcpbenchError, match="steps"):
        lcpbench.simulate(ROOT / "bench_scenes" / "box_on_ground.toml", steps=0)


def test_judge_cone_answers():
    c = lcpbench.Problem.cone(np.eye(3), [-1.0, 0.1, 0.0], [0.5])
    assert c.kind == "cone" and c.n == 3
    exact = lcpbench.judge(c, [1.0, -0.1, 0.0])
    assert exact.converged and exact.unresolved is None
    np.testing.assert_allclose(exact.w, [0.0, 0.0, 0.0], atol=1e-15)
    # Outside the cone (|r_T| = 0.6 > mu r_N = 0.5): not a solution.
    outside = lcpbench.judge(c, [1.0, -0.6, 0.0])
    assert outside.status == "stalled"
    # A matrix solver refuses the cone problem by status, as the command line does.
    r = lcpbench.solve(c, solver="lemke")
    assert r.status == "unsupported" and "cone" in r.reason
