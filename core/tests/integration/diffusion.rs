//! The TransCut diffusion solver (`transcut::diffusion`) on tetrahedralised spheres, against the
//! closed form of the uniformly lit sphere (ARCHITECTURE.md, "Validation that needs no other
//! program"; `optics::UniformSphere`).
//!
//! # Set-up
//!
//! A UV sphere of radius R = 20 (256 × 128 segments, so its faceting, at most 1.5e-3 mm deep, is
//! far below the tet error) is filled by the isosurface-stuffing mesher; mm_per_unit = 1. Every
//! boundary vertex gets the same transmitted source q = π(1 − F_ext(η)) (a constant environment of
//! radiance 1). Errors are relative, per channel, at the boundary vertices: the maximum over them,
//! and the area-weighted RMS (weights S_i/3).
//!
//! # Reference radius
//!
//! The reference is φ(R) with the sphere's radius R = 20, **without correction**: the tet
//! boundary is a polyhedron inscribed in the sphere (0.13% less volume at 200k tets), but the
//! surface fluence depends on the radius only through (x coth x − 1)/R, x = σtr R, so using the
//! radius of the sphere of equal volume instead changes the reference by less than 1e-4
//! (asserted in `uniform_sphere_matches_the_closed_form_for_every_preset`). The boundary vertices
//! lie on the boundary where the condition is imposed, so they are compared with φ(R), not φ(|x|).
//!
//! # Resolution
//!
//! The discretisation error at the surface is, to leading order, C (σtr h)² with h the lattice
//! spacing (interior tets have volume h³/12) and C ≈ 0.01–0.04 for the RMS, about 2.5× that for
//! the maximum; the radiance error is the fluence error times the amplification φ/(φ − 2q) of
//! eq. 3 (1.3 for marble, 2.7 for chicken, > 10 for ketchup). At 200k tets on this sphere
//! h ≈ 1.25 mm, which resolves the diffuse mean free path ℓd = 1/σtr of the marble- and milk-like
//! channels but not that of skin, chicken, potato (blue), apple (blue), jade (red) or ketchup
//! (ℓd down to 0.4 mm). So the < 1% bound is asserted on every channel whose predicted radiance
//! error amp · (σtr h)² · 0.075 is below 1.1% (`amp · (σtr h)² ≤ 0.15`), and every other channel
//! is checked against the second-order error model. Ketchup's green and blue channels have an
//! albedo below 0.1: there the diffusion approximation predicts φ(R) < 2q, i.e. a negative
//! exitant radiance, and only φ is compared.

#![allow(clippy::needless_range_loop)] // per-channel loops read best indexed

use std::sync::{Mutex, OnceLock};
use std::time::Instant;

use transcut::diffusion::{
    assemble, assemble_consistent, assemble_fitted, energy_balance, solve, surface_fluence, surface_radiance, DiffusionSystem,
    Discretization,
};
use transcut::mesh::{TetMesh, TriMesh};
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::{f_ext, radiance_from_fluence, Medium, UniformSphere, PRESET_NAMES};
use transcut::sparse::SolveOptions;
use transcut::DVec3;

/// Sphere radius (scene units = mm).
const RADIUS: f64 = 20.0;

use crate::common;
use common::uv_sphere;

/// The sphere meshed with about `tets` tets, built once per size for the whole test binary.
fn sphere_mesh(tets: usize) -> &'static TetMesh {
    static SURFACE: OnceLock<TriMesh> = OnceLock::new();
    static MESHES: Mutex<Vec<(usize, &'static TetMesh)>> = Mutex::new(Vec::new());
    let surface = SURFACE.get_or_init(|| uv_sphere(RADIUS, 256, 128));
    let mut meshes = MESHES.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(&(_, m)) = meshes.iter().find(|(n, _)| *n == tets) {
        return m;
    }
    let mesh: &'static TetMesh = Box::leak(Box::new(tetrahedralize(surface, &MesherOptions::with_tets(tets)).unwrap()));
    meshes.push((tets, mesh));
    mesh
}

/// Lattice spacing of a stuffed mesh from its volume and tet count (interior tets: h³/12).
fn spacing(mesh: &TetMesh) -> f64 {
    (12.0 * mesh.volume() / mesh.tet_count() as f64).cbrt()
}

/// q = π(1 − F_ext(η)): what a constant environment of radiance 1 transmits.
fn uniform_q(m: &Medium) -> f64 {
    std::f64::consts::PI * (1.0 - f_ext(m.eta))
}

/// Assembled (TransCut or consistent FEM), lit uniformly and solved with the default options.
fn solved(mesh: &TetMesh, m: Medium, consistent: bool) -> (DiffusionSystem, Vec<[f64; 3]>) {
    solved_with(mesh, m, if consistent { assemble_consistent } else { assemble })
}

/// An assembly of the library's: TransCut's, the consistent FEM or the fitted variant.
type Assembler = fn(&TetMesh, &[Medium], f64) -> Result<DiffusionSystem, transcut::diffusion::DiffusionError>;

