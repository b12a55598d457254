//! The device relaxation (`gpu::GpuRelaxation`, `relax_jacobi.wgsl`, `relax_gs.wgsl`) and the
//! hierarchy transfers (`gpu::GpuTransfer`, `gpu::prolong_add`, `gpu::restrict` on an operator
//! from `Prolongation::from_csr`) against their CPU twins (`sparse::relax`, `Prolongation`):
//! after 2–3 and after 50 sweeps of each scheme the device result is within 1e-5 (relative, max
//! norm per channel) of the CPU's, on a 7-point lattice system of 4096 rows (SPD and non-symmetric) and
//! on an irregular non-symmetric pattern; frozen rows keep their value bit for bit; a
//! coarse-to-fine pass that never leaves the device equals the CPU's, also on the polygrid
//! hierarchy of the paper's own (unsymmetric) stencil with its trilinear transfers.
//!
//! Like `gpu.rs`, these tests need a GPU adapter (scripts/test.sh installs Mesa's lavapipe);
//! without one they FAIL with a message, and `TRANSCUT_GPU_TESTS=skip` skips them, loudly.
#![cfg(feature = "gpu")]
#![allow(clippy::needless_range_loop)] // per-channel loops read clearer with indices

use std::sync::Arc;

use crate::gpu_common;
use gpu_common::{device, lock};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use transcut::diffusion::DiffusionError;
use transcut::gpu::{self, GpuError, GpuRelaxation, GpuTransfer};
use transcut::sparse::hierarchy::Prolongation;
use transcut::sparse::relax::{coloured_gauss_seidel_sweep, jacobi_sweep, Colouring};
use transcut::sparse::{CsrMatrix3, CsrPattern, SparseError, Triplet};

const SWEEPS: usize = 50;
const TOLERANCE: f64 = 1e-5;

/// The vertex `(x, y, z)` of an `n³` lattice.
fn id(n: usize, x: usize, y: usize, z: usize) -> u32 {
    (x + n * (y + n * z)) as u32
}

/// The edges of an `n³` lattice's 7-point stencil, lower vertex first.
fn lattice_edges(n: usize) -> Vec<[u32; 2]> {
    let mut edges = Vec::new();
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let i = id(n, x, y, z);
                if x + 1 < n {
                    edges.push([i, id(n, x + 1, y, z)]);
                }
                if y + 1 < n {
                    edges.push([i, id(n, x, y + 1, z)]);
                }
                if z + 1 < n {
                    edges.push([i, id(n, x, y, z + 1)]);
                }
            }
        }
    }
    edges
}

/// Red-black: the parity of `x + y + z`.
fn parity(n: usize) -> Vec<u32> {
    (0..n * n * n).map(|i| ((i % n + (i / n) % n + i / (n * n)) % 2) as u32).collect()
}

/// The 7-point diffusion matrix of an `n³` lattice with a mass term; with `drift` the
/// couplings are upwinded (`−w (1 ± γ)` for the lower/upper vertex of an edge, non-symmetric),
/// the diagonal `Σ_j |a_ij| + mass` either way.
fn lattice(n: usize, drift: bool, rng: &mut ChaCha8Rng) -> CsrMatrix3 {
    let edges = lattice_edges(n);
    let pattern = Arc::new(CsrPattern::from_edges(n * n * n, &edges).unwrap());
    let gamma = if drift { [0.4, -0.3, 0.6] } else { [0.0; 3] };
    let mut t = Vec::new();
    for &[i, j] in &edges {
        let w: f64 = rng.random_range(1.0..3.0);
        let k = [w, 0.7 * w, 1.3 * w];
        let lo = [0, 1, 2].map(|c| -k[c] * (1.0 + gamma[c]));
        let hi = [0, 1, 2].map(|c| -k[c] * (1.0 - gamma[c]));
        t.extend([
            Triplet::new(i, j, lo),
            Triplet::new(j, i, hi),
            Triplet::new(i, i, lo.map(f64::abs)),
            Triplet::new(j, j, hi.map(f64::abs)),
        ]);
    }
    t.extend((0..(n * n * n) as u32).map(|i| Triplet::new(i, i, [0.3, 0.8, 2.0])));
    CsrMatrix3::from_triplets_with_pattern(pattern, &t).unwrap()
}

