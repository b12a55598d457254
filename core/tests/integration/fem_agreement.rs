//! The TransCut assembly against the consistent P1 FEM reference on the Stanford bunny: the two
//! agree within 3% RMS with a heterogeneous medium at 500k tets.
//!
//! Setup: the shared bunny scaled to 60 mm across (largest bounding-box extent, as `transcut
//! bench bake`), meshed to about 500k tets (lattice spacing h ≈ 1.0 mm); marble with darker,
//! less scattering veins (Perlin turbulence, 12 mm period; vein σa = (0.06, 0.09, 0.14) mm⁻¹,
//! 20–30× the marble's, σtr h of the vein up to 0.95) sampled per tet; one sun (direction
//! (0, −1, −1), irradiance 3), self-shadowed by the bunny's own surface. Both systems get the
//! same per-vertex source q and are solved to a relative residual of 1e-9.
//!
//! # The measures
//!
//! **Over the whole surface**, with no vertex left out: the relative L2 difference per channel,
//! √(Σ S_i (Lo_TC,i − Lo_FEM,i)² / Σ S_i Lo_FEM,i²) over every boundary vertex (the usual
//! "relative RMS error" of two renderings of one field). Asserted < 3% for both media. Measured
//! at 508k tets: homogeneous (1.46, 1.61, 1.73)%, veins (1.81, 2.04, 2.36)%.
//!
//! **Vertex by vertex**, the stricter measure below, which weighs a dim vertex's relative
//! difference as much as a bright one's:
//!
//! Per channel c, d_i = Lo_TC,i / Lo_FEM,i − 1 with Lo(x, n) of ARCHITECTURE.md, and
//! RMS = √(Σ S_i d_i² / Σ S_i) over a set of boundary vertices, S_i the vertex's boundary area
//! (so the number does not depend on how densely the mesh samples the surface). The bar (3%)
//! is asserted over the **lit interior**: vertices where q_c > 0 at the vertex and at all its
//! boundary neighbours. The one-edge band along shadow edges and the terminator is left out: there
//! the true q jumps (or kinks) inside a triangle, which no P1 load represents; the lumped and the
//! consistent load then differ by O(1) on that band (max |d| 25–60%), a band whose area shrinks
//! with h. RMS over all lit vertices (q_c > 0) and over all vertices are printed too.
//!
//! # Measured (`where_the_difference_comes_from`, run with `--ignored --nocapture`)
//!
//! RMS in % (R, G, B), TransCut vs consistent FEM:
//!
//! | tets (h)        | medium          | lit interior       | all lit (q > 0)    |
//! |-----------------|-----------------|--------------------|--------------------|
//! | 253k (1.27 mm)  | homogeneous     | 1.80, 1.98, 2.15   | 2.81, 3.13, 3.48   |
//! | 508k (1.01 mm)  | homogeneous     | 1.44, 1.61, 1.78   | 2.11, 2.39, 2.69   |
//! | 1.02M (0.80 mm) | homogeneous     | 1.10, 1.24, 1.38   | 1.67, 1.91, 2.17   |
//! | 253k            | veins (this)    | 2.35, 2.72, 3.40   | 3.78, 4.40, 5.28   |
//! | 508k            | veins (this)    | 1.89, 2.21, 2.70   | 2.86, 3.37, 4.04   |
//! | 1.02M           | veins (this)    | 1.46, 1.71, 2.06   | 2.43, 2.91, 3.67   |
//! | 508k            | veins σa ÷ 3    | 1.59, 1.81, 2.00   | 2.33, 2.70, 3.03   |
//!
//! The two discretisations approach each other at about first order in h (the factor per
//! refinement, 0.76–0.81, is close to the ratio of spacings, 0.79), so the reference is not the
//! limit at 500k either: the difference is discretisation error of both. Where it comes from
//! (508k, homogeneous, all lit): TransCut shares the P1 stiffness exactly and differs in three
//! lumped terms. Replacing TransCut's lumped load by the consistent one leaves 1.1–1.8%; also
//! using the consistent boundary mass leaves 0.03–0.12% (the absorption mass, negligible for
//! marble; 0.4–1.6% with the veins' absorption). Lumping only one of the two surface terms is
//! worse than lumping both (3.2–4.6%): TransCut's lumped load and lumped boundary mass partly
//! cancel. q itself varies from vertex to vertex at the lattice scale (it follows the boundary
//! normals of a ~1 mm faceted surface), which is what makes the surface lumping visible.
//!
//! # Not held to the bar
//!
//! With q > 0 as the only condition, the veined marble at 500k is at 2.9/3.4/4.0% (above 3% in
//! green and blue), the milder veins at 3.03% in blue; the band along shadow edges is the
//! difference. Those numbers are printed, and asserted for the homogeneous marble only.

