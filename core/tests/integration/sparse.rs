//! Integration tests of `transcut::sparse`: solvers against dense references, channel
//! independence, warm starts, errors, determinism across thread counts, Matrix Market I/O.
//! The `bench_` tests are `#[ignore]`d measurements, run by hand in release mode:
//! `cargo test --release -p transcut --test integration -- --ignored --nocapture sparse::bench_`.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use transcut::sparse::{
    bicgstab, pcg, read_array_matrix_market, write_vector3_matrix_market, write_vector_matrix_market, CsrMatrix, CsrMatrix3,
    CsrPattern, Precision, Preconditioner, PreconditionerKind, SolveOptions, SparseError, Triplet,
};

/// A random SPD matrix: a random weighted graph Laplacian (different weights per channel) plus a
/// positive diagonal, so strictly diagonally dominant with positive diagonal.
fn random_spd(n: usize, extra_edges: usize, seed: u64) -> CsrMatrix3 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut t = Vec::new();
    let edge = |i: u32, j: u32, rng: &mut ChaCha8Rng, t: &mut Vec<Triplet<[f64; 3]>>| {
        let w: [f64; 3] = std::array::from_fn(|_| rng.random_range(0.1..2.0));
        t.push(Triplet::new(i, j, w.map(|x| -x)));
        t.push(Triplet::new(j, i, w.map(|x| -x)));
        t.push(Triplet::new(i, i, w));
        t.push(Triplet::new(j, j, w));
    };
    // A path keeps the graph connected; random chords add fill.
    for i in 1..n as u32 {
        edge(i - 1, i, &mut rng, &mut t);
    }
    for _ in 0..extra_edges {
        let i = rng.random_range(0..n as u32);
        let j = rng.random_range(0..n as u32);
        if i != j {
            edge(i, j, &mut rng, &mut t);
        }
    }
    for i in 0..n as u32 {
        // Different "absorption" per channel: channel 0 is the worst conditioned.
        let m = [1e-3, 1e-1, 1.0].map(|s: f64| s * rng.random_range(0.5..1.5));
        t.push(Triplet::new(i, i, m));
    }
    CsrMatrix3::from_triplets(n, &t).unwrap()
}

fn random_vec(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| std::array::from_fn(|_| rng.random_range(-1.0..1.0))).collect()
}

fn channel(v: &[[f64; 3]], c: usize) -> DVector<f64> {
    DVector::from_iterator(v.len(), v.iter().map(|x| x[c]))
}

fn rel_err(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).norm() / b.norm()
}

fn jacobi(a: &CsrMatrix3) -> Preconditioner {
    Preconditioner::new(a, PreconditionerKind::Jacobi).unwrap()
}

#[test]
fn pcg_matches_dense_cholesky_for_each_preconditioner() {
    for (seed, n) in [(1u64, 60usize), (2, 150), (3, 300)] {
        let a = random_spd(n, 3 * n, seed);
        assert!(a.is_symmetric(0.0));
        let b = random_vec(n, seed + 100);
        for kind in [
            PreconditionerKind::Identity,
            PreconditionerKind::Jacobi,
            PreconditionerKind::Chebyshev { degree: 1 },
            PreconditionerKind::Chebyshev { degree: 3 },
            PreconditionerKind::Ssor,
        ] {
            let pc = Preconditioner::new(&a, kind).unwrap();
            for precision in [Precision::Mixed, Precision::Double] {
                let mut x = vec![[0.0; 3]; n];
                let opts = SolveOptions::default().with_tolerance(1e-12).with_precision(precision);
                let stats = pcg(&a, &b, &mut x, &pc, &opts).unwrap();
                assert!(stats.converged, "{kind:?} {precision:?}: {stats:?}");
                for c in 0..3 {
                    let dense = a.to_dense(c);
                    let exact = dense.clone().cholesky().expect("SPD").solve(&channel(&b, c));
                    let e = rel_err(&channel(&x, c), &exact);
                    assert!(e < 1e-8, "n {n} {kind:?} {precision:?} channel {c}: error {e:e}");
                    assert!(stats.relative_residual[c] <= 1e-12);
                    // The reported residual is the true one.
                    let r = channel(&b, c) - &dense * channel(&x, c);
                    let true_rel = r.norm() / channel(&b, c).norm();
                    assert!((true_rel - stats.relative_residual[c]).abs() <= 1e-3 * true_rel + 1e-15);
                }
            }
        }
    }
}