/// A non-symmetric matrix on an irregular, non-symmetric pattern of `n` rows (1–6 random
/// off-diagonal entries per row), strictly diagonally dominant by 20%, channel 1's diagonal
/// negative.
fn irregular(n: usize, rng: &mut ChaCha8Rng) -> CsrMatrix3 {
    let mut t = Vec::new();
    let mut entries = Vec::new();
    for i in 0..n as u32 {
        let mut sum = [0.0; 3];
        for _ in 0..rng.random_range(1..=6) {
            let j = rng.random_range(0..n as u32);
            if j != i {
                let v: [f64; 3] = [0, 1, 2].map(|_| rng.random_range(-1.0..0.5));
                for c in 0..3 {
                    sum[c] += v[c].abs();
                }
                entries.push([i, j]);
                t.push(Triplet::new(i, j, v));
            }
        }
        t.push(Triplet::new(i, i, [1.2 * sum[0] + 0.1, -(1.2 * sum[1] + 0.1), 1.2 * sum[2] + 0.1]));
    }
    let pattern = Arc::new(CsrPattern::from_entries(n, &entries).unwrap());
    assert!(!pattern.is_structurally_symmetric());
    CsrMatrix3::from_triplets_with_pattern(pattern, &t).unwrap()
}

fn random_vector(rng: &mut ChaCha8Rng, n: usize) -> Vec<[f64; 3]> {
    (0..n).map(|_| [rng.random_range(-1.0..1.0), rng.random_range(0.0..2.0), rng.random_range(-3.0..1.0)]).collect()
}

/// `max_i |a_i − b_i| / max_i |b_i|` per channel.
fn rel_max(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    [0, 1, 2].map(|c| {
        let num = a.iter().zip(b).map(|(x, y)| (x[c] - y[c]).abs()).fold(0.0, f64::max);
        num / b.iter().map(|y| y[c].abs()).fold(0.0, f64::max)
    })
}

fn assert_close(what: &str, gpu: &[[f64; 3]], cpu: &[[f64; 3]]) {
    let e = rel_max(gpu, cpu);
    eprintln!("{what}: device vs CPU, relative max difference {:.2e} {:.2e} {:.2e}", e[0], e[1], e[2]);
    assert!(e.iter().all(|&e| e < TOLERANCE), "{what}: {e:?}");
}

/// The three test systems: (name, matrix, colouring).
fn systems(rng: &mut ChaCha8Rng) -> Vec<(&'static str, CsrMatrix3, Colouring)> {
    let n = 16;
    let spd = lattice(n, false, rng);
    let drift = lattice(n, true, rng);
    let irr = irregular(3000, rng);
    let rb = |a: &CsrMatrix3| Colouring::from_colours(a.pattern(), parity(n)).unwrap();
    let (c_spd, c_drift, c_irr) = (rb(&spd), rb(&drift), Colouring::greedy(irr.pattern()));
    vec![("SPD lattice 16³", spd, c_spd), ("drift lattice 16³", drift, c_drift), ("irregular 3000", irr, c_irr)]
}

#[test]
fn jacobi_sweeps_equal_the_cpu_sweeps() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for (name, a, _) in systems(&mut rng) {
        let b = random_vector(&mut rng, a.n());
        let x0 = random_vector(&mut rng, a.n());
        for omega in [2.0 / 3.0, 1.0] {
            // After 3 sweeps (far from converged) and after SWEEPS.
            for sweeps in [3, SWEEPS] {
                let mut cpu = x0.clone();
                let mut out = vec![[0.0; 3]; a.n()];
                for _ in 0..sweeps {
                    jacobi_sweep(&a, &b, &cpu, &mut out, omega, None).unwrap();
                    std::mem::swap(&mut cpu, &mut out);
                }
                let mut dev = GpuRelaxation::new(ctx, &a, &b, &x0).unwrap();
                // Two calls (an odd count first), so the ping-pong buffers swap across calls.
                let updates = dev.jacobi(1, omega).unwrap() + dev.jacobi(sweeps - 1, omega).unwrap();
                assert_eq!(updates, sweeps * a.n());
                assert_close(&format!("{name}, {sweeps} Jacobi sweeps ω = {omega:.3}"), &dev.solution().unwrap(), &cpu);
                // The sweeps moved x well beyond the tolerance: the comparison means something.
                assert!(rel_max(&cpu, &x0).iter().all(|&e| e > 1e-2));
            }
        }
    }
}

