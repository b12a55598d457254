//! The radiosity stage against closed forms (design/radiosity.md §3 and §7, checks A1–A3, A5):
//! form factors of squares and discs with and without a blocker, reciprocity and closed rows,
//! and the inside of a closed sphere, where every kernel is 1/(4πR²).

use glam::DVec3;
use transcut::mesh::icosphere;
use transcut::radiosity::analytic::{coaxial_discs, parallel_rectangles, perpendicular_rectangles, point_to_disc};
use transcut::radiosity::{
    solve, solve_coupled, FormFactorOptions, FormFactors, Iteration, Opaque, PatchSet, RadiosityError, SolveOptions, Surface,
};

/// A mesh: positions and counter-clockwise triangles.
type Mesh = (Vec<DVec3>, Vec<[u32; 3]>);

/// An n × n grid over the rectangle corner + s·u + t·v (s, t ∈ [0, 1]), facing u × v (or
/// the other way when `flip`).
fn grid(corner: DVec3, u: DVec3, v: DVec3, n: u32, flip: bool) -> Mesh {
    let p = (0..=n).flat_map(|j| (0..=n).map(move |i| corner + u * (i as f64 / n as f64) + v * (j as f64 / n as f64))).collect();
    let mut t = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 2, a + n + 1);
            if flip {
                t.extend([[a, c, b], [a, d, c]]);
            } else {
                t.extend([[a, b, c], [a, c, d]]);
            }
        }
    }
    (p, t)
}

/// A disc of radius `r` at height `z`: `rings` rings of 6k vertices about the centre, facing +z
/// (or −z when `down`).
fn disc(r: f64, z: f64, rings: u32, down: bool) -> Mesh {
    let mut p = vec![DVec3::new(0.0, 0.0, z)];
    let (mut start, mut len) = (vec![0u32], vec![1u32]);
    for ring in 1..=rings {
        start.push(p.len() as u32);
        len.push(6 * ring);
        let radius = r * f64::from(ring) / f64::from(rings);
        for k in 0..6 * ring {
            let phi = std::f64::consts::TAU * f64::from(k) / f64::from(6 * ring);
            p.push(DVec3::new(radius * phi.cos(), radius * phi.sin(), z));
        }
    }
    let mut t = Vec::new();
    for ring in 1..=rings as usize {
        let (so, no, si, ni) = (start[ring], len[ring], start[ring - 1], len[ring - 1]);
        let outer = |k: u32| so + k % no;
        let inner = |k: u32| si + k % ni;
        // Walk both rings counter-clockwise, advancing the one whose next vertex comes first.
        let (mut a, mut b) = (0u32, 0u32);
        while a < no || (ring > 1 && b < ni) {
            let outer_first =
                ring == 1 || b >= ni || (a < no && f64::from(a + 1) / f64::from(no) <= f64::from(b + 1) / f64::from(ni));
            let tri = if outer_first {
                a += 1;
                [inner(b), outer(a - 1), outer(a)]
            } else {
                b += 1;
                [inner(b - 1), outer(a), inner(b)]
            };
            t.push(if down { [tri[0], tri[2], tri[1]] } else { tri });
        }
    }
    (p, t)
}

/// F from the surfaces `from` (all of it) to `to`, Σᵢ Aᵢ Σ_{j ∈ to} F_ij / Σᵢ Aᵢ, with
/// `total_rays` cast from `from` in all.
fn surface_factor(meshes: &[(&Mesh, bool)], from: usize, to: usize, total_rays: usize) -> f64 {
    let surfaces: Vec<Surface> =
        meshes.iter().map(|(m, two_sided)| Surface { positions: &m.0, triangles: &m.1, two_sided: *two_sided }).collect();
    let patches = PatchSet::new(&surfaces).unwrap();
    let emitters: Vec<usize> = (0..patches.len()).filter(|&i| patches.surface_of(i) == from && !patches.is_back(i)).collect();
    let rays = (total_rays / emitters.len()).max(1);
    let f = FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: rays, ..Default::default() }, &|| true).unwrap();
    let a = patches.areas();
    let area: f64 = emitters.iter().map(|&i| a[i]).sum();
    let flux: f64 = emitters
        .iter()
        .map(|&i| a[i] * f.row(i).filter(|&(j, _)| patches.surface_of(j) == to).map(|(_, v)| v).sum::<f64>())
        .sum();
    flux / area
}

