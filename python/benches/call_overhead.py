"""What a call from Python adds to a solve: ``lcpbench.solve`` timed with ``timeit`` beside
the solver's own time from ``lcpbench solve --repeat`` on the same problem file.

    python python/benches/call_overhead.py [--lcpbench PATH] [--solvers pgs,lemke,...]
        [--problem FILE.json] [--repeat 30]

(Solvers that stop at the iteration cap on the default problem, such as pgs at 1e-8, take
seconds per solve; pass them with ``--solvers`` when that is what is to be measured.)

Without ``--problem`` it exports the contact LCP of step 10 of
``bench_scenes/scaling/wall_5x25.toml`` (2,706 rows) with the command-line tool. For each solver
it prints the CLI's median solve time (the solver's own time), the median of ``repeat`` timed
``lcpbench.solve(A_csr, b, ...)`` calls (problem built from scipy CSR arrays in the call), the
median with the problem built once (``lcpbench.solve(problem, ...)``), each with its ratio to
the solver's own time (the CLI's), beside the solve time the calls report themselves
(``time_s``), what the CSR call adds beyond its own reported solve time, and the time of
``Problem.lcp(A_csr, b)`` alone; and for a 4×4 LCP the call's cost beyond the solve it reports
(``time_s``). Medians with min–max spread; run it on a quiet machine, with the package built
by ``pip install ./python`` (release, as the CLI).
"""

import argparse
import json
import os
import statistics
import subprocess
import tempfile
import timeit

import numpy as np
import scipy.sparse as sp

import lcpbench


def cli_time(exe, path, solver, repeat):
    out = subprocess.run(
        [exe, "solve", path, "--solver", solver, "--repeat", str(repeat), "--json",
         "--max-iter", "10000"],
        check=True, capture_output=True, text=True).stdout
    doc = json.loads(out)
    return doc


def timed(fn, repeat):
    fn()  # warm caches, as `--repeat` does
    times = timeit.repeat(fn, number=1, repeat=repeat)
    return statistics.median(times), min(times), max(times)


def timed_solves(solve, repeat):
    """``repeat`` timed calls of ``solve`` (after one untimed call, as ``--repeat`` does): the
    first call's result, the calls' wall times and the solve times they report (``time_s``),
    and per call what it added beyond its own solve (wall less ``time_s``)."""
    first = solve()
    walls, owns, beyond = [], [], []
    for _ in range(repeat):
        t0 = timeit.default_timer()
        r = solve()
        wall = timeit.default_timer() - t0
        walls.append(wall)
        owns.append(r.time_s)
        beyond.append(wall - r.time_s)
    return first, walls, owns, beyond


def spread(xs):
    return statistics.median(xs), min(xs), max(xs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lcpbench", default="target/release/lcpbench")
    ap.add_argument("--solvers", default="newton-min,newton-fb,nncg")
    ap.add_argument("--problem")
    ap.add_argument("--repeat", type=int, default=30)
    args = ap.parse_args()

    tmp = tempfile.mkdtemp()
    path = args.problem
    if path is None:
        path = os.path.join(tmp, "wall_5x25_step10.json")
        subprocess.run([args.lcpbench, "export", "bench_scenes/scaling/wall_5x25.toml",
                        "--step", "10", "-o", path], check=True, capture_output=True)
    doc = json.load(open(path))
    problem = lcpbench.read(path)
    n = len(doc["b"])
    a = problem.A if hasattr(problem, "A") else None
    if a is None or not sp.issparse(a):
        a = sp.csr_matrix(np.asarray(a))
    a = a.tocsr()
    b = np.asarray(doc["b"], dtype=float)
    lo = np.asarray(problem.lo) if hasattr(problem, "lo") else None
    hi = np.asarray(problem.hi) if hasattr(problem, "hi") else None
    friction = problem.friction if hasattr(problem, "friction") else None
    print(f"problem {path}: {n} rows, {a.nnz} stored entries; {args.repeat} timed calls each")
    print(f"{'solver':<12} {'status':<16} {'own (CLI) ms':>13} {'own (in call) ms':>17} "
          f"{'solve(A,b) ms':>14} {'ratio':>6} {'solve(problem) ms':>18} {'ratio':>6}")
    for solver in args.solvers.split(","):
        cli = cli_time(args.lcpbench, path, solver, args.repeat)
        own = cli["time_s"]
        # The CSR call builds its problem from the CSR arrays, stored sparse; the one read from
        # the file may be dense, so the two solves differ. What the CSR call adds beyond its own
        # solve: reading the arrays, building the problem, the result's arrays.
        r, csr_walls, csr_owns, csr_beyond = timed_solves(
            lambda: lcpbench.solve(a, b, lo, hi, friction, solver=solver, max_iter=10000),
            args.repeat)
        _, reuse_walls, reuse_owns, _ = timed_solves(
            lambda: lcpbench.solve(problem, solver=solver, max_iter=10000), args.repeat)
        build = timed(lambda: lcpbench.Problem.lcp(a, b, lo, hi, friction), args.repeat)
        call, reuse = spread(csr_walls), spread(reuse_walls)
        inner = statistics.median(reuse_owns)
        csr_own_med = statistics.median(csr_owns)
        beyond_med = statistics.median(csr_beyond)
        print(f"{solver:<12} {r.status:<16} {own * 1e3:13.3f} {inner * 1e3:17.3f} "
              f"{call[0] * 1e3:8.3f} ({call[1] * 1e3:.3f}-{call[2] * 1e3:.3f}) "
              f"{call[0] / own:6.2f} {reuse[0] * 1e3:18.3f} {reuse[0] / own:6.2f}")
        print(f"{'':<12} solve(A,b): own {csr_own_med * 1e3:.3f} ms, the call beyond it "
              f"{beyond_med * 1e3:.3f} ms ({100 * beyond_med / csr_own_med:.1f} % of its own "
              f"time); Problem.lcp(A,b) alone {build[0] * 1e3:.3f} ms "
              f"({build[1] * 1e3:.3f}-{build[2] * 1e3:.3f})")

    a4 = np.array([[4.0, 1, 0, 0], [1, 4, 1, 0], [0, 1, 4, 1], [0, 0, 1, 4]])
    b4 = np.array([-1.0, 2, -3, 1])
    for solver in ["lemke", "pgs"]:
        _, _, _, beyond = timed_solves(lambda: lcpbench.solve(a4, b4, solver=solver),
                                       args.repeat * 20)
        med, lo_, hi_ = spread(beyond)
        print(f"4x4 {solver}: call beyond the reported solve time: median "
              f"{med * 1e6:.2f} us (min {lo_ * 1e6:.2f}, max {hi_ * 1e6:.2f})")


if __name__ == "__main__":
    main()