#[test]
fn gauss_seidel_sweeps_equal_the_cpu_sweeps() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for (name, a, colouring) in systems(&mut rng) {
        let b = random_vector(&mut rng, a.n());
        let x0 = random_vector(&mut rng, a.n());
        for (symmetric, sweeps) in [false, true].into_iter().flat_map(|s| [(s, 2), (s, SWEEPS)]) {
            let mut cpu = x0.clone();
            let mut cpu_updates = 0;
            for _ in 0..sweeps {
                cpu_updates += coloured_gauss_seidel_sweep(&a, &b, &mut cpu, &colouring, None, symmetric).unwrap();
            }
            let mut dev = GpuRelaxation::new(ctx, &a, &b, &x0).unwrap();
            dev.set_colouring(&colouring).unwrap();
            let updates = dev.gauss_seidel(sweeps, symmetric).unwrap();
            assert_eq!(updates, cpu_updates);
            assert_close(
                &format!("{name}, {sweeps} Gauss–Seidel sweeps ({} colours, symmetric {symmetric})", colouring.count()),
                &dev.solution().unwrap(),
                &cpu,
            );
            assert!(rel_max(&cpu, &x0).iter().all(|&e| e > 1e-2));
        }
    }
}

#[test]
fn frozen_rows_keep_their_value_on_the_device() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for (name, a, colouring) in systems(&mut rng) {
        let n = a.n();
        let b = random_vector(&mut rng, n);
        let x0 = random_vector(&mut rng, n);
        let active: Vec<bool> = (0..n).map(|_| rng.random_range(0.0..1.0) < 0.8).collect();
        let frozen = active.iter().filter(|&&f| !f).count();
        let f32_bits = |v: [f64; 3]| v.map(|x| (x as f32).to_bits());
        let check = |what: &str, dev: &[[f64; 3]], cpu: &[[f64; 3]]| {
            for i in (0..n).filter(|&i| !active[i]) {
                assert_eq!(f32_bits(dev[i]), f32_bits(x0[i]), "{name}, {what}: frozen row {i}");
            }
            assert_close(&format!("{name}, {what} with {frozen} frozen rows"), dev, cpu);
        };
        // Jacobi, an odd number of sweeps: the frozen rows are copied between the buffers.
        let (mut cpu, mut out) = (x0.clone(), vec![[0.0; 3]; n]);
        for _ in 0..SWEEPS + 1 {
            jacobi_sweep(&a, &b, &cpu, &mut out, 0.8, Some(&active)).unwrap();
            std::mem::swap(&mut cpu, &mut out);
        }
        let mut dev = GpuRelaxation::new(ctx, &a, &b, &x0).unwrap();
        dev.set_active(Some(&active)).unwrap();
        assert_eq!(dev.active_rows(), n - frozen);
        assert_eq!(dev.jacobi(SWEEPS + 1, 0.8).unwrap(), (SWEEPS + 1) * (n - frozen));
        check("Jacobi", &dev.solution().unwrap(), &cpu);
        // Gauss–Seidel, the mask set before and after the colouring.
        let mut cpu = x0.clone();
        let mut cpu_updates = 0;
        for _ in 0..SWEEPS {
            cpu_updates += coloured_gauss_seidel_sweep(&a, &b, &mut cpu, &colouring, Some(&active), true).unwrap();
        }
        for mask_first in [true, false] {
            let mut dev = GpuRelaxation::new(ctx, &a, &b, &x0).unwrap();
            if mask_first {
                dev.set_active(Some(&active)).unwrap();
                dev.set_colouring(&colouring).unwrap();
            } else {
                dev.set_colouring(&colouring).unwrap();
                dev.set_active(Some(&active)).unwrap();
            }
            assert_eq!(dev.gauss_seidel(SWEEPS, true).unwrap(), cpu_updates);
            check("symmetric Gauss–Seidel", &dev.solution().unwrap(), &cpu);
        }
        // Unfrozen again, every row moves.
        dev.set_active(None).unwrap();
        dev.set_solution(&x0).unwrap();
        dev.jacobi(1, 1.0).unwrap();
        let moved = dev.solution().unwrap();
        assert!((0..n).all(|i| f32_bits(moved[i]) != f32_bits(x0[i])), "{name}");
    }
}

