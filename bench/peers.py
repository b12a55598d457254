#!/usr/bin/env python3
"""Times peer sparse solvers on exactly the system `transcut bake --export-system DIR` wrote.

Not part of the test suite: a benchmark run by hand beside `transcut bench bake`, so that our
numbers and the peers' come from the same machine at the same time (docs/benchmarks.md).

What it measures, per colour channel c (M_c differs per channel: kappa and mu depend on c), on
M_c x = b[:, c] with the Matrix Market files M_red.mtx, M_green.mtx, M_blue.mtx and b.mtx:

- scipy-jacobi-pcg: SciPy's CG (scipy.sparse.linalg.cg) with a Jacobi (diagonal) preconditioner,
  from x = 0 to a relative residual ||b - M x|| / ||b|| <= 1e-6 (rtol, the stopping rule of
  `transcut`'s solver); iterations counted by callback;
- pyamg-sa: PyAMG smoothed aggregation (pyamg.smoothed_aggregation_solver, defaults), setup
  timed apart from the solve (CG-accelerated V-cycles to the same 1e-6 relative residual);
- cholmod: scikit-sparse's CHOLMOD (sksparse.cholmod), symbolic analysis + numeric
  factorisation timed apart from one solve (skipped with a note when scikit-sparse is missing).

Every timing is the median of --runs runs (default 5; every run is in the JSON); --only and
--channels restrict the peers and channels (CHOLMOD's factorisation is slow on a loaded machine).
BLAS threads follow the usual variables (OPENBLAS_NUM_THREADS, OMP_NUM_THREADS). Loading the
files and building CSR matrices is not timed. The achieved relative residual is checked for
every solver. Output: one JSON object on stdout (per channel and summed over the three
channels, which is what one `transcut` solve does in one pass), plus the machine load from
/proc/loadavg at start and end.

How to run (in a virtual environment outside the repository; see /work/notes/peers.md):

    python3 -m venv /work/peers-venv
    /work/peers-venv/bin/pip install numpy scipy pyamg
    apt-get install libsuitesparse-dev && /work/peers-venv/bin/pip install scikit-sparse
    cargo run --release -p transcut-cli -- bake assets/meshes/stanford-bunny.obj \
        --medium marble --scale <mm per unit for 60 mm> --light sun:dir=0,-1,-1,irradiance=3 \
        --tets 500000 --export-system /tmp/sys500k -o /tmp/b.ply --json
    /work/peers-venv/bin/python bench/peers.py /tmp/sys500k --runs 5
"""

import argparse
import json
import os
import statistics
import sys
import time

import numpy as np
import scipy
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as spla

CHANNELS = ["red", "green", "blue"]
RTOL = 1e-6


def load(folder):
    """The three channel matrices (CSR, float64) and b (n x 3)."""
    mats = []
    for c in CHANNELS:
        m = scipy.io.mmread(os.path.join(folder, f"M_{c}.mtx"))
        mats.append(sp.csr_matrix(m, dtype=np.float64))
    b = np.asarray(scipy.io.mmread(os.path.join(folder, "b.mtx")), dtype=np.float64)
    if b.ndim == 1:
        b = b[:, None]
    assert b.shape == (mats[0].shape[0], 3), b.shape
    return mats, b


def relres(a, x, b):
    return float(np.linalg.norm(b - a @ x) / np.linalg.norm(b))


def median_runs(fn, runs):
    """Runs fn() `runs` times; returns (median seconds, all seconds, last result)."""
    times, out = [], None
    for _ in range(runs):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), times, out


def scipy_pcg(a, b, runs):
    inv_diag = 1.0 / a.diagonal()
    precond = spla.LinearOperator(a.shape, matvec=lambda r: inv_diag * r, dtype=np.float64)

    def run():
        count = [0]

        def cb(_xk):
            count[0] += 1

        x, info = spla.cg(a, b, rtol=RTOL, atol=0.0, M=precond, callback=cb, maxiter=100000)
        assert info == 0, info
        return x, count[0]

    med, times, (x, its) = median_runs(run, runs)
    return {"solve_s": med, "runs_s": times, "iterations": its, "relative_residual": relres(a, x, b)}