#[test]
fn badly_scaled_systems_converge_in_both_precisions() {
    // B = T A T with T spanning four orders of magnitude: Jacobi scaling undoes T exactly, so
    // the iteration counts match those of A while the unscaled residual norm is dominated by a
    // few rows.
    let n = 300;
    let a = random_spd(n, 900, 61);
    let mut rng = ChaCha8Rng::seed_from_u64(62);
    let t: Vec<f64> = (0..n).map(|_| 10f64.powf(rng.random_range(-2.0..2.0))).collect();
    let p = a.pattern();
    let mut values = a.values().to_vec();
    for (i, &ti) in t.iter().enumerate() {
        let (s, e) = (p.row_ptr()[i], p.row_ptr()[i + 1]);
        for (v, &j) in values[s..e].iter_mut().zip(&p.col_idx()[s..e]) {
            *v = v.map(|x| x * ti * t[j as usize]);
        }
    }
    let bm = CsrMatrix3::new(Arc::clone(p), values).unwrap();
    let b = random_vec(n, 63);
    for precision in [Precision::Mixed, Precision::Double] {
        let mut x = vec![[0.0; 3]; n];
        let opts = SolveOptions::default().with_tolerance(1e-9).with_precision(precision);
        let s = pcg(&bm, &b, &mut x, &jacobi(&bm), &opts).unwrap();
        assert!(s.converged, "{precision:?}: {s:?}");
        for c in 0..3 {
            let exact = bm.to_dense(c).cholesky().unwrap().solve(&channel(&b, c));
            let e = rel_err(&channel(&x, c), &exact);
            assert!(e < 1e-6, "{precision:?} channel {c}: {e:e}");
        }
        // Below what f64 can attain here (about 1e-11 on channel R): no error and no endless
        // loop; the mixed solve hands over to f64 when its f32 operator stops resolving the
        // residual, and both report the residual they reached.
        let mut x = vec![[0.0; 3]; n];
        let opts = SolveOptions::default().with_tolerance(1e-14).with_precision(precision);
        let s = pcg(&bm, &b, &mut x, &jacobi(&bm), &opts).unwrap();
        assert!(!s.converged_channels[0]);
        assert!(s.relative_residual[0] < 1e-9, "{precision:?}: {s:?}");
        assert!(s.iterations[0] < 1000, "{precision:?}: {s:?}");
    }
}

#[test]
fn channels_converge_independently() {
    let n = 400;
    let a = random_spd(n, 4 * n, 7);
    let b = random_vec(n, 8);
    for precision in [Precision::Mixed, Precision::Double] {
        let opts = SolveOptions::default().with_tolerance(1e-10).with_precision(precision);
        let mut x = vec![[0.0; 3]; n];
        let stats = pcg(&a, &b, &mut x, &jacobi(&a), &opts).unwrap();
        // Channel 0 has the smallest mass term, so the worst conditioning: most iterations.
        let it = stats.iterations;
        assert!(it[0] > it[1] && it[1] > it[2], "{precision:?}: {it:?}");
        // Each channel alone (others zero) gives the same iterations and the same bits.
        for c in 0..3 {
            let mut bc = vec![[0.0; 3]; n];
            for (d, s) in bc.iter_mut().zip(&b) {
                d[c] = s[c];
            }
            let mut xc = vec![[0.0; 3]; n];
            let sc = pcg(&a, &bc, &mut xc, &jacobi(&a), &opts).unwrap();
            assert_eq!(sc.iterations[c], it[c], "{precision:?} channel {c}");
            assert_eq!(sc.relative_residual[c], stats.relative_residual[c]);
            for k in 0..3 {
                if k != c {
                    assert_eq!(sc.iterations[k], 0);
                    assert!(xc.iter().all(|v| v[k] == 0.0));
                }
            }
            assert!(xc.iter().zip(&x).all(|(u, v)| u[c].to_bits() == v[c].to_bits()), "{precision:?} channel {c}");
        }
    }
}

#[test]
fn warm_start_from_the_solution_takes_at_most_one_iteration() {
    let n = 300;
    let a = random_spd(n, 900, 11);
    let b = random_vec(n, 12);
    let mut x = vec![[0.0; 3]; n];
    let opts = SolveOptions::default().with_tolerance(1e-8);
    let cold = pcg(&a, &b, &mut x, &jacobi(&a), &opts).unwrap();
    assert!(cold.iterations.iter().all(|&i| i > 5));
    let mut exact = vec![[0.0; 3]; n];
    for c in 0..3 {
        let s = a.to_dense(c).cholesky().unwrap().solve(&channel(&b, c));
        for (e, v) in exact.iter_mut().zip(s.iter()) {
            e[c] = *v;
        }
    }
    let mut x = exact.clone();
    let warm = pcg(&a, &b, &mut x, &jacobi(&a), &opts).unwrap();
    assert!(warm.iterations.iter().all(|&i| i <= 1), "{warm:?}");
    assert!(warm.converged);
    let mut x = exact.clone();
    let warm = bicgstab(&a, &b, &mut x, &jacobi(&a), &opts).unwrap();
    assert!(warm.iterations.iter().all(|&i| i <= 1), "{warm:?}");
}