/// Trilinear interpolation from an `m³` lattice (spacing 2) to the `(2m − 1)³` lattice (spacing
/// 1) as a general operator: weights 1, ½, ¼, ⅛.
fn trilinear(m: usize) -> Prolongation {
    let f = 2 * m - 1;
    let (mut row_ptr, mut cols, mut weights) = (vec![0], Vec::new(), Vec::new());
    for z in 0..f {
        for y in 0..f {
            for x in 0..f {
                let axis = |v: usize| if v.is_multiple_of(2) { vec![(v / 2, 1.0)] } else { vec![(v / 2, 0.5), (v / 2 + 1, 0.5)] };
                for &(cz, wz) in &axis(z) {
                    for &(cy, wy) in &axis(y) {
                        for &(cx, wx) in &axis(x) {
                            cols.push(id(m, cx, cy, cz));
                            weights.push(wx * wy * wz);
                        }
                    }
                }
                row_ptr.push(cols.len());
            }
        }
    }
    Prolongation::from_csr(m * m * m, row_ptr, cols, weights).unwrap()
}

/// A random `n_fine × n_coarse` operator: 0–4 entries per row (a column may repeat), weights
/// of either sign; and the same with the weights' magnitudes.
fn random_operator(rng: &mut ChaCha8Rng, n_fine: usize, n_coarse: usize) -> (Prolongation, Prolongation) {
    let (mut row_ptr, mut cols, mut weights) = (vec![0], Vec::new(), Vec::new());
    for _ in 0..n_fine {
        for _ in 0..rng.random_range(0..=4) {
            cols.push(rng.random_range(0..n_coarse as u32));
            weights.push(rng.random_range(-1.0..1.0));
        }
        row_ptr.push(cols.len());
    }
    let magnitudes = weights.iter().map(|w: &f64| w.abs()).collect();
    (
        Prolongation::from_csr(n_coarse, row_ptr.clone(), cols.clone(), weights).unwrap(),
        Prolongation::from_csr(n_coarse, row_ptr, cols, magnitudes).unwrap(),
    )
}

/// Each entry's difference over `Σ |w| |x|` of its sum (f32 rounding), the worst.
fn worst_against_bound(gpu: &[[f64; 3]], cpu: &[[f64; 3]], bound: &[[f64; 3]]) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..cpu.len() {
        for c in 0..3 {
            worst = worst.max((gpu[i][c] - cpu[i][c]).abs() / bound[i][c].max(1e-300));
        }
    }
    worst
}