/// The fitted rows with the boundary layer's absorption (`Discretization::FittedLayer`).
fn assemble_fitted_layer(
    mesh: &TetMesh,
    media: &[Medium],
    mm_per_unit: f64,
) -> Result<DiffusionSystem, transcut::diffusion::DiffusionError> {
    DiffusionSystem::new(mesh, media, mm_per_unit, Discretization::FittedLayer)
}

/// Assembled by `assembler`, lit uniformly and solved with the default options.
fn solved_with(mesh: &TetMesh, m: Medium, assembler: Assembler) -> (DiffusionSystem, Vec<[f64; 3]>) {
    let mut sys = assembler(mesh, &[m], 1.0).unwrap();
    sys.set_source(&vec![[uniform_q(&m); 3]; sys.boundary().len()]).unwrap();
    let sol = solve(&sys, None, &SolveOptions::default()).unwrap();
    (sys, sol.phi)
}

/// Three numbers in exponent notation.
fn exp3(v: [f64; 3]) -> String {
    format!("({:.2e}, {:.2e}, {:.2e})", v[0], v[1], v[2])
}

/// Relative errors at the boundary vertices, per channel.
#[derive(Debug, Clone, Copy)]
struct SurfaceErrors {
    /// Max over boundary vertices of |φ_i/φ(R) − 1|.
    phi_max: [f64; 3],
    /// Area-weighted RMS of φ_i/φ(R) − 1.
    phi_rms: [f64; 3],
    /// Area-weighted mean of φ_i/φ(R) − 1 (the systematic part).
    phi_mean: [f64; 3],
    /// The same for Lo(x, n) against the closed form.
    lo_max: [f64; 3],
    lo_rms: [f64; 3],
}

fn surface_errors(sys: &DiffusionSystem, phi: &[[f64; 3]], sphere: &UniformSphere) -> SurfaceErrors {
    let phis = surface_fluence(sys, phi).unwrap();
    let lo = surface_radiance(sys, phi).unwrap();
    let (exact, exact_lo) = (sphere.surface_fluence(), sphere.surface_radiance(1.0));
    let b = sys.boundary();
    let area: f64 = b.area_mm2.iter().sum();
    let mut e = SurfaceErrors { phi_max: [0.0; 3], phi_rms: [0.0; 3], phi_mean: [0.0; 3], lo_max: [0.0; 3], lo_rms: [0.0; 3] };
    for k in 0..b.len() {
        let w = b.area_mm2[k] / area;
        for c in 0..3 {
            let ep = phis[k][c] / exact[c] - 1.0;
            let el = lo[k][c] / exact_lo[c] - 1.0;
            e.phi_max[c] = e.phi_max[c].max(ep.abs());
            e.phi_rms[c] += w * ep * ep;
            e.phi_mean[c] += w * ep;
            e.lo_max[c] = e.lo_max[c].max(el.abs());
            e.lo_rms[c] += w * el * el;
        }
    }
    for c in 0..3 {
        e.phi_rms[c] = e.phi_rms[c].sqrt();
        e.lo_rms[c] = e.lo_rms[c].sqrt();
    }
    e
}

/// Every preset at about 200k tets: the < 1% bound on φ and Lo (max over the boundary vertices)
/// for every channel the mesh resolves (see the module documentation), the second-order error
/// model RMS ≤ 0.06 (σtr h)² (· amp for Lo) for the others.
///
/// Measured (TransCut, h = 1.25 mm), resolved channels: the largest errors are marble blue
/// (σtr h = 0.32) with φ 0.48% / Lo 0.63% and skin2 red (0.26) with φ 0.35% / Lo 0.54%;
/// unresolved: e.g. skin1 blue (σtr h = 1.84) φ RMS 11.6%, chicken1 blue Lo RMS 7.4%, ketchup
/// blue φ RMS 27%.
#[test]
fn uniform_sphere_matches_the_closed_form_for_every_preset() {
    let mesh = sphere_mesh(200_000);
    assert!(mesh.tet_count() >= 200_000 * 9 / 10, "{} tets", mesh.tet_count());
    let h = spacing(mesh);
    let r_eff = (3.0 * mesh.volume() / (4.0 * std::f64::consts::PI)).cbrt();
    eprintln!("{} tets, {} vertices, h = {h:.4} mm, equal-volume radius {r_eff:.4}", mesh.tet_count(), mesh.vertex_count());
    let mut resolved = 0;
    for name in PRESET_NAMES {
        let m = Medium::preset(name).unwrap();
        let q = uniform_q(&m);
        let sphere = UniformSphere::new(m, RADIUS, [q; 3]).unwrap();
        // The volume correction is negligible (module documentation).
        let corrected = UniformSphere::new(m, r_eff, [q; 3]).unwrap().surface_fluence();
        for c in 0..3 {
            assert!((corrected[c] / sphere.surface_fluence()[c] - 1.0).abs() < 1e-4, "{name}");
        }
        let t = Instant::now();
        let (sys, phi) = solved(mesh, m, false);
        let elapsed = t.elapsed().as_secs_f64();
        let e = surface_errors(&sys, &phi, &sphere);
        let tr = m.sigma_tr();
        let exact = sphere.surface_fluence();
        for c in 0..3 {
            let x2 = (tr[c] * h).powi(2);
            let amp = exact[c] / (exact[c] - 2.0 * q); // Lo error / φ error
            eprintln!(
                "{name:9} ch{c} σtr·h {:.3} amp {amp:6.2}: φ max {:.2e} rms {:.2e} | Lo max {:.2e} rms {:.2e} ({elapsed:.2} s)",
                tr[c] * h,
                e.phi_max[c],
                e.phi_rms[c],
                e.lo_max[c],
                e.lo_rms[c]
            );
            if amp > 0.0 && amp * x2 <= 0.15 {
                resolved += 1;
                assert!(e.phi_max[c] < 0.01, "{name} channel {c}: φ error {:.3e}", e.phi_max[c]);
                assert!(e.lo_max[c] < 0.01, "{name} channel {c}: Lo error {:.3e}", e.lo_max[c]);
            } else {
                assert!(e.phi_rms[c] <= 0.06 * x2, "{name} channel {c}: φ RMS {:.3e}, (σtr h)² {x2:.3}", e.phi_rms[c]);
                if amp > 0.0 {
                    assert!(e.lo_rms[c] <= 0.06 * amp * x2, "{name} channel {c}: Lo RMS {:.3e}", e.lo_rms[c]);
                }
            }
        }
    }
    assert!(resolved >= 15, "only {resolved} resolved channels");
}