#[test]
fn zero_right_hand_side_returns_zero_immediately() {
    let n = 50;
    let a = random_spd(n, 100, 3);
    let mut b = random_vec(n, 4);
    for v in &mut b {
        v[1] = 0.0;
    }
    let mut x = vec![[5.0; 3]; n];
    let s = pcg(&a, &b, &mut x, &jacobi(&a), &SolveOptions::default()).unwrap();
    assert_eq!(s.iterations[1], 0);
    assert_eq!(s.relative_residual[1], 0.0);
    assert!(x.iter().all(|v| v[1] == 0.0));
    let zero = vec![[0.0; 3]; n];
    let mut x = vec![[1.0; 3]; n];
    let s = pcg(&a, &zero, &mut x, &jacobi(&a), &SolveOptions::default()).unwrap();
    assert_eq!(s.iterations, [0; 3]);
    assert!(s.converged);
    assert!(x.iter().all(|v| *v == [0.0; 3]));
}

#[test]
fn indefinite_matrix_breaks_down_naming_the_channel() {
    // Channel G is indefinite (eigenvalues 3 and -1 of [[1, 2], [2, 1]] blocks); R, B are SPD.
    let n = 20;
    let mut t = Vec::new();
    for k in 0..n as u32 / 2 {
        let (i, j) = (2 * k, 2 * k + 1);
        t.push(Triplet::new(i, i, [2.0, 1.0, 2.0]));
        t.push(Triplet::new(j, j, [2.0, 1.0, 2.0]));
        t.push(Triplet::new(i, j, [0.5, 2.0, 0.5]));
        t.push(Triplet::new(j, i, [0.5, 2.0, 0.5]));
    }
    let a = CsrMatrix3::from_triplets(n, &t).unwrap();
    let b: Vec<[f64; 3]> = (0..n).map(|i| if i % 2 == 0 { [1.0; 3] } else { [-1.0; 3] }).collect();
    let mut x = vec![[0.0; 3]; n];
    let err = pcg(&a, &b, &mut x, &jacobi(&a), &SolveOptions::default()).unwrap_err();
    match &err {
        SparseError::Breakdown { method, channel, iteration, .. } => {
            assert_eq!((*method, *channel, *iteration), ("PCG", 1, 1));
        }
        e => panic!("expected breakdown, got {e}"),
    }
    let msg = err.to_string();
    assert!(msg.contains("channel 1 (G)") && msg.contains("not positive definite"), "{msg}");
    assert!(x.iter().all(|v| *v == [0.0; 3]), "x unchanged on error");
    // A negative diagonal is caught when building Jacobi.
    let mut neg = a.clone();
    let k = neg.pattern().diagonal_positions()[4];
    neg.values_mut()[k][0] = -1.0;
    let e = Preconditioner::new(&neg, PreconditionerKind::Jacobi).unwrap_err();
    assert!(matches!(e, SparseError::NonPositiveDiagonal { row: 4, channel: 0, .. }), "{e}");
}