#[test]
fn transfers_equal_the_cpu_operators() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    let abs = |v: &[[f64; 3]]| v.iter().map(|x| x.map(f64::abs)).collect::<Vec<_>>();
    let random = random_operator(&mut rng, 2500, 700);
    for (name, p, p_abs) in [("trilinear 8³ → 15³", trilinear(8), trilinear(8)), ("random 2500 × 700", random.0, random.1)] {
        let (nf, nc) = (p.n_fine(), p.n_coarse());
        let fine = random_vector(&mut rng, nf);
        let coarse = random_vector(&mut rng, nc);
        // CPU twins and the bounds of their rounding, |P| |x|.
        let mut cpu_p = fine.clone();
        p.prolong_add(&coarse, &mut cpu_p);
        let mut bound_p = abs(&fine);
        p_abs.prolong_add(&abs(&coarse), &mut bound_p);
        let mut cpu_r = vec![[0.0; 3]; nc];
        p.restrict(&fine, &mut cpu_r);
        let mut bound_r = vec![[0.0; 3]; nc];
        p_abs.restrict(&abs(&fine), &mut bound_r);
        // One transfer on its own.
        let one_p = gpu::prolong_add(ctx, &p, &coarse, &fine).unwrap();
        let one_r = gpu::restrict(ctx, &p, &fine).unwrap();
        // Between two systems on the device (identity matrices: only their vectors matter).
        let t = GpuTransfer::upload(ctx, &p).unwrap();
        assert_eq!((t.n_fine(), t.n_coarse()), (nf, nc));
        let mut f = GpuRelaxation::new(ctx, &identity(nf), &fine, &fine).unwrap();
        let mut c = GpuRelaxation::new(ctx, &identity(nc), &vec![[0.0; 3]; nc], &coarse).unwrap();
        f.prolong_add_from(&c, &t).unwrap();
        c.restrict_rhs_from(&f, &t).unwrap();
        let dev_p = f.solution().unwrap();
        let dev_r = c.rhs().unwrap();
        for (what, g, cpu, bound) in [
            ("prolong_add", &one_p, &cpu_p, &bound_p),
            ("restrict", &one_r, &cpu_r, &bound_r),
            ("GpuRelaxation::prolong_add_from", &dev_p, &cpu_p, &bound_p),
            ("GpuRelaxation::restrict_rhs_from", &dev_r, &cpu_r, &bound_r),
        ] {
            let worst = worst_against_bound(g, cpu, bound);
            eprintln!("{name}: {what}: worst difference {worst:.2e} of Σ|w||x|");
            assert!(worst < 1e-6, "{name}: {what}: {worst:e}");
        }
        // Sizes are checked.
        let wrong = GpuRelaxation::new(ctx, &identity(nc + 1), &vec![[0.0; 3]; nc + 1], &vec![[0.0; 3]; nc + 1]).unwrap();
        let e = f.prolong_add_from(&wrong, &t).unwrap_err();
        assert!(
            matches!(e, GpuError::Diffusion(DiffusionError::LengthMismatch { expected, found, .. }) if expected == nc && found == nc + 1),
            "{e}"
        );
    }
}

/// The `n × n` identity.
fn identity(n: usize) -> CsrMatrix3 {
    let pattern = Arc::new(CsrPattern::from_edges(n, &[]).unwrap());
    let t: Vec<_> = (0..n as u32).map(|i| Triplet::new(i, i, [1.0; 3])).collect();
    CsrMatrix3::from_triplets_with_pattern(pattern, &t).unwrap()
}

#[test]
fn a_coarse_to_fine_pass_on_the_device_equals_the_cpu_pass() {
    // Coarse 8³ lattice: b_c = Pᵀ b_f, 50 red-black sweeps from zero; the fine 15³ lattice
    // starts from P x_c and takes 50 more. On the device nothing is read back in between.
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let p = trilinear(8);
    let coarse = lattice(8, true, &mut rng);
    let fine = lattice(15, true, &mut rng);
    let b_fine = random_vector(&mut rng, fine.n());
    let (rb_c, rb_f) = (
        Colouring::from_colours(coarse.pattern(), parity(8)).unwrap(),
        Colouring::from_colours(fine.pattern(), parity(15)).unwrap(),
    );
    // CPU.
    let mut b_c = vec![[0.0; 3]; coarse.n()];
    p.restrict(&b_fine, &mut b_c);
    let mut x_c = vec![[0.0; 3]; coarse.n()];
    for _ in 0..SWEEPS {
        coloured_gauss_seidel_sweep(&coarse, &b_c, &mut x_c, &rb_c, None, false).unwrap();
    }
    let mut x_f = vec![[0.0; 3]; fine.n()];
    p.prolong_add(&x_c, &mut x_f);
    for _ in 0..SWEEPS {
        coloured_gauss_seidel_sweep(&fine, &b_fine, &mut x_f, &rb_f, None, false).unwrap();
    }
    // Device.
    let t = GpuTransfer::upload(ctx, &p).unwrap();
    let mut f = GpuRelaxation::new(ctx, &fine, &b_fine, &vec![[0.0; 3]; fine.n()]).unwrap();
    f.set_colouring(&rb_f).unwrap();
    let mut c = GpuRelaxation::new(ctx, &coarse, &vec![[0.0; 3]; coarse.n()], &vec![[0.0; 3]; coarse.n()]).unwrap();
    c.set_colouring(&rb_c).unwrap();
    c.restrict_rhs_from(&f, &t).unwrap();
    c.gauss_seidel(SWEEPS, false).unwrap();
    f.prolong_add_from(&c, &t).unwrap();
    f.gauss_seidel(SWEEPS, false).unwrap();
    assert_close("coarse level", &c.solution().unwrap(), &x_c);
    assert_close("fine level after the coarse-to-fine pass", &f.solution().unwrap(), &x_f);
}