/// A1: every closed form within 1% at 2¹⁶ rays; the blocked disc 0.300 ± 0.005.
#[test]
fn form_factors_match_the_closed_forms() {
    const RAYS: usize = 1 << 16;
    for c in [1.0, 0.5, 2.0] {
        let a = grid(DVec3::ZERO, DVec3::X, DVec3::Y, 12, false);
        let b = grid(DVec3::new(0.0, 0.0, c), DVec3::X, DVec3::Y, 12, true);
        let got = surface_factor(&[(&a, false), (&b, false)], 0, 1, RAYS);
        let want = parallel_rectangles(1.0, 1.0, c);
        assert!((got - want).abs() <= 0.01 * want, "parallel squares at {c}: {got} against {want}");
    }
    for h in [1.0, 2.0] {
        // The emitter in z = 0 (x, y ∈ [0, 1]), the receiver in y = 0 up to z = h, facing +y.
        let a = grid(DVec3::ZERO, DVec3::X, DVec3::Y, 12, false);
        let b = grid(DVec3::ZERO, DVec3::X, DVec3::new(0.0, 0.0, h), 12, true);
        let got = surface_factor(&[(&a, false), (&b, false)], 0, 1, RAYS);
        let want = perpendicular_rectangles(1.0, 1.0, h);
        assert!((got - want).abs() <= 0.01 * want, "perpendicular squares, h = {h}: {got} against {want}");
    }
    for h in [1.0, 0.5] {
        let a = disc(1.0, 0.0, 8, false);
        let b = disc(1.0, h, 8, true);
        let got = surface_factor(&[(&a, false), (&b, false)], 0, 1, RAYS);
        let want = coaxial_discs(1.0, 1.0, h);
        assert!((got - want).abs() <= 0.01 * want, "coaxial discs at {h}: {got} against {want}");
    }
    // A small square (a differential area) under a disc of radius 1 at height 1, with a
    // two-sided blocker of radius 0.25 at height 0.5 between them.
    let point = grid(DVec3::new(-5e-4, -5e-4, 0.0), DVec3::X * 1e-3, DVec3::Y * 1e-3, 1, false);
    let target = disc(1.0, 1.0, 8, true);
    let blocker = disc(0.25, 0.5, 8, true);
    let got = surface_factor(&[(&point, false), (&target, false), (&blocker, true)], 0, 1, RAYS);
    let want = point_to_disc(1.0, 1.0) - point_to_disc(0.25, 0.5);
    assert!((got - 0.3).abs() <= 0.005 && (want - 0.3).abs() < 1e-12, "the blocked disc: {got}");
}

/// The inside of a sphere, its triangles facing the centre.
fn inner_sphere(radius: f64, subdivisions: u32) -> Mesh {
    let m = icosphere(radius, subdivisions);
    (m.positions().to_vec(), m.triangles().iter().map(|t| [t[0], t[2], t[1]]).collect())
}

/// A2: reciprocity to rounding, every row ≤ 1, and in a closed scene every row 1 (to the f32
/// rounding of the stored factors).
#[test]
fn factors_are_reciprocal_and_closed_rows_sum_to_one() {
    let sphere = inner_sphere(10.0, 3);
    let patches = PatchSet::new(&[Surface { positions: &sphere.0, triangles: &sphere.1, two_sided: false }]).unwrap();
    let f = FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 128, ..Default::default() }, &|| true).unwrap();
    let a = patches.areas();
    for i in 0..f.len() {
        for (j, v) in f.row(i) {
            let (x, y) = (a[i] * v, a[j] * f.get(j, i));
            assert!((x - y).abs() <= 1e-12 * x.abs().max(y.abs()), "A{i}F{i},{j} = {x}, A{j}F{j},{i} = {y}");
        }
        // Balanced to 1, then each factor rounded down to f32 (relative 2⁻²³ at most).
        let deficit = 1.0 - f.row_sum(i);
        assert!((-1e-12..=2f64.powi(-23)).contains(&deficit), "row {i} of a closed sphere sums to {}", f.row_sum(i));
    }
    // Every kernel is 1/(4πR²): a patch sees each half of the sphere as half of its light.
    let upper: Vec<bool> = patches.positions().iter().map(|p| p.z > 0.0).collect();
    let share: Vec<f64> = (0..f.len()).map(|i| f.row(i).filter(|&(j, _)| upper[j]).map(|(_, v)| v).sum::<f64>()).collect();
    let half: f64 = (0..f.len()).filter(|&j| upper[j]).map(|j| a[j]).sum::<f64>() / a.iter().sum::<f64>();
    let mean = share.iter().sum::<f64>() / share.len() as f64;
    let worst = share.iter().map(|s| (s - half).abs()).fold(0.0, f64::max);
    // The mean to 1%; each row within 4.5σ of 128 plain Monte Carlo rays (σ = √(¼/128) = 0.044).
    assert!((mean - half).abs() < 0.01 * half && worst < 0.2, "the upper half's share: mean {mean}, worst {worst}, want {half}");
}