/// Refinement 25k → 50k → 100k → 200k tets, marble (σtr h from 0.30 to 0.15 in red, 0.64 to
/// 0.32 in blue), order = log(e₁/e₂)/log(h₁/h₂), h ∝ tets^(−1/3).
///
/// The systematic error (area-weighted mean of φ_i/φ(R) − 1) converges at second order in the
/// green and blue channels (measured orders 1.91, 1.98, 1.94 and 1.87, 1.93, 1.90; red's
/// systematic error is below 7e-5 throughout and not used). The pointwise error (RMS over the
/// boundary vertices) is dominated by the irregular boundary layer of the stuffed mesh, whose
/// configurations change from one lattice spacing to the next; its order rises from 1.5 to 1.8
/// over these refinements (1.8 from 200k to 400k): asserted ≥ 1.4.
#[test]
fn transcut_converges_at_second_order() {
    let m = Medium::preset("marble").unwrap();
    let sphere = UniformSphere::new(m, RADIUS, [uniform_q(&m); 3]).unwrap();
    let mut levels = Vec::new();
    for n in [25_000, 50_000, 100_000, 200_000] {
        let mesh = sphere_mesh(n);
        let (sys, phi) = solved(mesh, m, false);
        levels.push(((mesh.tet_count() as f64).powf(-1.0 / 3.0), surface_errors(&sys, &phi, &sphere)));
    }
    for w in levels.windows(2) {
        let ((h1, e1), (h2, e2)) = (w[0], w[1]);
        let order = |a: f64, b: f64| (a / b).ln() / (h1 / h2).ln();
        let mean = [1, 2].map(|c| order(e1.phi_mean[c].abs(), e2.phi_mean[c].abs()));
        let rms = [0, 1, 2].map(|c| order(e1.phi_rms[c], e2.phi_rms[c]));
        eprintln!(
            "h ratio {:.4}: mean errors {} -> {}, orders (G, B) {mean:.3?}; RMS {} -> {}, orders {rms:.3?}",
            h1 / h2,
            exp3(e1.phi_mean),
            exp3(e2.phi_mean),
            exp3(e1.phi_rms),
            exp3(e2.phi_rms)
        );
        for o in mean {
            assert!((1.7..=2.3).contains(&o), "order {o}");
        }
        for o in rms {
            assert!(o >= 1.4, "RMS order {o}");
        }
        for c in 1..3 {
            assert!(e1.phi_mean[c] < 0.0 && e2.phi_mean[c] < 0.0, "a systematic under-estimate");
        }
    }
    let fine = levels[3].1;
    eprintln!("200k: φ mean {}, RMS {}, max {}", exp3(fine.phi_mean), exp3(fine.phi_rms), exp3(fine.phi_max));
}