#[test]
fn device_errors_are_the_cpu_errors() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let n = 6;
    let mut a = lattice(n, false, &mut rng);
    let rows = a.n();
    let b = vec![[1.0; 3]; rows];
    let len = |e: GpuError| match e {
        GpuError::Diffusion(DiffusionError::LengthMismatch { expected, found, .. }) => (expected, found),
        other => panic!("{other}"),
    };
    assert_eq!(len(GpuRelaxation::new(ctx, &a, &b[1..], &b).unwrap_err()), (rows, rows - 1));
    assert_eq!(len(GpuRelaxation::new(ctx, &a, &b, &b[2..]).unwrap_err()), (rows, rows - 2));
    let mut dev = GpuRelaxation::new(ctx, &a, &b, &b).unwrap();
    assert_eq!(len(dev.set_active(Some(&[true; 3])).unwrap_err()), (rows, 3));
    assert_eq!(len(dev.set_solution(&b[1..]).unwrap_err()), (rows, rows - 1));
    assert_eq!(len(dev.set_rhs(&b[1..]).unwrap_err()), (rows, rows - 1));
    assert!(matches!(dev.gauss_seidel(1, false), Err(GpuError::Unsupported { .. })));
    for omega in [0.0, -1.0, f64::NAN] {
        assert!(matches!(dev.jacobi(1, omega), Err(GpuError::Diffusion(DiffusionError::Sparse(SparseError::InvalidOption(_))))));
    }
    // A colouring that couples two rows of one colour here.
    let diagonal = Arc::new(CsrPattern::from_edges(rows, &[]).unwrap());
    let lone = Colouring::from_colours(&diagonal, vec![0; rows]).unwrap();
    let e = dev.set_colouring(&lone).unwrap_err();
    assert!(
        matches!(e, GpuError::Diffusion(DiffusionError::Sparse(SparseError::ColouringConflict { row: 0, col: 1, colour: 0 }))),
        "{e}"
    );
    // A zero diagonal: refused while its row is active, as on the CPU.
    let d = a.pattern().diagonal_positions()[10];
    a.values_mut()[d][2] = 0.0;
    let mut dev = GpuRelaxation::new(ctx, &a, &b, &b).unwrap();
    dev.set_colouring(&Colouring::greedy(a.pattern())).unwrap();
    for e in [dev.jacobi(1, 1.0).unwrap_err(), dev.gauss_seidel(1, true).unwrap_err()] {
        assert!(
            matches!(e, GpuError::Diffusion(DiffusionError::Sparse(SparseError::UnusableDiagonal { row: 10, channel: 2, .. }))),
            "{e}"
        );
    }
    let active: Vec<bool> = (0..rows).map(|i| i != 10).collect();
    dev.set_active(Some(&active)).unwrap();
    dev.jacobi(3, 1.0).unwrap();
    dev.gauss_seidel(3, true).unwrap();
    assert!(dev.solution().unwrap().iter().flatten().all(|v| v.is_finite()));
    // A diagonal f32 cannot hold.
    a.values_mut()[d][2] = 1e-60;
    let mut dev = GpuRelaxation::new(ctx, &a, &b, &b).unwrap();
    assert!(matches!(dev.jacobi(1, 1.0), Err(GpuError::Unsupported { .. })));
}