use std::time::Instant;

use transcut::diffusion::{assemble, assemble_consistent, solve, surface_radiance, DiffusionSystem};
use transcut::light::{transmitted_source, Light, SourceOptions};
use transcut::mesh::{TetMesh, TriangleBvh};
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::Medium;
use transcut::sparse::{pcg, CsrMatrix3, Jacobi, Preconditioner, SolveOptions};
use transcut::volume::{TableLayout, TetSampling};
use transcut::DVec3;

use crate::common;
use common::bunny;

/// How far the two radiances are apart, per channel.
#[derive(Debug, Clone, Copy, Default)]
struct Agreement {
    /// Boundary vertices counted.
    vertices: usize,
    /// Area-weighted RMS of Lo_TC/Lo_FEM − 1.
    rms: [f64; 3],
    /// Area-weighted mean of Lo_TC/Lo_FEM − 1 (the systematic part).
    mean: [f64; 3],
    /// Largest |Lo_TC/Lo_FEM − 1|.
    max: [f64; 3],
    /// The relative L2 difference √(Σ S_i (Lo_TC − Lo_FEM)² / Σ S_i Lo_FEM²).
    l2: [f64; 3],
}

impl Agreement {
    /// Over the boundary vertices `k` where `counted(k, c)` holds.
    fn measure(tc: &[[f64; 3]], fem: &[[f64; 3]], area: &[f64], counted: impl Fn(usize, usize) -> bool) -> Self {
        let mut a = Agreement::default();
        for c in 0..3 {
            let (mut w, mut n) = (0.0, 0);
            let (mut diff2, mut ref2) = (0.0, 0.0);
            for k in 0..tc.len() {
                if !counted(k, c) {
                    continue;
                }
                diff2 += area[k] * (tc[k][c] - fem[k][c]).powi(2);
                ref2 += area[k] * fem[k][c].powi(2);
                let d = tc[k][c] / fem[k][c] - 1.0;
                w += area[k];
                n += 1;
                a.rms[c] += area[k] * d * d;
                a.mean[c] += area[k] * d;
                a.max[c] = a.max[c].max(d.abs());
            }
            a.rms[c] = (a.rms[c] / w).sqrt();
            a.l2[c] = (diff2 / ref2).sqrt();
            a.mean[c] /= w;
            a.vertices = a.vertices.max(n);
        }
        a
    }
}

fn percent(v: [f64; 3]) -> String {
    format!("({:.3}%, {:.3}%, {:.3}%)", 100.0 * v[0], 100.0 * v[1], 100.0 * v[2])
}

/// Lo(x, n) at the boundary vertices of `system` lit by `q`, solved tightly.
fn radiance(system: &mut DiffusionSystem, q: &[[f64; 3]]) -> (Vec<[f64; 3]>, [usize; 3]) {
    system.set_source(q).unwrap();
    let options = SolveOptions::default().with_tolerance(1e-9);
    let solution = solve(system, None, &options).unwrap();
    assert!(solution.stats.converged, "{:?}", solution.stats);
    (surface_radiance(system, &solution.phi).unwrap(), solution.stats.iterations)
}