/// TransCut (lumped masses) against the consistent P1 FEM on the same meshes: they differ by
/// the mass lumping, O(h²). Measured max |φ_TC/φ_FEM − 1| over the boundary, marble (R, G, B):
/// (2.1e-4, 6.7e-4, 1.7e-3) at 100k and (1.2e-4, 3.5e-4, 8.9e-4) at 200k tets (Lo: 1.2e-3 at
/// most); skin2 blue (σtr h = 1.15, unresolved) 3.8% at 200k. Asserted: at most 0.05 (σtr h)²
/// everywhere, below 0.5% for marble, and shrinking by more than 1.3× per doubling.
#[test]
fn transcut_and_consistent_fem_agree() {
    let mut previous: Option<[f64; 3]> = None;
    for n in [100_000, 200_000] {
        let mesh = sphere_mesh(n);
        for name in ["marble", "skin2"] {
            let m = Medium::preset(name).unwrap();
            let (tc, phi_tc) = solved(mesh, m, false);
            let (fem, phi_fem) = solved(mesh, m, true);
            let (a, b) = (surface_fluence(&tc, &phi_tc).unwrap(), surface_fluence(&fem, &phi_fem).unwrap());
            let (la, lb) = (surface_radiance(&tc, &phi_tc).unwrap(), surface_radiance(&fem, &phi_fem).unwrap());
            let mut diff = [0.0f64; 3];
            let mut diff_lo = [0.0f64; 3];
            for k in 0..a.len() {
                for c in 0..3 {
                    diff[c] = diff[c].max((a[k][c] / b[k][c] - 1.0).abs());
                    diff_lo[c] = diff_lo[c].max((la[k][c] / lb[k][c] - 1.0).abs());
                }
            }
            eprintln!("{n} {name}: max |φ_TC/φ_FEM − 1| {}, Lo {}", exp3(diff), exp3(diff_lo));
            let tr = m.sigma_tr();
            let h = spacing(mesh);
            for c in 0..3 {
                // Both are within about 0.04 (σtr h)² of the closed form (RMS).
                assert!(diff[c] <= 0.05 * (tr[c] * h).powi(2), "{name} channel {c}: {diff:?}");
            }
            if name == "marble" {
                for c in 0..3 {
                    assert!(diff[c] < 5e-3 && diff_lo[c] < 5e-3, "{diff:?} {diff_lo:?}");
                }
                if let Some(p) = previous {
                    for c in 0..3 {
                        // Second order: 2^(2/3) = 1.59 per doubling of the tet count.
                        assert!(p[c] / diff[c] > 1.3, "{p:?} -> {diff:?}");
                    }
                }
                previous = Some(diff);
            }
        }
    }
}

/// M is symmetric (to 1e-12 of its largest entry; the assembly makes it exactly symmetric) and
/// positive definite (a dense Cholesky factorisation succeeds), also with two materials and
/// with the stuffed mesh's obtuse dihedral angles, which make some off-diagonal entries
/// positive (so M is not an M-matrix and positive definiteness does not come from diagonal
/// dominance).
#[test]
fn matrix_is_symmetric_positive_definite() {
    let mut mesh = sphere_mesh(3_000).clone();
    // Two materials with the same η: the lower half of the sphere is skin, the upper marble.
    let marble = Medium::preset("marble").unwrap();
    let skin = Medium { eta: marble.eta, ..Medium::preset("skin1").unwrap() };
    let materials =
        (0..mesh.tet_count()).map(|t| u32::from(mesh.tet_positions(t).iter().map(|p| p.z).sum::<f64>() < 0.0)).collect();
    mesh.set_materials(materials).unwrap();
    for (consistent, assembler) in
        [(false, assemble as Assembler), (true, assemble_consistent), (false, assemble_fitted), (false, assemble_fitted_layer)]
    {
        let sys = assembler(&mesh, &[marble, skin], 1.0).unwrap();
        let m = sys.matrix();
        let largest = m.values().iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(m.is_symmetric(1e-12 * largest));
        let positive_off_diagonal = (0..m.n())
            .flat_map(|i| m.pattern().row(i).iter().map(move |&j| (i, j as usize)))
            .filter(|&(i, j)| i != j && m.get(i, j).unwrap()[0] > 0.0)
            .count();
        if !consistent {
            assert!(positive_off_diagonal > 0, "expected obtuse angles in a stuffed mesh");
        }
        for c in 0..3 {
            let dense = m.to_dense(c);
            assert!(dense.clone().cholesky().is_some(), "channel {c} is not positive definite");
            assert!((&dense - dense.transpose()).amax() <= 1e-12 * largest);
        }
    }
}