/// The paper's own stencil (App. B: unsymmetric rows, P1's weights where its fit gives no
/// Laplacian) relaxes on the device as on the CPU, through the polygrid hierarchy's own levels,
/// colourings and trilinear transfers: Jacobi (ω = 1, the paper's GPU update) on the finest
/// level, and the coarse-to-fine cascade of Gauss–Seidel sweeps against the hierarchy's solve.
#[test]
fn the_papers_stencil_relaxes_on_the_device_as_on_the_cpu() {
    use transcut::optics::Medium;
    use transcut::polygrid::{cubed_sphere, RelaxHierarchy, RelaxOptions, RelaxState, Start, Stencil};
    use transcut::DVec3;
    let _g = lock();
    let Some(ctx) = device() else { return };
    let grid = cubed_sphere(16, DVec3::ZERO, 40.0).unwrap();
    let marble = Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3, 0.0).unwrap();
    let mut h = RelaxHierarchy::new(&grid, &vec![marble; grid.cells().len()], 1.0, Stencil::PaperLsq, 3).unwrap();
    let l = DVec3::new(0.3, 0.5, 1.0).normalize();
    let q: Vec<[f64; 3]> = h.boundary_normals().iter().map(|n| [0.98299 * n.dot(l).max(0.0); 3]).collect();
    h.set_source(&q).unwrap();
    // The rows are not symmetric: some a_ij differs from a_ji.
    let (rp, ci, v) = (h.matrix(0).pattern().row_ptr(), h.matrix(0).pattern().col_idx(), h.matrix(0).values());
    let entry = |i: usize, j: u32| ci[rp[i]..rp[i + 1]].binary_search(&j).ok().map(|k| v[rp[i] + k][0]);
    let unsymmetric = (0..h.node_count(0))
        .flat_map(|i| ci[rp[i]..rp[i + 1]].iter().map(move |&j| (i, j)))
        .filter(|&(i, j)| entry(j as usize, i as u32).is_none_or(|aji| (aji - entry(i, j).unwrap()).abs() > 1e-9 * aji.abs()))
        .count();
    assert!(unsymmetric > 0, "the paper's matrix is expected unsymmetric");

    // Jacobi on the finest level.
    let (a, b) = (h.matrix(0), h.rhs(0));
    let zero = vec![[0.0; 3]; a.n()];
    let (mut x, mut out) = (zero.clone(), zero.clone());
    for _ in 0..SWEEPS {
        jacobi_sweep(a, b, &x, &mut out, 1.0, None).unwrap();
        std::mem::swap(&mut x, &mut out);
    }
    let mut dev = GpuRelaxation::new(ctx, a, b, &zero).unwrap();
    dev.jacobi(SWEEPS, 1.0).unwrap();
    assert_close("paper stencil, Jacobi", &dev.solution().unwrap(), &x);

    // The cascade, coarsest level first, nothing read back between the levels.
    let options = RelaxOptions::default().with_tolerance(1e-300).with_coarse_tolerance(1e-300).with_max_sweeps(SWEEPS);
    let mut state = RelaxState::new(&h);
    h.solve(&mut state, Start::Cold, &options, None).unwrap();
    let mut coarser: Option<GpuRelaxation> = None;
    for level in (0..h.level_count()).rev() {
        let mut dev = GpuRelaxation::new(ctx, h.matrix(level), h.rhs(level), &vec![[0.0; 3]; h.node_count(level)]).unwrap();
        dev.set_colouring(h.colouring(level)).unwrap();
        if let Some(c) = &coarser {
            let p = h.prolongation(level);
            let (row_ptr, cols, weights) = p.csr();
            let p = Prolongation::from_csr(p.coarse_count(), row_ptr.to_vec(), cols.to_vec(), weights.to_vec()).unwrap();
            dev.prolong_add_from(c, &GpuTransfer::upload(ctx, &p).unwrap()).unwrap();
        }
        dev.gauss_seidel(SWEEPS, false).unwrap();
        assert_close(&format!("paper stencil, cascade level {level}"), &dev.solution().unwrap(), state.level_solution(level));
        coarser = Some(dev);
    }
}
