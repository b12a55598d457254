//! TransCut's validity limit: a bake knows how well its tet mesh resolves each channel's
//! diffusion length (σtr · h at the surface, `ObjectStats::resolution`) and refuses one it
//! cannot resolve (`SceneError::Unresolved`) instead of returning a picture that is too dark or
//! black.
//!
//! h here is computed by the test itself: the mean length of the boundary triangles' edges of
//! the tet mesh the bake kept, in mm; σtr = √(3 σa (σa + σ′s)) from the preset's coefficients.

use glam::DVec3;
use transcut::diffusion::{assemble, solve, surface_radiance, Discretization};
use transcut::edit::{EditError, MediumEdit, MediumOp, PaintStroke, Region};
use transcut::light::{Environment, Light};
use transcut::mesh::TetMesh;
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::methods::transcut::MAX_RESOLUTION;
use transcut::optics::{f_ext, Medium, UniformSphere};
use transcut::sparse::SolveOptions;
use transcut::{bake, BakeOptions, Object, Progress, Scene, SceneError, Session, SessionError, TransCutOptions};

use crate::common;
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

/// The radiance amplification of eq. 3 for the uniformly lit half-space, by hand:
/// φ(0) = Q/(1 + 2Aκσtr), κσtr = √(σa/(3σ′t)), amp = 1/(1 − (1 − Fdr)(1 + 2Aκσtr)/2), capped at 5.
fn amplification(m: &Medium) -> [f64; 3] {
    let fdr = -1.440 / (m.eta * m.eta) + 0.710 / m.eta + 0.668 + 0.0636 * m.eta;
    let a = (1.0 + fdr) / (1.0 - fdr);
    [0, 1, 2].map(|c| {
        let ks = (m.sigma_a[c] / (3.0 * (m.sigma_a[c] + m.sigma_s_prime[c]))).sqrt();
        let d = 1.0 - (1.0 - fdr) * (1.0 + 2.0 * a * ks) / 2.0;
        if d > 0.2 {
            1.0 / d
        } else {
            5.0
        }
    })
}

/// A channel's bound on σtr·h with TransCut's assembly: `MAX_RESOLUTION / amp`.
fn paper_bound(m: &Medium) -> [f64; 3] {
    amplification(m).map(|a| MAX_RESOLUTION / a)
}

/// A channel's bound on σtr·h with the default assembly (the fitted rows with the layer's
/// absorption): twice TransCut's.
fn bound(m: &Medium) -> [f64; 3] {
    assert_eq!(TransCutOptions::default().discretization, Discretization::FittedLayer);
    paper_bound(m).map(|b| 2.0 * b)
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
    for (r, s) in object.stats.resolution.iter().zip(s) {
        assert!((r / (s * h) - 1.0).abs() < 1e-12, "{:?} vs {h}", object.stats.resolution);
    }
    // 5000 tets in a sphere of radius 10 mm: h ≈ (12 V / N)^(1/3) = 2.9 mm by the lattice's
    // count, so blue (σtr = 0.253 mm⁻¹) is resolved, σtr·h well below 1.
    assert!(h > 1.5 && h < 3.5, "{h}");
    assert!(object.stats.resolution[2] < 1.0);
    // The same sphere modelled in cm has the same spacing in mm; one twice the size has twice
    // the spacing.
    for (radius, mm_per_unit, expected) in [(1.0, 10.0, 1.0), (2.0, 10.0, 2.0)] {
        let other =
            Scene { objects: vec![Object::new("sphere", uv_sphere(radius, 64, 32), marble, mm_per_unit)], lights: vec![sun()] };
        let baked = bake(&other, &at(5_000)).unwrap();
        let ratio = baked.objects[0].stats.resolution[2] / object.stats.resolution[2];
        assert!((ratio / expected - 1.0).abs() < 0.02, "{ratio}");
    }
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
        assert!((bound / self::bound(&marble)[2] - 1.0).abs() < 1e-3, "{bound}");
        // Marble's blue bound: amp = 1.327 (by hand in the unit test), 2 × 5 / 1.327 = 7.54.
        assert!((bound - 7.54).abs() < 0.01, "{bound}");
        // The spacing against the lattice's own estimate (interior tets h³/12 fill the volume).
        let volume_mm3 = 4.0 / 3.0 * std::f64::consts::PI * (radius_m * 1000.0).powi(3);
        let lattice = (12.0 * volume_mm3 / *tets as f64).cbrt();
        assert!(*spacing_mm > 0.5 * lattice && *spacing_mm < 1.2 * lattice, "{spacing_mm} vs {lattice}");
        assert!((sigma_tr_h / (sigma_tr(&marble)[2] * spacing_mm) - 1.0).abs() < 1e-12);
        assert!(*sigma_tr_h > 20.0 * radius_m, "{sigma_tr_h}");
        // What would resolve it: h ∝ N^(−1/3), aiming at 0.9 × the bound.
        let ratio = sigma_tr_h / (0.9 * bound);
        assert_eq!(*tets_needed, (*tets as f64 * ratio.powi(3)).ceil());
        assert!((scale * ratio - 1.0).abs() < 1e-12);
        let text = err.to_string();
        for part in ["statue", "blue", "σtr·h", "mm", "tets"] {
            assert!(text.contains(part), "{part}: {text}");
        }
    }
}