/// A3 and A5: a point light inside a closed diffuse sphere. Every kernel being 1/(4πR²), the
/// radiosity is B(x) = ρE_d(x) + ρ²Ē/(1 − ρ), Ē = I/R² the mean irradiance; within 2% per
/// vertex and 0.3% in the mean, in the sweeps the contraction predicts, with the energy
/// balanced to 10× the tolerance.
#[test]
fn a_closed_sphere_with_a_point_light_has_the_closed_form() {
    let radius = 10.0;
    let sphere = inner_sphere(radius, 4);
    let patches = PatchSet::new(&[Surface { positions: &sphere.0, triangles: &sphere.1, two_sided: false }]).unwrap();
    let f = FormFactors::gather(&patches, &FormFactorOptions::default(), &|| true).unwrap();
    let (intensity, light) = (100.0, DVec3::new(2.0, -3.0, 1.5));
    let direct: Vec<[f64; 3]> = patches
        .positions()
        .iter()
        .zip(patches.normals())
        .map(|(&x, &n)| {
            let d = light - x;
            [intensity * n.dot(d).max(0.0) / d.length().powi(3); 3]
        })
        .collect();
    let areas = patches.areas();
    // The discrete mean irradiance: the light's power over the mesh's area, as the closed form
    // has it for the sphere (the mesh is inscribed, so its own mean is what its patches get).
    let mean = areas.iter().zip(&direct).map(|(a, e)| a * e[0]).sum::<f64>() / areas.iter().sum::<f64>();
    assert!((mean - intensity / (radius * radius)).abs() < 0.01 * mean, "mean irradiance {mean}");
    for (rho, iteration) in [
        (0.5, Iteration::Jacobi),
        (0.9, Iteration::Jacobi),
        (0.9, Iteration::GaussSeidel),
        (0.5, Iteration::BiCgStab),
        (0.9, Iteration::BiCgStab),
    ] {
        let options = SolveOptions { iteration, tolerance: 1e-3, max_iterations: 500, bounces: None };
        let albedo = vec![[rho; 3]; patches.len()];
        let zero = vec![[0.0; 3]; patches.len()];
        let s = solve(&f, areas, &albedo, &direct, &zero, &options, &|| true).unwrap();
        let (mut worst, mut sum, mut sum_want) = (0.0f64, 0.0, 0.0);
        for (i, b) in s.radiosity.iter().enumerate() {
            let want = rho * direct[i][0] + rho * rho * mean / (1.0 - rho);
            worst = worst.max((b[0] - want).abs() / want);
            sum += areas[i] * b[0];
            sum_want += areas[i] * want;
        }
        assert!(worst <= 0.02, "ρ = {rho}, {iteration:?}: {worst} off at worst");
        assert!((sum - sum_want).abs() <= 0.003 * sum_want, "ρ = {rho}, {iteration:?}: mean {sum} against {sum_want}");
        let predicted = 1.2 * (1e-3f64).ln() / rho.ln();
        if iteration == Iteration::Jacobi {
            assert!(s.iterations as f64 <= predicted, "ρ = {rho}: {} sweeps, the rate predicts {predicted:.0}", s.iterations);
        }
        // Every kernel the same: K is nearly of rank one, which a Krylov method resolves at once.
        if iteration == Iteration::BiCgStab {
            assert!(s.iterations <= 4, "ρ = {rho}: BiCGSTAB took {} iterations", s.iterations);
            assert!(s.estimated_error <= options.tolerance, "ρ = {rho}: the bound {} is above the tolerance", s.estimated_error);
        }
        assert!(s.energy.defect() <= 10.0 * options.tolerance, "ρ = {rho}: energy defect {}", s.energy.defect());
        // Nothing escapes but the f32 rounding of the rows (each at most 2⁻²³ below 1) lets out.
        let leak = 2f64.powi(-23) * sum + 1e-12 * s.energy.direct[0];
        assert!(s.energy.escaped[0].abs() <= leak, "light escaped a closed sphere: {} > {leak}", s.energy.escaped[0]);
    }
}