#[test]
fn non_finite_inputs_and_bad_sizes_are_named() {
    let n = 30;
    let a = random_spd(n, 60, 5);
    let pc = jacobi(&a);
    let mut b = random_vec(n, 6);
    b[17][2] = f64::NAN;
    let mut x = vec![[0.0; 3]; n];
    let e = pcg(&a, &b, &mut x, &pc, &SolveOptions::default()).unwrap_err();
    assert!(matches!(e, SparseError::NonFinite { what: "right-hand side", row: 17, channel: 2, .. }), "{e}");
    assert!(e.to_string().contains("right-hand side"), "{e}");
    let e = bicgstab(&a, &b, &mut x, &pc, &SolveOptions::default()).unwrap_err();
    assert!(matches!(e, SparseError::NonFinite { row: 17, .. }), "{e}");
    let b = random_vec(n, 6);
    x[3][0] = f64::INFINITY;
    let e = pcg(&a, &b, &mut x, &pc, &SolveOptions::default()).unwrap_err();
    assert!(matches!(e, SparseError::NonFinite { what: "initial guess", row: 3, channel: 0, .. }), "{e}");
    let mut x = vec![[0.0; 3]; n];
    let mut bad = a.clone();
    let k = bad.pattern().position(9, 9).unwrap();
    bad.values_mut()[k][1] = f64::NAN;
    let e = pcg(&bad, &b, &mut x, &pc, &SolveOptions::default()).unwrap_err();
    assert!(matches!(e, SparseError::NonFinite { what: "matrix", row: 9, channel: 1, .. }), "{e}");
    let e = pcg(&a, &b[..n - 1], &mut x, &pc, &SolveOptions::default()).unwrap_err();
    assert!(matches!(e, SparseError::DimensionMismatch { expected: 30, found: 29, .. }), "{e}");
    let other = jacobi(&random_spd(n + 1, 10, 1));
    let e = pcg(&a, &b, &mut x, &other, &SolveOptions::default()).unwrap_err();
    assert!(matches!(e, SparseError::DimensionMismatch { .. }), "{e}");
    let same_size = jacobi(&random_spd(n, 10, 1));
    let e = pcg(&a, &b, &mut x, &same_size, &SolveOptions::default()).unwrap_err();
    assert!(matches!(e, SparseError::PatternMismatch(_)), "{e}");
    let e = pcg(&a, &b, &mut x, &pc, &SolveOptions::default().with_tolerance(f64::NAN)).unwrap_err();
    assert!(matches!(e, SparseError::InvalidOption(_)), "{e}");
}

#[test]
fn monitor_can_cancel_and_iteration_limit_reports_not_converged() {
    let n = 500;
    let a = random_spd(n, 1500, 21);
    let b = random_vec(n, 22);
    let calls = std::sync::atomic::AtomicUsize::new(0);
    let stop_at_5 = |it: usize, rel: [f64; 3]| {
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        assert!(rel.iter().all(|r| r.is_finite()));
        it < 5
    };
    let mut x = vec![[0.0; 3]; n];
    let e = pcg(&a, &b, &mut x, &jacobi(&a), &SolveOptions::default().with_monitor(&stop_at_5)).unwrap_err();
    assert!(matches!(e, SparseError::Cancelled { iteration: 5 }), "{e}");
    assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 5);
    assert!(x.iter().all(|v| *v == [0.0; 3]));
    let s = pcg(&a, &b, &mut x, &jacobi(&a), &SolveOptions::default().with_max_iterations(3)).unwrap();
    assert!(!s.converged);
    assert_eq!(s.iterations, [3; 3]);
    assert!(s.relative_residual.iter().all(|&r| r > 1e-6 && r < 1.0));
}

/// A large enough system for many parallel blocks.
fn big_system() -> (CsrMatrix3, Vec<[f64; 3]>) {
    let n = 30_000;
    (random_spd(n, 5 * n, 99), random_vec(n, 98))
}

#[test]
fn results_are_bit_identical_for_1_2_and_3_threads() {
    let (a, b) = big_system();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut out = Vec::new();
            for kind in [PreconditionerKind::Jacobi, PreconditionerKind::Chebyshev { degree: 2 }, PreconditionerKind::Ssor] {
                let pc = Preconditioner::new(&a, kind).unwrap();
                for precision in [Precision::Mixed, Precision::Double] {
                    let mut x = vec![[0.0; 3]; a.n()];
                    let opts = SolveOptions::default().with_tolerance(1e-9).with_precision(precision);
                    let s = pcg(&a, &b, &mut x, &pc, &opts).unwrap();
                    out.push((s, x));
                }
            }
            let mut x = vec![[0.0; 3]; a.n()];
            let s = bicgstab(&a, &b, &mut x, &jacobi(&a), &SolveOptions::default().with_tolerance(1e-9)).unwrap();
            out.push((s, x));
            let again = CsrMatrix3::from_triplets(a.n(), &triplets_of(&a)).unwrap();
            (out, again)
        })
    };
    let (r1, m1) = run(1);
    let (r2, m2) = run(2);
    let (r3, m3) = run(3);
    assert_eq!(m1, m2);
    assert_eq!(m1, m3);
    for ((a1, a2), a3) in r1.iter().zip(&r2).zip(&r3) {
        assert!(a1.0.converged);
        assert_eq!(a1.0, a2.0);
        assert_eq!(a1.0, a3.0);
        let bits = |x: &Vec<[f64; 3]>| x.iter().flat_map(|v| v.map(f64::to_bits)).collect::<Vec<_>>();
        assert!(bits(&a1.1) == bits(&a2.1) && bits(&a1.1) == bits(&a3.1));
    }
}