/// Energy balance: absorbed + exitant = transmitted incident power.
///
/// Integrating the diffusion equation over Ω: ∫ μφ dV = ∫_∂Ω κ∇φ·n dS, and the boundary
/// condition φ + 2Aκ∇φ·n = Q, Q = 4q/(1 − Fdr), turns the right side into ∫ (Q − φ)/(2A) dS:
/// what is absorbed is the net flux entering through the surface. The exitance (power leaving
/// per area) is the hemispherical integral of eq. 3, ∫ Lo cos θo dωo =
/// [(1 + 1/A)φ − 4q/(1 + Fdr)]/(4π) · ∫ Ft cos θo dωo; with ∫ Ft cos θo dωo = π(1 − Fdr) and
/// 1 + 1/A = 2/(1 + Fdr) it is (φ − 2q)/(2A). Adding: absorbed + exitant =
/// ∫ (Q − 2q)/(2A) dS = ∫ q dS, because (4/(1 − Fdr) − 2)/(2A) = 1.
///
/// Discretely the same identity holds exactly (to the solver tolerance): the sum of the rows of
/// M φ = b (4 × the weak form tested with 1) cancels the stiffness, the lumped absorption rows
/// sum to Σ_t μ_t V_t φ̄_t = ∫ μ φ_h for piecewise-linear φ_h, and the boundary rows to
/// (1/(2A)) ∫ φ_h dS and (1/(2A)) ∫ Q dS. Checked here to 1e-5, independently of the library's
/// `energy_balance`, and with the exitance integrated numerically from the radiance query
/// (`radiance_from_fluence` over the hemisphere, Ft = T(η, θo)/η² exactly), where
/// ∫ Ft cos θo dωo = π(1 − F_ext)/η² differs from π(1 − Fdr) only by the Egan–Hilgeman fit of
/// Fdr (measured: discrete defect below 2e-7, with the integrated query below 9e-4; asserted
/// 1e-5 and 1%).
#[test]
fn energy_balance_holds() {
    let mesh = sphere_mesh(50_000);
    for (name, assembler, fitted) in [
        ("marble", assemble as Assembler, false),
        ("skin1", assemble, false),
        ("jade", assemble, false),
        ("skin1", assemble_fitted, false),
        ("skin1", assemble_fitted_layer, true),
    ] {
        let m = Medium::preset(name).unwrap();
        let (sys, phi) = solved_with(mesh, m, assembler);
        let q = uniform_q(&m);
        let t = *sys.boundary_terms();
        // Absorbed, with the lumped mass: Σ_i φ_i Σ_{t ∋ i} V_t μ / 4.
        let mut lumped = vec![0.0; mesh.vertex_count()];
        for tet in 0..mesh.tet_count() {
            for &v in &mesh.tets()[tet] {
                lumped[v as usize] += mesh.tet_volume(tet) / 4.0;
            }
        }
        let lumped_absorbed = [0, 1, 2].map(|c| (0..phi.len()).map(|i| lumped[i] * m.sigma_a[c] * phi[i][c]).sum::<f64>());
        // The fitted scheme's boundary rows absorb by the layer's profile instead: its
        // absorption is the rows' sums less the Robin term 2S_i/(3A) (the stiffness rows sum to
        // zero; M is 4 × the weak form), S_i from the mesh's boundary areas.
        let absorbed = if fitted {
            let mut robin = vec![0.0; mesh.vertex_count()];
            for (f, face) in mesh.boundary_faces().iter().enumerate() {
                for &v in &face.vertices {
                    robin[v as usize] += 2.0 * mesh.boundary_area(f) / (3.0 * t.a);
                }
            }
            let matrix = sys.matrix();
            let (row_ptr, values) = (matrix.pattern().row_ptr(), matrix.values());
            [0, 1, 2].map(|c| {
                (0..phi.len())
                    .map(|i| phi[i][c] * (values[row_ptr[i]..row_ptr[i + 1]].iter().map(|v| v[c]).sum::<f64>() - robin[i]) / 4.0)
                    .sum::<f64>()
            })
        } else {
            lumped_absorbed
        };
        // Surface integrals of piecewise-linear functions over the boundary triangles.
        let mut phi_integral = [0.0; 3];
        let mut lo_weighted = [0.0; 3]; // ∫ [(1 + 1/A)φ − 4q/(1 + Fdr)] dS
        let mut area = 0.0;
        for (f, face) in mesh.boundary_faces().iter().enumerate() {
            let a = mesh.boundary_area(f);
            area += a;
            for c in 0..3 {
                let mean = face.vertices.iter().map(|&v| phi[v as usize][c]).sum::<f64>() / 3.0;
                phi_integral[c] += a * mean;
                lo_weighted[c] += a * ((1.0 + 1.0 / t.a) * mean - 4.0 * q / (1.0 + t.fdr));
            }
        }
        let incident = q * area;
        // Hemispherical integral of the radiance query per unit bracket: 2π ∫₀¹ Ft(μ) μ dμ/(4π).
        let steps = 20_000;
        let hemisphere: f64 = (0..steps)
            .map(|k| {
                let mu = (k as f64 + 0.5) / steps as f64;
                // radiance_from_fluence is linear in [(1 + 1/A)φ − 4q/(1 + Fdr)]: take φ giving
                // a bracket of 1.
                let phi_one = (1.0 + 4.0 * q / (1.0 + t.fdr)) / (1.0 + 1.0 / t.a);
                2.0 * std::f64::consts::PI * radiance_from_fluence(phi_one, q, t.eta, mu) * mu / steps as f64
            })
            .sum();
        let library = energy_balance(&sys, &phi).unwrap();
        for c in 0..3 {
            let exitant = (phi_integral[c] - 2.0 * q * area) / (2.0 * t.a);
            let discrete = (absorbed[c] + exitant) / incident - 1.0;
            let integrated = (absorbed[c] + hemisphere * lo_weighted[c]) / incident - 1.0;
            eprintln!(
                "{name} ch{c}: absorbed {:.4} + exitant {:.4} of incident {incident:.4}: defect {discrete:.1e}, \
                 with the integrated radiance query {integrated:.1e}",
                absorbed[c] / incident,
                exitant / incident
            );
            assert!(discrete.abs() < 1e-5, "{name} {c}: {discrete}");
            assert!(integrated.abs() < 0.01, "{name} {c}: {integrated}");
            assert!((library.absorbed[c] / absorbed[c] - 1.0).abs() < if fitted { 1e-8 } else { 1e-10 });
            if fitted {
                // Both estimate ∫ μ φ dV; the closed form's absorbed fraction is
                // 1 − (φ(R) − 2q)/(2Aq) (its exitance per area over q). The fitted rows' own
                // absorption is within 0.01 of it (measured: 0.0012, 0.0049, 0.0056), where
                // the lumped Σ μ V φ̄ of the same φ is 0.15 off in blue, above the incident power.
                let phi_r = UniformSphere::new(m, RADIUS, [q; 3]).unwrap().surface_fluence()[c];
                let exact = 1.0 - (phi_r - 2.0 * q) / (2.0 * t.a * q);
                let (own, lumped) = (absorbed[c] / incident, lumped_absorbed[c] / incident);
                eprintln!("  absorbed fraction: closed form {exact:.4}, fitted rows {own:.4}, lumped {lumped:.4}");
                assert!((own - exact).abs() < 0.01, "{name} {c}: absorbed fraction {own}, closed form {exact}");
            }
            assert!((library.exitant[c] / exitant - 1.0).abs() < 1e-10);
            assert!((library.incident[c] / incident - 1.0).abs() < 1e-10);
        }
    }
}

