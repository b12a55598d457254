//! TransCut's validity limit: a bake knows how well its tet mesh resolves each channel's
//! diffusion length (σtr · h at the surface, `ObjectStats::resolution`) and refuses one it
//! cannot resolve (`SceneError::Unresolved`) instead of returning a picture that is too dark or
//! black.
//!
//! h here is computed by the test itself: the mean length of the boundary triangles' edges of
//! the tet mesh the bake kept, in mm; σtr = √(3 σa (σa + σ′s)) from the preset's coefficients.

use glam::DVec3;
use transcut::diffusion::{assemble, solve, surface_radiance};
use transcut::light::{Environment, Light};
use transcut::mesh::TetMesh;
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::methods::transcut::MAX_RESOLUTION;
use transcut::optics::{f_ext, Medium, UniformSphere};
use transcut::sparse::SolveOptions;
use transcut::{bake, BakeOptions, Object, Scene, SceneError, TransCutOptions};

mod common;
use common::uv_sphere;

/// Mean boundary edge length of `mesh` in its own units (each boundary triangle's three edges).
fn mean_boundary_edge(mesh: &TetMesh) -> f64 {
    let p = mesh.positions();
    let mut sum = 0.0;
    for f in mesh.boundary_faces() {
        for k in 0..3 {
            sum += p[f.vertices[k] as usize].distance(p[f.vertices[(k + 1) % 3] as usize]);
        }
    }
    sum / (3 * mesh.boundary_faces().len()) as f64
}

/// σtr per channel, by hand.
fn sigma_tr(m: &Medium) -> [f64; 3] {
    [0, 1, 2].map(|c| (3.0 * m.sigma_a[c] * (m.sigma_a[c] + m.sigma_s_prime[c])).sqrt())
}