/// Lo(x, n) of a uniformly lit sphere on `mesh` (of radius `mesh_radius` in its units, scaled by
/// `mm_per_unit`) against the closed form: the area-weighted mean relative error per channel,
/// the largest over the boundary and channels, and the fraction of boundary nodes whose
/// radiance came out negative (compared as 0).
fn sphere_error(mesh: &TetMesh, mesh_radius: f64, m: Medium, mm_per_unit: f64) -> ([f64; 3], f64, f64) {
    let q = std::f64::consts::PI * (1.0 - f_ext(m.eta));
    let mut sys = assemble(mesh, &[m], mm_per_unit).unwrap();
    sys.set_source(&vec![[q; 3]; sys.boundary().len()]).unwrap();
    let mut options = SolveOptions::default();
    options.tolerance = 1e-9;
    let sol = solve(&sys, None, &options).unwrap();
    let lo = surface_radiance(&sys, &sol.phi).unwrap();
    let exact = UniformSphere::new(m, mesh_radius * mm_per_unit, [q; 3]).unwrap().surface_radiance(1.0);
    let b = sys.boundary();
    let area: f64 = b.area_mm2.iter().sum();
    let (mut worst, mut negative) = (0.0f64, 0usize);
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
    (means, worst, negative as f64 / lo.len() as f64)
}

/// The measurement behind [`MAX_RESOLUTION`]: the uniformly lit sphere (the mesher's sphere of
/// radius 10 units) at 5k–200k tets, six presets from wholemilk to ketchup, scaled from 5 mm to
/// 10 m, solved without the bake's guard; prints the error of Lo against σtr·h and asserts what the
/// bound promises per channel: at or below it the mean error is under 25%, at 3× it at least 25%.
#[test]
#[ignore = "slow: meshes the sphere at up to 300k tets; run with --ignored slow_"]
fn slow_sphere_error_against_sigma_tr_h() {
    let surface = uv_sphere(10.0, 192, 96);
    eprintln!("tets      medium  R mm     σtr·h (r, g, b)        mean err  max err  negative");
    // (σtr·h / bound, mean relative error, case) per channel.
    let mut rows: Vec<(f64, f64, String)> = Vec::new();
    for tets in [5_000, 20_000, 60_000, 200_000] {
        let mesh = tetrahedralize(&surface, &MesherOptions::with_tets(tets)).unwrap();
        let h = mean_boundary_edge(&mesh);
        for name in ["marble", "skin1", "ketchup", "apple", "chicken1", "wholemilk"] {
            let m = Medium::preset(name).unwrap();
            for mm_per_unit in [0.5, 1.0, 2.0, 4.0, 10.0, 100.0, 1000.0] {
                let s = sigma_tr(&m).map(|x| x * h * mm_per_unit);
                let b = paper_bound(&m);
                let (means, max, negative) = sphere_error(&mesh, 10.0, m, mm_per_unit);
                let mean = means.iter().fold(0.0f64, |a, &b| if b.abs() > a.abs() { b } else { a });
                eprintln!(
                    "{:7} {name:7} {:8.0} ({:7.3}, {:7.3}, {:7.3}) {mean:+9.4} {max:8.4} {negative:8.4}",
                    mesh.tet_count(),
                    10.0 * mm_per_unit,
                    s[0],
                    s[1],
                    s[2]
                );
                for c in 0..3 {
                    let closed_form_positive = !(name == "ketchup" && c > 0);
                    if closed_form_positive {
                        rows.push((
                            s[c] / b[c],
                            means[c],
                            format!("{name} {} tets, R {} mm, channel {c}", mesh.tet_count(), 10.0 * mm_per_unit),
                        ));
                    }
                }
            }
        }
    }
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (ratio, mean, case) in &rows {
        eprintln!("{ratio:7.3} {mean:+8.4} {case}");
        if *ratio <= 1.0 {
            assert!(mean.abs() < 0.25, "accepted but {mean:+.3} off: {case}");
        }
        if *ratio >= 3.0 {
            assert!(mean.abs() >= 0.25, "refused at only {mean:+.3}: {case}");
        }
    }
}