/// Assembles and solves both discretisations of `mesh` with `media`, and returns the agreement
/// on the lit vertices and on all of them.
fn compare(
    name: &str,
    mesh: &TetMesh,
    media: &[Medium],
    mm_per_unit: f64,
    occluder: &TriangleBvh,
) -> (Agreement, Agreement, Agreement) {
    let t = Instant::now();
    let mut tc = assemble(mesh, media, mm_per_unit).unwrap();
    let assembly_tc = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut fem = assemble_consistent(mesh, media, mm_per_unit).unwrap();
    let assembly_fem = t.elapsed().as_secs_f64();
    assert_eq!(tc.boundary(), fem.boundary());

    let sun = Light::Directional { direction: DVec3::new(0.0, -1.0, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
    let b = tc.boundary().clone();
    let points: Vec<DVec3> = b.ids.iter().map(|&v| mesh.positions()[v as usize]).collect();
    let q = transmitted_source(&[sun], &points, &b.normal, media[0].eta, Some(occluder), &SourceOptions::default()).unwrap();

    let t = Instant::now();
    let (lo_tc, it_tc) = radiance(&mut tc, &q);
    let (lo_fem, it_fem) = radiance(&mut fem, &q);
    let solves = t.elapsed().as_secs_f64();
    assert!(lo_fem.iter().flatten().chain(lo_tc.iter().flatten()).all(|x| x.is_finite() && *x > 0.0));

    let ring = ring_lit(mesh, &b.ids, &q);
    let interior = Agreement::measure(&lo_tc, &lo_fem, &b.area_mm2, |k, c| ring[k][c]);
    let lit = Agreement::measure(&lo_tc, &lo_fem, &b.area_mm2, |k, c| q[k][c] > 0.0);
    let all = Agreement::measure(&lo_tc, &lo_fem, &b.area_mm2, |_, _| true);
    eprintln!(
        "{name}: {} boundary vertices, {} lit, {} in the lit interior; assembly TC {assembly_tc:.2} s, FEM {assembly_fem:.2} s; solves {solves:.2} s ({it_tc:?} and {it_fem:?} iterations)",
        b.len(),
        lit.vertices,
        interior.vertices
    );
    eprintln!("  lit interior: RMS {}, mean {}, max {}", percent(interior.rms), percent(interior.mean), percent(interior.max));
    eprintln!("  all lit:      RMS {}, mean {}, max {}", percent(lit.rms), percent(lit.mean), percent(lit.max));
    eprintln!("  all:          RMS {}, mean {}, max {}", percent(all.rms), percent(all.mean), percent(all.max));
    eprintln!("  relative L2 over every boundary vertex: {}", percent(all.l2));
    assert!(interior.vertices > b.len() / 4, "{name}: only {} of {} vertices in the lit interior", interior.vertices, b.len());
    (interior, lit, all)
}

/// Per boundary vertex (in `ids` order) and channel: q > 0 at the vertex and at every vertex
/// it shares a boundary triangle with.
fn ring_lit(mesh: &TetMesh, ids: &[u32], q: &[[f64; 3]]) -> Vec<[bool; 3]> {
    let mut index = vec![u32::MAX; mesh.vertex_count()];
    for (k, &v) in ids.iter().enumerate() {
        index[v as usize] = k as u32;
    }
    let mut lit: Vec<[bool; 3]> = q.iter().map(|x| x.map(|v| v > 0.0)).collect();
    for f in mesh.boundary_faces() {
        let ks = f.vertices.map(|v| index[v as usize] as usize);
        for c in 0..3 {
            let all = ks.iter().all(|&k| q[k][c] > 0.0);
            for &k in &ks {
                lit[k][c] &= all;
            }
        }
    }
    lit
}

#[test]
fn transcut_and_consistent_fem_agree_on_the_bunny_with_marble_veins() {
    let (surface, mm_per_unit) = bunny();
    let t = Instant::now();
    let mut mesh = tetrahedralize(&surface, &MesherOptions::with_tets(500_000)).unwrap();
    eprintln!("bunny: {} tets, {} vertices, meshed in {:.2} s", mesh.tet_count(), mesh.vertex_count(), t.elapsed().as_secs_f64());
    assert!((mesh.tet_count() as f64 / 500_000.0 - 1.0).abs() < 0.1);
    let corners = (0..surface.triangles().len()).map(|t| surface.triangle(t)).collect();
    let occluder = TriangleBvh::new(corners);

    let marble = Medium::preset("marble").unwrap();
    let (homogeneous, homogeneous_lit, homogeneous_all) = compare("homogeneous marble", &mesh, &[marble], mm_per_unit, &occluder);

    let veins = common::veined(marble, mm_per_unit);
    let media = veins.per_tet(&mesh, TetSampling::Centroid).unwrap().apply(&mut mesh, TableLayout::Compact).unwrap();
    // The medium really varies: many distinct media spanning most of the base-to-vein range.
    let blue_a: Vec<f64> = media.iter().map(|m| m.sigma_a[2]).collect();
    let (lo_a, hi_a) = blue_a.iter().fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
    eprintln!("veins: {} media, blue σa in [{lo_a:.4}, {hi_a:.4}] mm⁻¹", media.len());
    assert!(media.len() > 1000 && hi_a > 10.0 * lo_a, "{} media, σa [{lo_a}, {hi_a}]", media.len());
    let (veined, _, veined_all) = compare("marble with veins", &mesh, &media, mm_per_unit, &occluder);

    for c in 0..3 {
        // The field as a whole, no vertex left out: the relative L2 difference.
        assert!(veined_all.l2[c] < 0.03, "veins, channel {c}: relative L2 {}", percent(veined_all.l2));
        assert!(homogeneous_all.l2[c] < 0.03, "homogeneous, channel {c}: relative L2 {}", percent(homogeneous_all.l2));
        assert!(veined.rms[c] < 0.03, "veins, channel {c}: RMS over the lit interior {}", percent(veined.rms));
        assert!(homogeneous.rms[c] < 0.03, "homogeneous, channel {c}: RMS over the lit interior {}", percent(homogeneous.rms));
        assert!(
            homogeneous_lit.rms[c] < 0.03,
            "homogeneous, channel {c}: RMS over all lit vertices {}",
            percent(homogeneous_lit.rms)
        );
    }
}

/// The same agreement on a graded mesh of the same budget (one cube per size; issue 23): the
/// surface layer is finer (h = 0.84 mm against 1.0 mm), the interior up to 16× coarser, and
/// TransCut and the consistent FEM share the mesh, so the difference is again the two
/// discretisations' own. Homogeneous marble, the same sun.
///
/// Measured (546k tets): relative L2 over every boundary vertex (1.13, 1.26, 1.37)%, lit
/// interior RMS (1.19, 1.35, 1.51)%, below the uniform mesh's (1.46, 1.61, 1.73)% and (1.44,
/// 1.61, 1.78)%.
#[test]
fn transcut_and_consistent_fem_agree_on_a_graded_bunny() {
    use transcut::mesher::{tetrahedralize_with, Grading};
    use transcut::Progress;
    let (surface, mm_per_unit) = bunny();
    let options = MesherOptions { grading: Grading::Graded { layers: 1 }, ..MesherOptions::with_tets(500_000) };
    let meshed = tetrahedralize_with(&surface, &options, Progress::none()).unwrap();
    eprintln!("graded bunny: {} tets, surface spacing {:.3} mm", meshed.stats.tets, meshed.stats.spacing * mm_per_unit);
    assert!((meshed.stats.tets as f64 / 500_000.0 - 1.0).abs() < 0.1);
    assert!(meshed.stats.cubes_per_level.iter().skip(2).any(|&n| n > 0), "{:?}: not graded", meshed.stats.cubes_per_level);
    let corners = (0..surface.triangles().len()).map(|t| surface.triangle(t)).collect();
    let occluder = TriangleBvh::new(corners);
    let marble = Medium::preset("marble").unwrap();
    let (interior, _, all) = compare("graded bunny, marble", &meshed.mesh, &[marble], mm_per_unit, &occluder);
    for c in 0..3 {
        assert!(all.l2[c] < 0.03, "channel {c}: relative L2 {}", percent(all.l2));
        assert!(interior.rms[c] < 0.03, "channel {c}: RMS over the lit interior {}", percent(interior.rms));
    }
}

/// Solves `matrix · φ = b` tightly (Jacobi PCG).
fn solve_raw(matrix: &CsrMatrix3, b: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut phi = vec![[0.0; 3]; matrix.n()];
    let stats = pcg(
        matrix,
        b,
        &mut phi,
        &Preconditioner::Jacobi(Jacobi::new(matrix).unwrap()),
        &SolveOptions::default().with_tolerance(1e-9),
    )
    .unwrap();
    assert!(stats.converged);
    phi
}

/// Where the TransCut/FEM difference comes from, on `mesh` with `media` lit by `q`: the four
/// combinations of matrix (TransCut, TransCut with the consistent boundary mass, consistent FEM)
/// and load (lumped, consistent), each against the full consistent FEM; RMS over the lit
/// vertices and over the lit interior (see the module documentation).
fn diagnose(name: &str, mesh: &TetMesh, media: &[Medium], mm_per_unit: f64, q: &[[f64; 3]]) {
    let mut tc = assemble(mesh, media, mm_per_unit).unwrap();
    let mut fem = assemble_consistent(mesh, media, mm_per_unit).unwrap();
    tc.set_source(q).unwrap();
    fem.set_source(q).unwrap();
    let pattern = tc.pattern().clone();
    assert!(pattern.row_ptr() == fem.pattern().row_ptr() && pattern.col_idx() == fem.pattern().col_idx());
    // TransCut with the consistent boundary mass: per boundary face of area a (mm²), the
    // diagonal loses a/(3A) (2a/(3A) lumped → a/(3A)) and each edge gains a/(6A).
    let a = tc.boundary_terms().a;
    let mut hybrid = tc.matrix().clone();
    let mm2 = mm_per_unit * mm_per_unit;
    for f in mesh.boundary_faces() {
        let [i, j, k] = f.vertices.map(|v| v as usize);
        let p = mesh.positions();
        let area = 0.5 * (p[j] - p[i]).cross(p[k] - p[i]).length() * mm2;
        for (r, s) in [(i, j), (j, k), (k, i)] {
            for (x, y) in [(r, s), (s, r)] {
                hybrid.add_to(x, y, [area / (6.0 * a); 3]).unwrap();
            }
        }
        for r in [i, j, k] {
            hybrid.add_to(r, r, [-area / (3.0 * a); 3]).unwrap();
        }
    }
    let reference = surface_radiance(&fem, &solve_raw(fem.matrix(), fem.rhs())).unwrap();
    let b = tc.boundary().clone();
    let ring = ring_lit(mesh, &b.ids, q);
    for (label, matrix, load) in [
        ("TC matrix, lumped load", tc.matrix(), tc.rhs()),
        ("TC matrix, consistent load", tc.matrix(), fem.rhs()),
        ("TC + consistent boundary mass, consistent load", &hybrid, fem.rhs()),
        ("TC + consistent boundary mass, lumped load", &hybrid, tc.rhs()),
        ("FEM matrix, lumped load", fem.matrix(), tc.rhs()),
    ] {
        let lo = surface_radiance(&tc, &solve_raw(matrix, load)).unwrap();
        let lit = Agreement::measure(&lo, &reference, &b.area_mm2, |k, c| q[k][c] > 0.0);
        let inner = Agreement::measure(&lo, &reference, &b.area_mm2, |k, c| ring[k][c]);
        let all = Agreement::measure(&lo, &reference, &b.area_mm2, |_, _| true);
        eprintln!(
            "{name} | {label} vs FEM: all lit RMS {} (max {}); lit interior RMS {} ({} vertices); all RMS {} mean {}",
            percent(lit.rms),
            percent(lit.max),
            percent(inner.rms),
            inner.vertices,
            percent(all.rms),
            percent(all.mean)
        );
    }
}

/// Not a check: the numbers behind the module documentation (run with `--ignored
/// --nocapture`). Splits the difference into load, boundary mass and absorption mass, at 250k,
/// 500k and 1M tets, for the veined and the homogeneous marble.
#[test]
#[ignore = "diagnosis, minutes; run by hand"]
fn where_the_difference_comes_from() {
    let (surface, mm_per_unit) = bunny();
    let corners = (0..surface.triangles().len()).map(|t| surface.triangle(t)).collect();
    let occluder = TriangleBvh::new(corners);
    let marble = Medium::preset("marble").unwrap();
    let sizes: Vec<usize> = std::env::var("FEM_SIZES")
        .map_or(vec![250_000, 500_000, 1_000_000], |s| s.split(',').map(|x| x.parse().unwrap()).collect());
    for tets in sizes {
        let mut mesh = tetrahedralize(&surface, &MesherOptions::with_tets(tets)).unwrap();
        let h = (12.0 * mesh.volume() / mesh.tet_count() as f64).cbrt() * mm_per_unit;
        eprintln!("--- {} tets, lattice spacing {h:.3} mm", mesh.tet_count());
        let sun = Light::Directional { direction: DVec3::new(0.0, -1.0, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
        let probe = assemble(&mesh, &[marble], mm_per_unit).unwrap();
        let b = probe.boundary();
        let points: Vec<DVec3> = b.ids.iter().map(|&v| mesh.positions()[v as usize]).collect();
        let q = transmitted_source(&[sun], &points, &b.normal, marble.eta, Some(&occluder), &SourceOptions::default()).unwrap();
        diagnose("homogeneous", &mesh, &[marble], mm_per_unit, &q);
        for (label, vein) in [
            ("veins σa (0.06, 0.09, 0.14)", Medium { sigma_a: [0.06, 0.09, 0.14], sigma_s_prime: [1.5, 1.8, 2.0], ..marble }),
            ("veins σa (0.02, 0.03, 0.04)", Medium { sigma_a: [0.02, 0.03, 0.04], sigma_s_prime: [1.5, 1.8, 2.0], ..marble }),
        ] {
            let veins = common::veined_with(marble, vein, mm_per_unit);
            let media = veins.per_tet(&mesh, TetSampling::Centroid).unwrap().apply(&mut mesh, TableLayout::Compact).unwrap();
            let tr = vein.sigma_tr();
            eprintln!("{label}: σtr h of the vein medium {:.2?}", tr.map(|t| t * h));
            diagnose(label, &mesh, &media, mm_per_unit, &q);
        }
    }
}