/// Bad input: albedo ≥ 1 or NaN, negative emission, wrong lengths: named, nothing solved.
#[test]
fn bad_values_are_named() {
    let sphere = inner_sphere(10.0, 1);
    let patches = PatchSet::new(&[Surface { positions: &sphere.0, triangles: &sphere.1, two_sided: false }]).unwrap();
    let f = FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 16, ..Default::default() }, &|| true).unwrap();
    let n = patches.len();
    let ok = vec![[0.5; 3]; n];
    let mut bad = ok.clone();
    bad[3] = [0.5, 1.0, 0.5];
    let o = SolveOptions::default();
    let e = solve(&f, patches.areas(), &bad, &ok, &ok, &o, &|| true).unwrap_err().to_string();
    assert!(e.contains("albedo of patch 3"), "{e}");
    bad[3] = [f64::NAN, 0.5, 0.5];
    assert!(solve(&f, patches.areas(), &bad, &ok, &ok, &o, &|| true).is_err());
    let mut emission = ok.clone();
    emission[7] = [0.0, -1.0, 0.0];
    let e = solve(&f, patches.areas(), &ok, &ok, &emission, &o, &|| true).unwrap_err().to_string();
    assert!(e.contains("emission of patch 7"), "{e}");
    let e = solve(&f, patches.areas(), &ok[1..], &ok, &ok, &o, &|| true).unwrap_err().to_string();
    assert!(e.contains("albedo: expected"), "{e}");
    assert!(solve(&f, patches.areas(), &ok, &ok, &ok, &o, &|| false).is_err());
    // A warm start of the wrong length, not finite, or with a count of bounces.
    let opaque = Opaque { albedo: &ok, direct: &ok, emission: &ok };
    let warm = |initial: &[[f64; 3]], options: &SolveOptions| {
        solve_coupled::<RadiosityError>(&f, patches.areas(), &opaque, &mut [], Some(initial), options, &|| true)
            .unwrap_err()
            .to_string()
    };
    assert!(warm(&ok[1..], &o).contains("initial radiosity: expected"), "{}", warm(&ok[1..], &o));
    let mut nan = ok.clone();
    nan[5] = [0.0, f64::INFINITY, 0.0];
    assert!(warm(&nan, &o).contains("initial radiosity of patch 5"), "{}", warm(&nan, &o));
    assert!(warm(&ok, &SolveOptions { bounces: Some(2), ..o }).contains("bounces"));
}

/// A warm start from the solution of a nearby problem reaches the same answer in fewer sweeps
/// (the closed sphere at ρ = 0.9, its light 10% brighter).
#[test]
fn a_warm_start_converges_to_the_same_answer_sooner() {
    let sphere = inner_sphere(10.0, 3);
    let patches = PatchSet::new(&[Surface { positions: &sphere.0, triangles: &sphere.1, two_sided: false }]).unwrap();
    let f = FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 128, ..Default::default() }, &|| true).unwrap();
    let n = patches.len();
    let direct = |scale: f64| -> Vec<[f64; 3]> {
        patches
            .positions()
            .iter()
            .zip(patches.normals())
            .map(|(&x, &nrm)| [scale * (nrm.dot(-x) / x.length()).max(0.0); 3])
            .collect()
    };
    let (albedo, zero) = (vec![[0.9; 3]; n], vec![[0.0; 3]; n]);
    let options = SolveOptions { tolerance: 1e-8, max_iterations: 1000, ..SolveOptions::default() };
    let (before, after) = (direct(1.0), direct(1.1));
    let old = solve(&f, patches.areas(), &albedo, &before, &zero, &options, &|| true).unwrap();
    let cold = solve(&f, patches.areas(), &albedo, &after, &zero, &options, &|| true).unwrap();
    let opaque = Opaque { albedo: &albedo, direct: &after, emission: &zero };
    let warm =
        solve_coupled::<RadiosityError>(&f, patches.areas(), &opaque, &mut [], Some(&old.radiosity), &options, &|| true).unwrap();
    let worst = warm.radiosity.iter().zip(&cold.radiosity).map(|(w, c)| (w[0] - c[0]).abs() / c[0]).fold(0.0, f64::max);
    assert!(worst < 1e-6, "warm and cold differ by {worst}");
    assert!(warm.iterations < cold.iterations, "warm {} sweeps, cold {}", warm.iterations, cold.iterations);
}