/// The environment light of the closed form, through the bake: a sphere the bound accepts bakes
/// within the accuracy the table promises (the guard does not refuse what it should not). With
/// TransCut's assembly the bound promises 25%; with the default one, whose bound is twice it,
/// the sphere at 0.9 of that bound is within 10% (measured: (0.5, 2.1, 3.8)% low on average at
/// 7.5k tets; the paper's at 0.9 of its own, 60k tets: (0.0, 2.6, 18.7)%).
#[test]
fn a_resolved_bake_is_accepted_and_near_the_closed_form() {
    let skin = Medium::preset("skin1").unwrap();
    let scene = Scene {
        objects: vec![Object::new("sphere", uv_sphere(10.0, 96, 48), skin, 1.0)],
        lights: vec![Light::Environment(Environment::Constant([1.0; 3]))],
    };
    let q = std::f64::consts::PI * (1.0 - f_ext(skin.eta));
    let exact = UniformSphere::new(skin, 10.0, [q; 3]).unwrap().surface_radiance(1.0);
    let paper = |tets| BakeOptions {
        method: TransCutOptions { tets, discretization: Discretization::TransCut, ..TransCutOptions::default() }.into(),
        ..BakeOptions::default()
    };
    // (options at about 0.9 of the bound, at a third of the tets, the bound, the promise): blue
    // σtr·h 1.1 against 5 / 4.02 = 1.24 with the paper's assembly, 2.2 against 2.49 with the
    // default.
    for (accepted, refused, b, promise) in
        [(paper(60_000), paper(20_000), paper_bound(&skin), 0.25), (at(7_500), at(2_500), bound(&skin), 0.10)]
    {
        let baked = bake(&scene, &accepted).unwrap();
        let object = &baked.objects[0];
        let s = object.stats.resolution;
        assert!(s[2] > 0.75 * b[2] && s[2] <= b[2], "{s:?} vs {b:?}");
        // At a third of the tets the same sphere is refused, naming blue.
        let err = bake(&scene, &refused).unwrap_err();
        assert!(matches!(&err, SceneError::Unresolved { channel: "blue", .. }), "{err}");
        for c in 0..3 {
            let mean = object.radiance.iter().map(|l| l[c] / exact[c] - 1.0).sum::<f64>() / object.radiance.len() as f64;
            eprintln!("bound {:.3}, σtr·h {:.3}: channel {c} mean error {mean:+.4}", b[2], s[2]);
            assert!(mean.abs() < promise, "channel {c}: mean error {mean}");
        }
    }
}

/// σtr·h of `m` at the surface of piece 0 of object 0 of `session` (h by hand, mm_per_unit 1).
fn surface_sigma_tr_h(session: &Session, m: &Medium) -> [f64; 3] {
    let h = mean_boundary_edge(session.editor(0).unwrap().unwrap().pieces()[0].mesh());
    sigma_tr(m).map(|s| s * h)
}

/// The largest σtr·h / bound over the channels of `m` at the surface of `session`'s object.
fn worst_ratio(session: &Session, m: &Medium) -> f64 {
    let (s, b) = (surface_sigma_tr_h(session, m), bound(m));
    (0..3).map(|c| s[c] / b[c]).fold(0.0, f64::max)
}

/// What the session holds for object 0: its radiance and its pieces' fluence.
type Held = (Option<Vec<[f64; 3]>>, Vec<Vec<[f64; 3]>>);