/// The matrix as triplets, each entry split in two summands (exercises duplicate summing).
fn triplets_of(a: &CsrMatrix3) -> Vec<Triplet<[f64; 3]>> {
    let p = a.pattern();
    let mut t = Vec::new();
    for i in 0..a.n() {
        let r = p.row_ptr()[i];
        for (q, &j) in p.row(i).iter().enumerate() {
            let v = a.values()[r + q];
            t.push(Triplet::new(i as u32, j, v.map(|x| 0.25 * x)));
            t.push(Triplet::new(i as u32, j, v.map(|x| 0.75 * x)));
        }
    }
    t
}

#[test]
fn matrix_market_round_trip() {
    let dir = std::env::temp_dir().join(format!("transcut-sparse-mm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let a = random_spd(200, 600, 31);
    for c in 0..3 {
        let path = dir.join(format!("a{c}.mtx"));
        a.write_matrix_market(&path, c).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("%%MatrixMarket matrix coordinate real symmetric"));
        let back = CsrMatrix::read_matrix_market(&path).unwrap();
        assert_eq!(back, a.channel(c));
    }
    // A general (unsymmetric) matrix with awkward values.
    let t = vec![
        Triplet::new(0u32, 1u32, 1e-300),
        Triplet::new(1, 0, -0.1),
        Triplet::new(2, 2, std::f64::consts::PI),
        Triplet::new(1, 2, 123_456_789.123_456_78),
    ];
    let g = CsrMatrix::from_triplets(3, &t).unwrap();
    let path = dir.join("g.mtx");
    g.write_matrix_market(&path, 0).unwrap();
    assert!(std::fs::read_to_string(&path).unwrap().contains("coordinate real general"));
    assert_eq!(CsrMatrix::read_matrix_market(&path).unwrap(), g);
    // Vectors.
    let v = random_vec(77, 3);
    let path = dir.join("v.mtx");
    write_vector3_matrix_market(&path, &v).unwrap();
    let arr = read_array_matrix_market(&path).unwrap();
    assert_eq!((arr.rows, arr.cols), (77, 3));
    for c in 0..3 {
        assert!(arr.column(c).iter().zip(&v).all(|(x, y)| *x == y[c]));
    }
    let path = dir.join("v1.mtx");
    let single: Vec<f64> = v.iter().map(|x| x[1]).collect();
    write_vector_matrix_market(&path, &single).unwrap();
    assert_eq!(read_array_matrix_market(&path).unwrap().data, single);
    // Errors name the line.
    let bad = dir.join("bad.mtx");
    std::fs::write(&bad, "%%MatrixMarket matrix coordinate real general\n% c\n3 3 2\n1 1 1.0\n4 1 2.0\n").unwrap();
    match CsrMatrix::read_matrix_market(&bad).unwrap_err() {
        SparseError::MatrixMarket { line, message, .. } => {
            assert_eq!(line, 5);
            assert!(message.contains("out of range"), "{message}");
        }
        e => panic!("{e}"),
    }
    std::fs::write(&bad, "%%MatrixMarket matrix coordinate complex general\n1 1 1\n1 1 1 0\n").unwrap();
    assert!(matches!(CsrMatrix::read_matrix_market(&bad), Err(SparseError::MatrixMarket { line: 1, .. })));
    assert!(matches!(CsrMatrix::read_matrix_market(dir.join("missing.mtx")), Err(SparseError::Io { .. })));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A nonsymmetric, strictly diagonally dominant matrix (convection–diffusion-like).
fn random_nonsymmetric(n: usize, seed: u64) -> CsrMatrix3 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut t = Vec::new();
    let mut rowsum = vec![[0.0f64; 3]; n];
    for (i, sum) in rowsum.iter_mut().enumerate() {
        for _ in 0..5 {
            let j = rng.random_range(0..n);
            if j != i {
                let v: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
                for c in 0..3 {
                    sum[c] += v[c].abs();
                }
                t.push(Triplet::new(i as u32, j as u32, v));
            }
        }
    }
    for (i, s) in rowsum.iter().enumerate() {
        t.push(Triplet::new(i as u32, i as u32, s.map(|x| 1.05 * x + 0.01)));
    }
    CsrMatrix3::from_triplets(n, &t).unwrap()
}

#[test]
fn bicgstab_matches_dense_lu_on_nonsymmetric_systems() {
    for (seed, n) in [(41u64, 80usize), (42, 250)] {
        let a = random_nonsymmetric(n, seed);
        assert!(!a.is_symmetric(1e-3));
        let b = random_vec(n, seed + 1);
        for kind in [PreconditionerKind::Identity, PreconditionerKind::Jacobi] {
            let pc = Preconditioner::new(&a, kind).unwrap();
            let mut x = random_vec(n, 5); // a (bad) warm start
            let s = bicgstab(&a, &b, &mut x, &pc, &SolveOptions::default().with_tolerance(1e-12)).unwrap();
            assert!(s.converged, "{kind:?}: {s:?}");
            for c in 0..3 {
                let exact = a.to_dense(c).lu().solve(&channel(&b, c)).unwrap();
                let e = rel_err(&channel(&x, c), &exact);
                assert!(e < 1e-8, "n {n} {kind:?} channel {c}: {e:e}");
            }
        }
    }
}

#[test]
fn bicgstab_also_solves_spd_systems() {
    let a = random_spd(200, 600, 51);
    let b = random_vec(200, 52);
    let mut x = vec![[0.0; 3]; 200];
    let s = bicgstab(&a, &b, &mut x, &jacobi(&a), &SolveOptions::default().with_tolerance(1e-11)).unwrap();
    assert!(s.converged);
    for c in 0..3 {
        let exact = a.to_dense(c).cholesky().unwrap().solve(&channel(&b, c));
        assert!(rel_err(&channel(&x, c), &exact) < 1e-8);
    }
}

#[test]
fn pattern_from_edges_and_assembly_on_it() {
    let edges = [[0u32, 1u32], [1, 2], [2, 0], [3, 2], [1, 0]];
    let p = Arc::new(CsrPattern::from_edges(4, &edges).unwrap());
    assert_eq!(p.nnz(), 4 + 2 * 4);
    let mut a = CsrMatrix3::zeros(Arc::clone(&p));
    for &[i, j] in &edges[..4] {
        let (i, j) = (i as usize, j as usize);
        for (r, c, v) in [(i, j, -1.0), (j, i, -1.0), (i, i, 1.5), (j, j, 1.5)] {
            a.add_to(r, c, [v, 2.0 * v, 3.0 * v]).unwrap();
        }
    }
    assert!(a.is_symmetric(0.0));
    assert!(matches!(a.add_to(0, 3, [1.0; 3]), Err(SparseError::NotInPattern { row: 0, col: 3 })));
    let d = a.to_dense(1);
    assert_eq!(d[(2, 2)], 9.0);
    assert_eq!(d[(3, 2)], -2.0);
    let b = vec![[1.0; 3]; 4];
    let mut x = vec![[0.0; 3]; 4];
    let s = pcg(&a, &b, &mut x, &jacobi(&a), &SolveOptions::default().with_tolerance(1e-13)).unwrap();
    assert!(s.converged);
    let y = a.mul_vec(&x).unwrap();
    assert!(y.iter().all(|v| v.iter().all(|t| (t - 1.0).abs() < 1e-12)));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// SpMV and triplet assembly agree with dense arithmetic for arbitrary small matrices.
    #[test]
    fn spmv_and_assembly_match_dense(
        n in 1usize..40,
        entries in prop::collection::vec((0u32..40, 0u32..40, -10.0f64..10.0), 0..200),
        xs in prop::collection::vec(-5.0f64..5.0, 40),
    ) {
        let t: Vec<Triplet<[f64; 3]>> = entries
            .iter()
            .filter(|(i, j, _)| (*i as usize) < n && (*j as usize) < n)
            .map(|&(i, j, v)| Triplet::new(i, j, [v, -v, 0.5 * v]))
            .collect();
        let a = CsrMatrix3::from_triplets(n, &t).unwrap();
        let mut dense = DMatrix::<f64>::zeros(n, n);
        for tr in &t {
            dense[(tr.row as usize, tr.col as usize)] += tr.value[0];
        }
        prop_assert!((a.to_dense(0) - &dense).abs().max() < 1e-12);
        let x: Vec<[f64; 3]> = xs[..n].iter().map(|&v| [v, v, v]).collect();
        let y = a.mul_vec(&x).unwrap();
        let yd = &dense * DVector::from_iterator(n, xs[..n].iter().copied());
        for i in 0..n {
            prop_assert!((y[i][0] - yd[i]).abs() < 1e-9);
            prop_assert!((y[i][1] + yd[i]).abs() < 1e-9);
        }
        for i in 0..n {
            prop_assert!(a.pattern().position(i, i).is_some());
        }
        let again = CsrMatrix3::from_triplets_with_pattern(Arc::clone(a.pattern()), &t).unwrap();
        prop_assert_eq!(again, a);
    }
}

// ---------------------------------------------------------------------------------------------
// Measurements (run by hand, release mode).

/// The tet-mesh proxy: a (2m)-ish cube of side `s` vertices, Kuhn (Freudenthal) connectivity
/// (14 neighbours inside, like a tetrahedral mesh vertex graph), marble-like coefficients per
/// channel, Robin boundary term, and `b` on the boundary only — the shape of the TransCut system.
pub fn kuhn_proxy(s: usize) -> (CsrMatrix3, Vec<[f64; 3]>) {
    let h = 20.0 / (s - 1) as f64; // a 20 mm cube
    let sigma_a = [0.0021, 0.0041, 0.0071];
    let sigma_s = [2.19, 2.62, 3.00];
    let kappa: [f64; 3] = std::array::from_fn(|c| 1.0 / (3.0 * (sigma_a[c] + sigma_s[c])));
    let big_a = 2.60; // (1 + Fdr)/(1 − Fdr) at η = 1.3
    let idx = |x: usize, y: usize, z: usize| ((z * s + y) * s + x) as u32;
    let offsets: [([i64; 3], f64); 7] = [
        ([1, 0, 0], 1.0),
        ([0, 1, 0], 1.0),
        ([0, 0, 1], 1.0),
        ([1, 1, 0], 0.5),
        ([0, 1, 1], 0.5),
        ([1, 0, 1], 0.5),
        ([1, 1, 1], 0.25),
    ];
    let n = s * s * s;
    let mut t = Vec::with_capacity(n * 30);
    for z in 0..s {
        for y in 0..s {
            for x in 0..s {
                let i = idx(x, y, z);
                let boundary = [x, y, z].iter().any(|&v| v == 0 || v == s - 1);
                let mass: [f64; 3] =
                    std::array::from_fn(|c| h * h * h * sigma_a[c] + if boundary { 2.0 * h * h / (3.0 * big_a) } else { 0.0 });
                t.push(Triplet::new(i, i, mass));
                for (o, wgt) in offsets {
                    let (a, b, c) = (x as i64 + o[0], y as i64 + o[1], z as i64 + o[2]);
                    if a < s as i64 && b < s as i64 && c < s as i64 {
                        let j = idx(a as usize, b as usize, c as usize);
                        let w: [f64; 3] = std::array::from_fn(|ch| 4.0 * kappa[ch] * h * wgt / 3.0);
                        t.push(Triplet::new(i, j, w.map(|v| -v)));
                        t.push(Triplet::new(j, i, w.map(|v| -v)));
                        t.push(Triplet::new(i, i, w));
                        t.push(Triplet::new(j, j, w));
                    }
                }
            }
        }
    }
    let a = CsrMatrix3::from_triplets(n, &t).unwrap();
    let b = (0..n)
        .map(|i| {
            let (x, y, z) = (i % s, (i / s) % s, i / (s * s));
            let boundary = [x, y, z].iter().any(|&v| v == 0 || v == s - 1);
            // Light from one side: a smooth source over the boundary.
            let q = if boundary { 1.0 + (x as f64 / s as f64) } else { 0.0 };
            [q * h * h; 3]
        })
        .collect();
    (a, b)
}

/// CPU time of the calling thread, from `/proc/thread-self/schedstat` (ns run time).
fn thread_cpu_ms() -> f64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    s.split_whitespace().next().and_then(|t| t.parse::<f64>().ok()).unwrap_or(f64::NAN) / 1e6
}