/// Relighting changes only b: the pattern and the matrix are kept, and the previous solution is
/// a warm start that saves iterations.
#[test]
fn relighting_keeps_the_matrix_and_warm_starts() {
    let mesh = sphere_mesh(50_000);
    let m = Medium::preset("marble").unwrap();
    let (mut sys, phi) = solved(mesh, m, false);
    let cold_iterations = solve(&sys, None, &SolveOptions::default()).unwrap().stats.iterations;
    let values = sys.matrix().values().to_vec();
    let pattern = std::sync::Arc::clone(sys.pattern());
    // The uniform light tilted by ±5% towards +x.
    let light = DVec3::new(1.0, 0.0, 0.0);
    let q: Vec<[f64; 3]> = sys.boundary().normal.iter().map(|n| [uniform_q(&m) * (1.0 + 0.05 * n.dot(light)); 3]).collect();
    sys.set_source(&q).unwrap();
    assert!(std::sync::Arc::ptr_eq(&pattern, sys.pattern()));
    assert_eq!(sys.matrix().values(), &values[..]);
    let warm = solve(&sys, Some(&phi), &SolveOptions::default()).unwrap();
    let cold = solve(&sys, None, &SolveOptions::default()).unwrap();
    let exact = solve(&sys, None, &SolveOptions::default().with_tolerance(1e-12)).unwrap();
    let error =
        |x: &[[f64; 3]]| [0, 1, 2].map(|c| (0..x.len()).map(|i| (x[i][c] / exact.phi[i][c] - 1.0).abs()).fold(0.0, f64::max));
    eprintln!(
        "iterations: uniform cold {cold_iterations:?}, relit cold {:?} (error {}), warm {:?} (error {})",
        cold.stats.iterations,
        exp3(error(&cold.phi)),
        warm.stats.iterations,
        exp3(error(&warm.phi))
    );
    for c in 0..3 {
        assert!(warm.stats.iterations[c] < cold.stats.iterations[c]);
        assert!(error(&warm.phi)[c] < 1e-3 && error(&cold.phi)[c] < 1e-3);
    }
}

/// A graded mesh spends the same budget on a finer surface layer, and the surface error follows
/// the surface spacing squared, not the tet count: skin1 and chicken1 (whose blue channels the
/// uniform mesh leaves unresolved) on the R = 10 mm sphere at 200k tets, uniform against graded
/// with one cube per size. Measured: spacings 0.637 and 0.550 mm (199,634 and 195,880 tets);
/// skin1 blue Lo RMS 12.1% → 9.4%, chicken1 blue 1.37% → 1.12%: ratios 0.78 and 0.82 against
/// the predicted (0.550 / 0.637)² = 0.75.
///
/// The exponentially fitted assembly on the graded mesh takes them further: skin1 blue 5.2%,
/// chicken1 blue 0.66% (ratios 0.55 and 0.59 to TransCut's on the same mesh), and leaves the
/// resolved channels within 1e-4 of TransCut's.
#[test]
fn graded_meshes_trade_interior_tets_for_surface_accuracy() {
    use transcut::mesher::{tetrahedralize_with, Grading};
    use transcut::Progress;
    let surface = uv_sphere(10.0, 256, 128);
    let mesh = |grading| {
        let options = MesherOptions { grading, ..MesherOptions::with_tets(200_000) };
        tetrahedralize_with(&surface, &options, Progress::none()).unwrap()
    };
    let (uniform, graded) = (mesh(Grading::Uniform), mesh(Grading::Graded { layers: 1 }));
    let (hu, hg) = (uniform.stats.spacing, graded.stats.spacing);
    eprintln!("spacing {hu:.4} / {hg:.4} mm, tets {} / {}", uniform.stats.tets, graded.stats.tets);
    assert!(graded.stats.tets <= uniform.stats.tets * 11 / 10, "{} tets", graded.stats.tets);
    assert!(hg < 0.92 * hu, "the graded surface spacing {hg} is not finer than {hu}");
    let predicted = (hg / hu).powi(2);
    for name in ["skin1", "chicken1"] {
        let m = Medium::preset(name).unwrap();
        let q = uniform_q(&m);
        let sphere = UniformSphere::new(m, 10.0, [q; 3]).unwrap();
        let rms = |mesh: &TetMesh| {
            let (sys, phi) = solved(mesh, m, false);
            surface_errors(&sys, &phi, &sphere).lo_rms[2]
        };
        let (eu, eg) = (rms(&uniform.mesh), rms(&graded.mesh));
        eprintln!("{name} blue Lo RMS {eu:.3e} → {eg:.3e}: ratio {:.3}, predicted {predicted:.3}", eg / eu);
        assert!((eg / eu - predicted).abs() < 0.1, "{name}: ratio {:.3} against (h_g / h_u)² = {predicted:.3}", eg / eu);
        let (sys, phi) = solved(&graded.mesh, m, false);
        let transcut = surface_errors(&sys, &phi, &sphere).lo_rms;
        let (sys, phi) = solved_with(&graded.mesh, m, assemble_fitted);
        let fitted = surface_errors(&sys, &phi, &sphere).lo_rms;
        eprintln!("{name} Lo RMS, graded mesh: TransCut {} fitted {}", exp3(transcut), exp3(fitted));
        assert!(fitted[2] < 0.7 * transcut[2], "{name} blue: fitted {:.3e}, TransCut {:.3e}", fitted[2], transcut[2]);
        for c in 0..2 {
            assert!(fitted[c] < transcut[c] + 1e-4, "{name} channel {c}: fitted {:.3e}, TransCut {:.3e}", fitted[c], transcut[c]);
        }
    }
}