fn held(session: &Session) -> Held {
    let pieces = session.editor(0).unwrap().unwrap().pieces().iter().map(|p| p.fluence().to_vec()).collect();
    (session.radiance(0).unwrap(), pieces)
}

/// An edit cannot give the radiance a bake would have refused: a medium edit or paint stroke
/// that puts at the surface a medium the mesh does not resolve fails with
/// `EditError::Unresolved` (σtr·h and its bound as computed here by hand) and changes nothing;
/// the same medium deep inside (no tet there owns a boundary face) and a medium under the bound
/// at the surface are accepted.
#[test]
fn an_edit_that_the_mesh_cannot_resolve_at_the_surface_is_refused() {
    let marble = Medium::preset("marble").unwrap();
    let scene = Scene { objects: vec![Object::new("ball", uv_sphere(10.0, 32, 16), marble, 1.0)], lights: vec![sun()] };
    let mut session = Session::bake(&scene, &at(4_000), Progress::none()).unwrap();
    session.start(0, Progress::none()).unwrap();
    // A dark ink, three hundred times marble's absorption in green and blue.
    let dense = Medium { sigma_a: [0.3, 1.2, 2.4], sigma_s_prime: [2.0, 2.5, 3.0], ..marble };
    let ratio = worst_ratio(&session, &dense);
    assert!(ratio > 2.0, "the test medium must be well above the bound: {ratio}");
    let (expected, b) = (surface_sigma_tr_h(&session, &dense), bound(&dense));
    let worst = (0..3).max_by(|&i, &j| (expected[i] / b[i]).total_cmp(&(expected[j] / b[j]))).unwrap();
    let set = MediumOp::Set { sigma_a: dense.sigma_a, sigma_s: dense.sigma_s_prime };
    let before = held(&session);

    // A cap at the surface: refused, naming the worst channel with σtr·h and its bound by hand.
    let at_surface = MediumEdit { region: Region::Sphere { center: DVec3::new(0.0, 0.0, 10.0), radius: 4.0 }, op: set.clone() };
    let err = session.edit_medium(0, &at_surface, Progress::none()).unwrap_err();
    let SessionError::Edit { source, .. } = &err else { panic!("{err}") };
    let EditError::Unresolved(u) = source.as_ref() else { panic!("{err}") };
    let name = ["red", "green", "blue"][worst];
    assert_eq!(u.channel, name, "{err}");
    assert!((u.sigma_tr_h / expected[worst] - 1.0).abs() < 1e-9, "{} vs {}", u.sigma_tr_h, expected[worst]);
    assert!((u.bound / b[worst] - 1.0).abs() < 1e-3, "{} vs {}", u.bound, b[worst]);
    assert!(err.to_string().contains(name), "{err}");
    assert!(held(&session) == before, "a refused edit changed the session");

    // A stroke across the surface with the same medium at full strength: refused too.
    let stroke = PaintStroke {
        points: vec![DVec3::new(-3.0, 0.0, 9.5), DVec3::new(3.0, 0.0, 9.5)],
        radius: 3.0,
        medium: dense,
        strength: 1.0,
    };
    let err = session.paint(0, &stroke, Progress::none()).unwrap_err();
    assert!(matches!(&err, SessionError::Edit { source, .. } if matches!(source.as_ref(), EditError::Unresolved(_))), "{err}");
    assert!(held(&session) == before, "a refused stroke changed the session");

    // The same medium in a core 6 mm below the surface: no surface tet changes, accepted.
    let inside = MediumEdit { region: Region::Sphere { center: DVec3::ZERO, radius: 4.0 }, op: set };
    session.edit_medium(0, &inside, Progress::none()).unwrap();
    assert!(held(&session) != before);

    // A medium under the bound at the surface is accepted.
    let mild = Medium { sigma_a: marble.sigma_a.map(|a| 2.0 * a), ..marble };
    assert!(worst_ratio(&session, &mild) < 0.9, "{}", worst_ratio(&session, &mild));
    let op = MediumOp::Set { sigma_a: mild.sigma_a, sigma_s: mild.sigma_s_prime };
    session.edit_medium(0, &MediumEdit { region: at_surface.region, op }, Progress::none()).unwrap();
}