fn time_best<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps {
        let t0 = Instant::now();
        let r = f();
        best = best.min(t0.elapsed().as_secs_f64() * 1e3);
        out = Some(r);
    }
    (best, out.expect("reps ≥ 1"))
}

#[test]
#[ignore = "measurement: run by hand in release mode"]
fn bench_preconditioners_on_the_86k_proxy() {
    let s = 44;
    let t0 = Instant::now();
    let (a, b) = kuhn_proxy(s);
    let n = a.n();
    println!("load: {}", std::fs::read_to_string("/proc/loadavg").unwrap_or_default().trim());
    println!(
        "proxy: n = {n}, nnz = {} ({:.1}/row), assembly {:.0} ms, threads {}",
        a.nnz(),
        a.nnz() as f64 / n as f64,
        t0.elapsed().as_secs_f64() * 1e3,
        rayon::current_num_threads()
    );
    let x1 = vec![[1.0; 3]; n];
    let mut y = vec![[0.0; 3]; n];
    let (ms, ()) = time_best(20, || a.spmv(&x1, &mut y).unwrap());
    let bytes = a.nnz() * (24 + 4) + n * (8 + 24 + 24);
    println!("SpMV (3 channels): {ms:.3} ms, {:.1} GB/s effective", bytes as f64 / ms / 1e6);
    let kinds = [
        PreconditionerKind::Jacobi,
        PreconditionerKind::Chebyshev { degree: 1 },
        PreconditionerKind::Chebyshev { degree: 2 },
        PreconditionerKind::Chebyshev { degree: 3 },
        PreconditionerKind::Chebyshev { degree: 4 },
        PreconditionerKind::Ssor,
    ];
    let rounds: usize = std::env::var("ROUNDS").ok().and_then(|v| v.parse().ok()).unwrap_or(7);
    let mut pcs = Vec::new();
    for kind in kinds {
        let (setup, pc) = time_best(3, || Preconditioner::new(&a, kind).unwrap());
        pcs.push((kind, setup, pc));
    }
    let cases: Vec<(usize, Precision)> = (0..pcs.len()).flat_map(|k| [(k, Precision::Mixed), (k, Precision::Double)]).collect();
    let mut best = vec![f64::INFINITY; cases.len()];
    let mut cpu1 = vec![f64::INFINITY; cases.len()];
    let mut results = vec![None; cases.len()];
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    // Rounds interleave the cases, so that load from other processes hits them alike. Besides
    // the wall time on the default pool, the CPU time of a one-thread solve (from the kernel's
    // per-thread accounting, so less sensitive to other processes' load) is recorded.
    for _ in 0..rounds {
        for (ci, &(k, precision)) in cases.iter().enumerate() {
            let opts = SolveOptions::default().with_precision(precision);
            let t = Instant::now();
            let mut x = vec![[0.0; 3]; n];
            let stats = pcg(&a, &b, &mut x, &pcs[k].2, &opts).unwrap();
            best[ci] = best[ci].min(t.elapsed().as_secs_f64() * 1e3);
            results[ci] = Some((stats, x));
            let ms = one.install(|| {
                let c0 = thread_cpu_ms();
                let mut x = vec![[0.0; 3]; n];
                let _ = pcg(&a, &b, &mut x, &pcs[k].2, &opts).unwrap();
                thread_cpu_ms() - c0
            });
            cpu1[ci] = cpu1[ci].min(ms);
        }
    }
    let reference = results[1].clone().expect("ran").1; // Jacobi, f64
    for (ci, &(k, precision)) in cases.iter().enumerate() {
        let (stats, x) = results[ci].as_ref().expect("ran");
        assert!(stats.converged);
        let d: f64 = x.iter().zip(&reference).map(|(u, v)| (u[0] - v[0]).abs()).fold(0.0, f64::max);
        println!(
            "{:?} {precision:?}: iterations {:?}, solve {:.1} ms wall (2 threads), {:.1} ms CPU (1 thread), setup {:.1} ms, residual {:.2e}/{:.2e}/{:.2e}, max |x − x_ref| R = {d:.1e}",
            pcs[k].0, stats.iterations, best[ci], cpu1[ci], pcs[k].1, stats.relative_residual[0], stats.relative_residual[1], stats.relative_residual[2]
        );
    }
    let x = reference;
    // What f32 matrix values would cost in accuracy: the residual that rounding A to f32 alone
    // leaves at the f64 solution, ‖(A − A₃₂) x‖ / ‖b‖.
    let a32 =
        CsrMatrix3::new(Arc::clone(a.pattern()), a.values().iter().map(|v| v.map(|t| f64::from(t as f32))).collect()).unwrap();
    let y64 = a.mul_vec(&x).unwrap();
    let y32 = a32.mul_vec(&x).unwrap();
    let bn = transcut::sparse::norm3(&b);
    let diff: Vec<[f64; 3]> = y64.iter().zip(&y32).map(|(u, v)| [u[0] - v[0], u[1] - v[1], u[2] - v[2]]).collect();
    let dn = transcut::sparse::norm3(&diff);
    println!(
        "f32 matrix values: residual floor {:.1e}/{:.1e}/{:.1e} (vs tolerance 1e-6)",
        dn[0] / bn[0],
        dn[1] / bn[1],
        dn[2] / bn[2]
    );
}