/// Issue 23's accuracy bar: the R = 10 mm sphere at ≤ 300k tets with the default sizing (each
/// preset's grading as [`GradingChoice::Auto`], the default, chooses it for a 300k budget: graded
/// with one cube per size where the uniform lattice would leave σtr h > ½) and the default assembly
/// (`Discretization::FittedLayer`): Lo within 1% RMS of the closed form for every preset and
/// channel whose closed-form Lo is positive. Ketchup's green and blue are the exception the
/// model itself makes (its Lo is negative there: −0.013, −0.025), checked to be so.
///
/// Measured (a budget of 290k): graded (299,895 tets, h = 0.457 mm) for skin1, skin2 and
/// ketchup, whose worst, skin1 blue (σtr h = 0.67), is 0.87% (uniform tets at 300k: 1.22%);
/// uniform (289,248 tets, h = 0.562 mm) for the others, whose worst, chicken2 and chicken1
/// blue, are 0.30% and 0.28%. Before the fitted boundary rows (`diffusion::fitted::layer_mass`)
/// skin1 blue was 3.75% graded.
#[test]
fn every_positive_channel_is_within_one_percent_on_the_auto_graded_sphere_at_300k() {
    use transcut::mesher::{tetrahedralize_with, uniform_spacing_estimate, Grading};
    use transcut::{GradingChoice, Progress, TransCutOptions};
    assert_eq!(TransCutOptions::default().grading, GradingChoice::Auto, "the default sizing");
    let radius = 10.0;
    // The budget that keeps both gradings at or below 300k (the mesher lands within ±10%).
    let tets = 290_000;
    let surface = uv_sphere(radius, 256, 128);
    let mesh = |grading| {
        let options = MesherOptions { grading, ..MesherOptions::with_tets(tets) };
        let meshed = tetrahedralize_with(&surface, &options, Progress::none()).unwrap();
        eprintln!("{grading:?}: {} tets, h = {:.3} mm", meshed.stats.tets, meshed.stats.spacing);
        assert!(meshed.stats.tets <= 300_000, "{} tets", meshed.stats.tets);
        meshed.mesh
    };
    let (uniform, graded) = (mesh(Grading::Uniform), mesh(Grading::Graded { layers: 1 }));
    let spacing_mm = uniform_spacing_estimate(&surface, tets);
    let mut negative = Vec::new();
    let mut chosen_graded = Vec::new();
    for name in PRESET_NAMES {
        let m = Medium::preset(name).unwrap();
        let grading = GradingChoice::Auto.resolve(|| (m.sigma_tr(), spacing_mm));
        let tets = if grading == Grading::Uniform {
            &uniform
        } else {
            chosen_graded.push(name);
            &graded
        };
        let q = uniform_q(&m);
        let sphere = UniformSphere::new(m, radius, [q; 3]).unwrap();
        let exact = sphere.surface_radiance(1.0);
        let (sys, phi) = solved_with(tets, m, assemble_fitted_layer);
        let e = surface_errors(&sys, &phi, &sphere);
        eprintln!("{name:9} {grading:?}: Lo RMS {} (exact Lo {exact:.3?})", exp3(e.lo_rms));
        for c in 0..3 {
            if exact[c] > 0.0 {
                assert!(e.lo_rms[c] < 0.01, "{name} channel {c}: Lo RMS {:.3e}", e.lo_rms[c]);
            } else {
                negative.push((name, c));
            }
        }
    }
    // σtr h at the uniform 0.556 mm: skin1 0.81, ketchup 1.41 and skin2 0.51 in blue; the
    // next, chicken1 blue, 0.32.
    assert_eq!(chosen_graded, ["ketchup", "skin1", "skin2"], "the presets graded at 300k");
    assert_eq!(negative, [("ketchup", 1), ("ketchup", 2)], "the channels whose closed-form Lo is not positive");
}