fn sun() -> Light {
    Light::Directional { direction: DVec3::new(0.0, 0.0, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 }
}

fn at(tets: usize) -> BakeOptions {
    BakeOptions { method: TransCutOptions { tets, ..TransCutOptions::default() }.into(), ..BakeOptions::default() }
}

#[test]
fn the_bake_reports_sigma_tr_h_per_channel() {
    let marble = Medium::preset("marble").unwrap();
    let scene = Scene { objects: vec![Object::new("sphere", uv_sphere(10.0, 64, 32), marble, 1.0)], lights: vec![sun()] };
    let baked = bake(&scene, &at(5_000)).unwrap();
    let object = &baked.objects[0];
    let h = mean_boundary_edge(&object.transcut().unwrap().tet_mesh);
    let s = sigma_tr(&marble);
    for c in 0..3 {
        assert!((object.stats.resolution[c] / (s[c] * h) - 1.0).abs() < 1e-12, "{:?} vs {h}", object.stats.resolution);
    }
    // 5000 tets in a sphere of radius 10 mm: h ≈ (12 V / N)^(1/3) = 2.9 mm by the lattice's
    // count, so blue (σtr = 0.253 mm⁻¹) is resolved, σtr·h well below 1.
    assert!(h > 1.5 && h < 3.5, "{h}");
    assert!(object.stats.resolution[2] < 1.0);
    // The same sphere modelled in cm: ten times the spacing in mm.
    let cm = Scene { objects: vec![Object::new("sphere", uv_sphere(1.0, 64, 32), marble, 10.0)], lights: vec![sun()] };
    let baked = bake(&cm, &at(5_000)).unwrap();
    let ratio = baked.objects[0].stats.resolution[2] / object.stats.resolution[2];
    assert!((ratio - 10.0).abs() < 0.2, "{ratio}");
}

#[test]
fn metre_scale_marble_spheres_at_5000_tets_are_refused_not_black() {
    let marble = Medium::preset("marble").unwrap();
    for radius_m in [1.0, 10.0] {
        // Modelled in metres: mm_per_unit = 1000.
        let scene =
            Scene { objects: vec![Object::new("statue", uv_sphere(radius_m, 64, 32), marble, 1000.0)], lights: vec![sun()] };
        let err = bake(&scene, &at(5_000)).unwrap_err();
        let SceneError::Unresolved { channel, sigma_tr_h, bound, spacing_mm, tets, tets_needed, scale, .. } = &err else {
            panic!("R = {radius_m} m: {err}");
        };
        // Blue has the shortest diffusion length of marble.
        assert_eq!(*channel, "blue");
        assert_eq!(*bound, MAX_RESOLUTION);
        // The spacing against the lattice's own estimate (interior tets h³/12 fill the volume).
        let volume_mm3 = 4.0 / 3.0 * std::f64::consts::PI * (radius_m * 1000.0).powi(3);
        let lattice = (12.0 * volume_mm3 / *tets as f64).cbrt();
        assert!(*spacing_mm > 0.5 * lattice && *spacing_mm < 1.2 * lattice, "{spacing_mm} vs {lattice}");
        assert!((sigma_tr_h / (sigma_tr(&marble)[2] * spacing_mm) - 1.0).abs() < 1e-12);
        assert!(*sigma_tr_h > 20.0 * radius_m, "{sigma_tr_h}");
        // What would resolve it: h ∝ N^(−1/3), aiming at 0.9 × the bound.
        let ratio = sigma_tr_h / (0.9 * MAX_RESOLUTION);
        assert_eq!(*tets_needed, (*tets as f64 * ratio.powi(3)).ceil());
        assert!((scale * ratio - 1.0).abs() < 1e-12);
        let text = err.to_string();
        for part in ["statue", "blue", "σtr·h", "mm", "tets"] {
            assert!(text.contains(part), "{part}: {text}");
        }
    }
}

/// Lo(x, n) of a uniformly lit sphere of `radius` mm on `mesh` (a unit-radius... any radius
/// sphere, scaled to `radius` mm by `mm_per_unit`) against the closed form: the area-weighted
/// mean and the largest relative error over the boundary, and the fraction of boundary nodes
/// whose radiance came out negative.
fn sphere_error(mesh: &TetMesh, mesh_radius: f64, m: Medium, mm_per_unit: f64) -> (f64, f64, f64) {
    let q = std::f64::consts::PI * (1.0 - f_ext(m.eta));
    let mut sys = assemble(mesh, &[m], mm_per_unit).unwrap();
    sys.set_source(&vec![[q; 3]; sys.boundary().len()]).unwrap();
    let sol = solve(&sys, None, &SolveOptions { tolerance: 1e-9, ..SolveOptions::default() }).unwrap();
    let lo = surface_radiance(&sys, &sol.phi).unwrap();
    let exact = UniformSphere::new(m, mesh_radius * mm_per_unit, [q; 3]).unwrap().surface_radiance(1.0);
    let b = sys.boundary();
    let area: f64 = b.area_mm2.iter().sum();
    let (mut mean, mut worst, mut negative) = (0.0f64, 0.0f64, 0usize);
    // The worst channel of the three.
    let mut means = [0.0; 3];
    for (k, l) in lo.iter().enumerate() {
        for c in 0..3 {
            let e = l[c].max(0.0) / exact[c] - 1.0;
            means[c] += b.area_mm2[k] / area * e;
            worst = worst.max(e.abs());
        }
        if l.iter().any(|&x| x < 0.0) {
            negative += 1;
        }
    }
    for c in means {
        mean = if c.abs() > mean.abs() { c } else { mean };
    }
    (mean, worst, negative as f64 / lo.len() as f64)
}

/// The measurement behind [`MAX_RESOLUTION`]: the uniformly lit sphere (the mesher's sphere of
/// radius 10 units) at 5k–300k tets, marble and skin1, scaled from 10 mm to 10 m, solved without
/// the bake's guard; prints the error of Lo against σtr·h and asserts what the bound promises:
/// below it the worst channel's mean error is under 25%, well above it (3×) at least 25%.
#[test]
#[ignore = "slow: meshes the sphere at up to 300k tets; run with --ignored slow_"]
fn slow_sphere_error_against_sigma_tr_h() {
    let surface = uv_sphere(10.0, 192, 96);
    eprintln!("tets      medium  R mm     σtr·h (r, g, b)        mean err  max err  negative");
    for tets in [5_000, 20_000, 60_000, 200_000, 300_000] {
        let mesh = tetrahedralize(&surface, &MesherOptions::with_tets(tets)).unwrap();
        let h = mean_boundary_edge(&mesh);
        for name in ["marble", "skin1"] {
            let m = Medium::preset(name).unwrap();
            for mm_per_unit in [1.0, 10.0, 100.0, 1000.0] {
                let s = sigma_tr(&m).map(|x| x * h * mm_per_unit);
                let worst_s = s.iter().fold(0.0f64, |a, &b| a.max(b));
                let (mean, max, negative) = sphere_error(&mesh, 10.0, m, mm_per_unit);
                eprintln!(
                    "{:7} {name:7} {:8.0} ({:7.3}, {:7.3}, {:7.3}) {mean:+9.4} {max:8.4} {negative:8.4}",
                    mesh.tet_count(),
                    10.0 * mm_per_unit,
                    s[0],
                    s[1],
                    s[2]
                );
                if worst_s <= MAX_RESOLUTION {
                    assert!(mean.abs() < 0.25, "{name} {tets} ×{mm_per_unit}: σtr·h {worst_s}: mean error {mean}");
                } else if worst_s >= 3.0 * MAX_RESOLUTION {
                    assert!(mean.abs() >= 0.25, "{name} {tets} ×{mm_per_unit}: σtr·h {worst_s}: mean error {mean}");
                }
            }
        }
    }
}

/// The environment light of the closed form, through the bake: a sphere the bound accepts bakes
/// within the accuracy the table promises (the guard does not refuse what it should not).
#[test]
fn a_resolved_bake_is_accepted_and_near_the_closed_form() {
    let skin = Medium::preset("skin1").unwrap();
    let scene = Scene {
        objects: vec![Object::new("sphere", uv_sphere(10.0, 96, 48), skin, 1.0)],
        lights: vec![Light::Environment(Environment::Constant([1.0; 3]))],
    };
    let baked = bake(&scene, &at(20_000)).unwrap();
    let object = &baked.objects[0];
    let worst = object.stats.resolution.iter().fold(0.0f64, |a, &b| a.max(b));
    assert!(worst > 1.0 && worst <= MAX_RESOLUTION, "{:?}", object.stats.resolution);
    let q = std::f64::consts::PI * (1.0 - f_ext(skin.eta));
    let exact = UniformSphere::new(skin, 10.0, [q; 3]).unwrap().surface_radiance(1.0);
    for c in 0..3 {
        let mean = object.radiance.iter().map(|l| l[c] / exact[c] - 1.0).sum::<f64>() / object.radiance.len() as f64;
        assert!(mean.abs() < 0.25, "channel {c}: mean error {mean}");
    }
}
