#!/usr/bin/env python3
"""Check that two lcpbench binaries give the same results, bit for bit, on a few scenes.

    scripts/same_results.py OLD_BINARY NEW_BINARY [OUTDIR]

Runs `simulate --record` for the serial iterative solvers (pgs, pgs+warm, sor, si, nsgs) on
tower_10, pyramid_5 and pyramid_3d_91 with each binary and compares the per-step records
(statuses, iterations, residuals, body states, contact impulses) with every timing field left
out. A change meant to make a solver or the step faster without changing its iteration must
leave them identical. Exit status 1 when any record differs.
"""
import json
import os
import subprocess
import sys

SCENES = [
    "bench_scenes/tower_10.toml",
    "bench_scenes/pyramid_5.toml",
    "bench_scenes/scaling/pyramid_3d_91.toml",
]
SOLVERS = ["pgs", "pgs+warm", "sor", "si", "nsgs"]
STEPS = "30"


def strip(v):
    """The record without wall-clock fields (names containing `time`, ending `_s`, phases)."""
    if isinstance(v, dict):
        return {
            k: strip(x)
            for k, x in v.items()
            if not ("time" in k or k.endswith("_s") or k == "phases")
        }
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v


def record(binary, scene, solver, out):
    args = [binary, "simulate", scene, "--solver", solver, "--steps", STEPS, "--record", out]
    subprocess.run(args, check=True, stdout=subprocess.DEVNULL)
    with open(out) as f:
        return [strip(json.loads(line)) for line in f if line.strip()]


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    old, new = sys.argv[1], sys.argv[2]
    out = sys.argv[3] if len(sys.argv) > 3 else "same-results-out"
    os.makedirs(out, exist_ok=True)
    differ = 0
    for scene in SCENES:
        for solver in SOLVERS:
            tag = os.path.basename(scene)[: -len(".toml")] + "_" + solver
            a = record(old, scene, solver, os.path.join(out, tag + ".old.jsonl"))
            b = record(new, scene, solver, os.path.join(out, tag + ".new.jsonl"))
            same = a == b
            differ += not same
            print(("same   " if same else "DIFFER ") + tag)
    print(f"{len(SCENES) * len(SOLVERS)} runs, {differ} differ")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