/// The automatic grading reaches the mesher per object, from the object's own medium: a
/// 20k-tet bake of the R = 10 mm sphere grades skin1 (σtr h ≈ 2.0 in blue at the uniform
/// 1.36 mm) and keeps marble uniform (0.34 in blue), in one scene, and the statistics say
/// which; a fixed grading applies to both.
#[test]
fn the_automatic_grading_follows_each_objects_medium() {
    use transcut::light::Light;
    use transcut::mesher::Grading;
    use transcut::{bake, BakeOptions, GradingChoice, Object, Scene, TransCutOptions};
    let sphere = |x: f64| uv_sphere(10.0, 64, 32).transformed(&glam::DMat4::from_translation(DVec3::new(x, 0.0, 0.0)));
    let objects = ["skin1", "marble"]
        .iter()
        .zip([-15.0, 15.0])
        .map(|(&name, x)| Object::new(name, sphere(x), Medium::preset(name).unwrap(), 1.0))
        .collect();
    let sun = Light::Directional { direction: DVec3::NEG_Z, irradiance: [1.0; 3], angular_diameter_deg: 0.0 };
    let scene = Scene { objects, lights: vec![sun] };
    let gradings = |grading| {
        let options = BakeOptions::with_method(TransCutOptions { tets: 20_000, grading, ..TransCutOptions::default() });
        let baked = bake(&scene, &options).unwrap();
        let of = |i: usize| baked.objects[i].stats.meshing.as_ref().unwrap().grading;
        (of(0), of(1))
    };
    assert_eq!(gradings(GradingChoice::Auto), (Grading::Graded { layers: 1 }, Grading::Uniform));
    assert_eq!(gradings(Grading::Uniform.into()), (Grading::Uniform, Grading::Uniform));
    assert_eq!(gradings(Grading::Graded { layers: 2 }.into()), (Grading::Graded { layers: 2 }, Grading::Graded { layers: 2 }));
}

/// Issue 23's convergence check on graded meshes (one cube per size, 50k → 100k → 200k tets on
/// the R = 20 mm sphere): the exponentially fitted assembly's Lo error (RMS over the boundary)
/// falls at order ≥ 1.5 in every channel of marble (resolved) and skin1 (its blue unresolved
/// at 50k, σtr h ≈ 2.7), order = log(e₁/e₂)/log(h₁/h₂) with the meshes' surface spacings.
///
/// Measured from 25k to 400k: fitted 1.58–1.82 (marble), 1.48–1.96 (skin1), rising towards 2;
/// TransCut's own assembly 1.66–1.80 (marble) but 1.13–1.67 in skin1's unresolved blue. The
/// default, `FittedLayer`, is the most accurate at every size here (skin1 blue Lo RMS 3.2% at
/// 200k against fitted 20% and TransCut 33%) but does not converge at a steady order: its
/// boundary rows' absorption carries the stiffness's pointwise error at O(1) relative to the
/// lumped absorption (skin1 blue orders −0.86, 0.26, 1.02, 1.33; docs/benchmarks.md).
#[test]
fn graded_meshes_converge_at_second_order_with_the_fitted_assembly() {
    use transcut::mesher::{tetrahedralize_with, Grading};
    use transcut::Progress;
    let surface = uv_sphere(RADIUS, 256, 128);
    let media = ["marble", "skin1"].map(|n| (n, Medium::preset(n).unwrap()));
    let mut previous: [Option<(f64, [f64; 3])>; 2] = [None; 2];
    for n in [50_000, 100_000, 200_000] {
        let options = MesherOptions { grading: Grading::Graded { layers: 1 }, ..MesherOptions::with_tets(n) };
        let t = tetrahedralize_with(&surface, &options, Progress::none()).unwrap();
        let h = t.stats.spacing;
        for (k, (name, m)) in media.iter().enumerate() {
            let sphere = UniformSphere::new(*m, RADIUS, [uniform_q(m); 3]).unwrap();
            let (sys, phi) = solved_with(&t.mesh, *m, assemble_fitted);
            let e = surface_errors(&sys, &phi, &sphere).lo_rms;
            if let Some((h0, e0)) = previous[k] {
                let orders = [0, 1, 2].map(|c| (e0[c] / e[c]).ln() / (h0 / h).ln());
                eprintln!("{name} {n} tets, h {h0:.3} → {h:.3} mm: Lo RMS {} → {}, orders {orders:.2?}", exp3(e0), exp3(e));
                for (c, o) in orders.iter().enumerate() {
                    assert!(*o >= 1.5, "{name} channel {c}: order {o:.2} from h = {h0:.3} to {h:.3} mm");
                }
            }
            previous[k] = Some((h, e));
        }
    }
}