def pyamg_sa(a, b, runs):
    import pyamg

    med_setup, setup_times, ml = median_runs(lambda: pyamg.smoothed_aggregation_solver(a), runs)

    def run():
        residuals = []
        x = ml.solve(b, tol=RTOL, accel="cg", residuals=residuals, maxiter=1000)
        return x, len(residuals) - 1

    med_solve, solve_times, (x, its) = median_runs(run, runs)
    return {
        "setup_s": med_setup,
        "setup_runs_s": setup_times,
        "solve_s": med_solve,
        "solve_runs_s": solve_times,
        "iterations": its,
        "levels": len(ml.levels),
        "operator_complexity": float(ml.operator_complexity()),
        "relative_residual": relres(a, x, b),
    }


def cholmod(a, b, runs):
    from sksparse.cholmod import analyze

    a_csc = sp.csc_matrix(a)

    def factor():
        f = analyze(a_csc)
        f.cholesky_inplace(a_csc)
        return f

    med_fact, fact_times, f = median_runs(factor, runs)
    med_solve, solve_times, x = median_runs(lambda: f(b), runs)
    return {
        "analyze_factor_s": med_fact,
        "analyze_factor_runs_s": fact_times,
        "solve_s": med_solve,
        "solve_runs_s": solve_times,
        "relative_residual": relres(a, x, b),
    }


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("folder", help="the --export-system folder (M_red.mtx, M_green.mtx, M_blue.mtx, b.mtx)")
    p.add_argument("--runs", type=int, default=5, help="runs per timing; the median is reported")
    p.add_argument("--only", choices=["scipy", "pyamg", "cholmod"], action="append", help="run only these peers")
    p.add_argument("--channels", default="red,green,blue", help="comma-separated subset of red,green,blue")
    args = p.parse_args()
    peers = args.only or ["scipy", "pyamg", "cholmod"]

    load_start = open("/proc/loadavg").read().split()[:3]
    mats, b = load(args.folder)
    report = {
        "folder": args.folder,
        "n": mats[0].shape[0],
        "nnz": int(mats[0].nnz),
        "runs": args.runs,
        "rtol": RTOL,
        "versions": {"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__},
        "loadavg_start": load_start,
        "channels": {},
    }
    try:
        import pyamg

        report["versions"]["pyamg"] = pyamg.__version__
    except ImportError:
        pass
    channels = [c for c in args.channels.split(",") if c]
    assert all(c in CHANNELS for c in channels), channels
    for c, name in enumerate(CHANNELS):
        if name not in channels:
            continue
        a, rhs = mats[c], b[:, c]
        entry = {}
        if "scipy" in peers:
            entry["scipy_jacobi_pcg"] = scipy_pcg(a, rhs, args.runs)
        if "pyamg" in peers:
            entry["pyamg_sa"] = pyamg_sa(a, rhs, args.runs)
        if "cholmod" in peers:
            try:
                entry["cholmod"] = cholmod(a, rhs, args.runs)
            except ImportError as e:
                entry["cholmod"] = {"skipped": f"scikit-sparse not importable: {e}"}
        report["channels"][name] = entry
        print(
            f"{name}: "
            + json.dumps({k: {kk: v for kk, v in d.items() if not kk.endswith("runs_s")} for k, d in entry.items()}),
            file=sys.stderr,
        )

    totals = {}
    for peer, keys in [
        ("scipy_jacobi_pcg", ["solve_s", "iterations"]),
        ("pyamg_sa", ["setup_s", "solve_s", "iterations"]),
        ("cholmod", ["analyze_factor_s", "solve_s"]),
    ]:
        if len(report["channels"]) != 3:
            break
        per = [report["channels"][c].get(peer, {}) for c in CHANNELS]
        if all(k in d for d in per for k in keys):
            totals[peer] = {k: sum(d[k] for d in per) for k in keys}
    report["three_channels"] = totals
    report["loadavg_end"] = open("/proc/loadavg").read().split()[:3]
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
