//! The PRT method against closed forms and brute force (design/prt.md §3, §7):
//!
//! - the uniformly lit sphere, whose dipole surface integral is exactly the disc integral out to
//!   2R (Archimedes: the sphere's area at chord distance c is 2πc dc), for four media;
//! - a sun- and spot-lit, self-shadowed object (spot, 60 mm) against direct summation of the
//!   exact dipole over 2¹⁸ samples, uncompressed and at the default compression;
//! - material edits, scale changes and relights equal to fresh bakes (bit for bit, or to the
//!   scale identity Rd(s r; σ) s² = Rd(r; s σ));
//! - environments through the samples' SH transfer: relights equal to fresh bakes, and a bake
//!   shadowed by a second object against the sampled path;
//! - what the method cannot represent refused by name.

use glam::{DMat4, DVec3};
use transcut::edit::{MediumEdit, MediumOp, PaintStroke, Region};
use transcut::light::{transmitted_source, Environment, EquirectMap, Light, SourceOptions};
use transcut::mesh::{icosphere, TriMesh, TriangleBvh};
use transcut::methods::Lighting;
use transcut::optics::Medium;
use transcut::prt::{haar_irradiance, PrtOptions, RdBasis, SurfaceSamples, Transfer};
use transcut::volume::Layers;
use transcut::{bake, BakeOptions, MediumSource, Method, Object, Progress, Scene, SceneError, Session, SessionError};

/// B = Σₖ sₖ (Tₖ q)[v] per receiver and channel for `medium` under `q` at the samples.
fn exitance(transfer: &Transfer, basis: &RdBasis, medium: &Medium, q: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let k = basis.terms();
    let mut gathered = vec![0.0; transfer.vertices() * k * 3];
    transfer.apply(&haar_irradiance(q), &mut gathered);
    let (weights, _) = basis.project_medium(medium);
    (0..transfer.vertices())
        .map(|v| [0, 1, 2].map(|c| (0..k).map(|j| weights[c][j] * gathered[(v * k + j) * 3 + c]).sum()))
        .collect()
}

/// The transfer of `mesh` (mm) to the vertices `ids`.
fn transfer_to(mesh: &TriMesh, ids: &[usize], options: &PrtOptions) -> (Transfer, SurfaceSamples) {
    let samples = SurfaceSamples::new(mesh.positions(), mesh.triangles(), options.samples_log2, options.seed).unwrap();
    let points: Vec<DVec3> = ids.iter().map(|&v| mesh.positions()[v]).collect();
    let basis = RdBasis::get(options.basis);
    let transfer =
        Transfer::precompute(&points, mesh.positions(), mesh.triangles(), &samples, basis, options, &|_| Ok(())).unwrap();
    (transfer, samples)
}

/// relative L² of `a` against `b` over every vertex and channel.
fn relative_l2(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let (mut e, mut n) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            e += (x[c] - y[c]).powi(2);
            n += y[c] * y[c];
        }
    }
    (e / n).sqrt()
}

/// The uniformly lit R = 10 mm sphere (a 20480-triangle icosphere, 2¹⁴ samples, the default
/// near field and compression): B = q P(2R), P the dipole's disc integral in closed form, at
/// every 37th vertex within 2e-3 for marble, skin1, apple and cream at η = 1.3 (design/prt.md
/// §7). The constant C(η) and the worked Lo of the marble sphere are checked through the bake
/// in `core/tests/integration/methods.rs`.
#[test]
fn uniform_sphere_matches_the_closed_form() {
    let mesh = icosphere(10.0, 5);
    let ids: Vec<usize> = (0..mesh.positions().len()).step_by(37).collect();
    let options = PrtOptions { samples_log2: 14, ..PrtOptions::default() };
    let (transfer, samples) = transfer_to(&mesh, &ids, &options);
    let basis = RdBasis::get(options.basis);
    let q = vec![[1.0; 3]; samples.len()];
    for name in ["marble", "skin1", "apple", "cream"] {
        let medium = Medium { eta: 1.3, ..Medium::preset(name).unwrap() };
        let b = exitance(&transfer, basis, &medium, &q);
        for c in 0..3 {
            let exact = medium.dipole(c).disc_integral(20.0);
            let worst = b.iter().map(|v| (v[c] / exact - 1.0).abs()).fold(0.0, f64::max);
            assert!(worst <= 2e-3, "{name} channel {c}: worst relative error {worst:.2e}");
        }
    }
}

/// q at points with unit normals.
type LightAt<'a> = dyn Fn(&[DVec3], &[DVec3]) -> Vec<[f64; 3]> + 'a;

/// The exitance of `medium` at `receivers` by direct summation of the exact dipole: over
/// `samples` (with their irradiance `q`) for the cells beyond `near` mm, and by adaptive
/// cubature of Rd(‖y − x‖) q(y) on the triangles of the cells within it, with q computed at
/// every cubature point (`light`: points and unit normals → q), pieces split until smaller than
/// a quarter of their distance from x plus z_r.
fn brute_force(
    mesh: &TriMesh,
    samples: &SurfaceSamples,
    q: &[[f64; 3]],
    medium: &Medium,
    receivers: &[DVec3],
    near: f64,
    light: &LightAt<'_>,
) -> Vec<[f64; 3]> {
    let dipoles = [0, 1, 2].map(|c| medium.dipole(c));
    let z_r = dipoles.iter().map(|d| d.z_r).fold(f64::INFINITY, f64::min);
    let normals = transcut::mesh::area_weighted_normals(mesh.positions(), mesh.triangles());
    receivers
        .iter()
        .map(|&x| {
            let mut b = [0.0; 3];
            for (j, qj) in q.iter().enumerate() {
                if near_triangle(mesh, samples, samples.triangles[j] as usize, x, near) {
                    continue;
                }
                let r = samples.positions[j].distance(x);
                for c in 0..3 {
                    b[c] += samples.areas[j] * dipoles[c].rd(r) * qj[c];
                }
            }
            let (mut points, mut point_normals, mut weights) = (Vec::new(), Vec::new(), Vec::new());
            for t in (0..mesh.triangles().len()).filter(|&t| near_triangle(mesh, samples, t, x, near)) {
                let tri = mesh.triangles()[t];
                let corners = tri.map(|v| mesh.positions()[v as usize]);
                let corner_normals = tri.map(|v| normals[v as usize]);
                let mut stack = vec![([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], 0u32)];
                while let Some((l0, l1, l2, depth)) = stack.pop() {
                    let at = |l: [f64; 3]| corners[0] * l[0] + corners[1] * l[1] + corners[2] * l[2];
                    let (p0, p1, p2) = (at(l0), at(l1), at(l2));
                    let centre = (p0 + p1 + p2) / 3.0;
                    let size = p0.distance(p1).max(p1.distance(p2)).max(p2.distance(p0));
                    if size > 0.25 * (centre.distance(x) + z_r) && depth < 12 {
                        let mid = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|i| 0.5 * (a[i] + b[i]));
                        let (m01, m12, m20) = (mid(l0, l1), mid(l1, l2), mid(l2, l0));
                        stack.extend([
                            (l0, m01, m20, depth + 1),
                            (m01, l1, m12, depth + 1),
                            (m20, m12, l2, depth + 1),
                            (m01, m12, m20, depth + 1),
                        ]);
                        continue;
                    }
                    // The 7-point rule on the piece, normals interpolated as the samples' are.
                    let area = 0.5 * (p1 - p0).cross(p2 - p0).length();
                    let s15 = 15f64.sqrt();
                    let (a1, b1, a2, b2) =
                        ((6.0 - s15) / 21.0, (9.0 + 2.0 * s15) / 21.0, (6.0 + s15) / 21.0, (9.0 - 2.0 * s15) / 21.0);
                    let (w1, w2) = ((155.0 - s15) / 1200.0, (155.0 + s15) / 1200.0);
                    let rule = [
                        ([1.0 / 3.0; 3], 9.0 / 40.0),
                        ([b1, a1, a1], w1),
                        ([a1, b1, a1], w1),
                        ([a1, a1, b1], w1),
                        ([b2, a2, a2], w2),
                        ([a2, b2, a2], w2),
                        ([a2, a2, b2], w2),
                    ];
                    for (m, w) in rule {
                        let l = [0, 1, 2].map(|i| m[0] * l0[i] + m[1] * l1[i] + m[2] * l2[i]);
                        points.push(at(l));
                        point_normals
                            .push((corner_normals[0] * l[0] + corner_normals[1] * l[1] + corner_normals[2] * l[2]).normalize());
                        weights.push(w * area);
                    }
                }
            }
            let qs = light(&points, &point_normals);
            for ((p, w), qv) in points.iter().zip(&weights).zip(&qs) {
                let r = p.distance(x);
                for c in 0..3 {
                    b[c] += w * dipoles[c].rd(r) * qv[c];
                }
            }
            b
        })
        .collect()
}

/// Whether triangle `t`'s cell (its owner's) lies within `near` of `x` (by the owner's centroid).
fn near_triangle(mesh: &TriMesh, samples: &SurfaceSamples, t: usize, x: DVec3, near: f64) -> bool {
    let owner = samples.owner[t] as usize;
    let [a, b, c] = mesh.triangle(owner);
    ((a + b + c) / 3.0).distance(x) < near
}

/// spot.obj scaled to 60 mm, lit by a sun and a spot with shadows (self-shadowed: the light
/// varies sharply across the surface, so the compression is tested, unlike under uniform light
/// where the rows' coefficient 0 alone matters): PRT with the default 2¹⁶ samples against the
/// exact dipole over 2¹⁸ samples (the near field by cubature with the light computed at every
/// cubature point), q at the samples as the method takes it (each sample's piece's mean where a
/// shadow's edge crosses it, `prt::cells`). Relative L² over 50 vertices, by terms per vertex:
/// 1.5e-3 uncompressed, 4.7e-3 at 2048, 1.1e-2 at the default 1024, 2.0e-2 at 512, 3.6e-2 at
/// 256 (asserted: the design's 2e-3, twice the default within 1%, the default within 2%, and
/// rising as the budget halves). The coefficients kept by |c| alone, without the level weight
/// (`prt::transfer`), were 1.0e-2 at 3072 and 1.9e-2 at 1536. With the samples' centre values
/// instead of the pieces' means, the shadows' edges alone put the uncompressed transfer at
/// 2.5e-3.
#[test]
fn shadowed_object_matches_brute_force() {
    let spot = transcut::mesh::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/meshes/spot.obj")).unwrap();
    let (lo, hi) = spot.bounds();
    let scale = 60.0 / (hi - lo).max_element();
    let mesh = spot.transformed(&DMat4::from_scale(DVec3::splat(scale)));
    let lights = [
        Light::Directional { direction: DVec3::new(0.4, -1.0, -0.6), irradiance: [3.0, 2.5, 2.0], angular_diameter_deg: 0.0 },
        Light::Spot {
            position: DVec3::new(40.0, 30.0, 30.0),
            direction: DVec3::new(-1.0, -0.7, -0.8),
            intensity: [9000.0; 3],
            cone_half_angle_deg: 20.0,
            blend: 0.2,
        },
    ];
    let medium = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let occluder = TriangleBvh::from_indexed(mesh.positions(), mesh.triangles());
    let source = SourceOptions::default();
    let lit_at = |p: &[DVec3], n: &[DVec3]| transmitted_source(&lights, p, n, medium.eta, Some(&occluder), &source).unwrap();
    // q as the method takes it: each sample's piece's mean where a shadow's edge crosses it.
    let lit = |s: &SurfaceSamples| {
        let none: transcut::light::Poll<'_> = &|_| Ok(());
        let (p, t) = (mesh.positions(), mesh.triangles());
        transcut::prt::cell_irradiance(s, p, t, &s.positions, &lights, medium.eta, Some(&occluder), &source, none).unwrap()
    };
    let ids: Vec<usize> = (0..mesh.positions().len()).step_by(mesh.positions().len() / 50).take(50).collect();
    let points: Vec<DVec3> = ids.iter().map(|&v| mesh.positions()[v]).collect();

    let reference_samples = SurfaceSamples::new(mesh.positions(), mesh.triangles(), 18, 99).unwrap();
    let reference = brute_force(
        &mesh,
        &reference_samples,
        &lit_at(&reference_samples.positions, &reference_samples.normals),
        &medium,
        &points,
        4.0,
        &lit_at,
    );
    // The compression's error curve (design/prt.md §7: the default budget within 2%, twice it
    // within 1%): every halving of the budget costs accuracy, down to a quarter of the default.
    let basis = RdBasis::get(PrtOptions::default().basis);
    let mut last = 0.0;
    for (budget, bound) in [(usize::MAX, 2e-3), (2048, 1e-2), (1024, 2e-2), (512, f64::INFINITY), (256, f64::INFINITY)] {
        let options = PrtOptions { terms_per_vertex: budget.min(PrtOptions::MAX_TERMS_PER_VERTEX), ..PrtOptions::default() };
        let (transfer, samples) = transfer_to(&mesh, &ids, &options);
        let b = exitance(&transfer, basis, &medium, &lit(&samples));
        let error = relative_l2(&b, &reference);
        eprintln!("budget {budget}: relative L2 {error:.2e} (dropped energy {:.2e})", transfer.stats().dropped_mean);
        assert!(error <= bound, "budget {budget}: relative L2 {error:.2e} > {bound:.0e}");
        assert!(error > last, "budget {budget}: relative L2 {error:.2e} is not above the larger budget's {last:.2e}");
        last = error;
    }
}

fn ball(medium: impl Into<transcut::Material>) -> Object {
    let mut object = Object::new("ball", icosphere(10.0, 3), Medium::preset("marble").unwrap(), 1.0);
    object.material = medium.into();
    object
}

fn prt_options() -> BakeOptions {
    BakeOptions {
        method: PrtOptions { samples_log2: 12, terms_per_vertex: 1024, ..PrtOptions::default() }.into(),
        ..BakeOptions::default()
    }
}

fn sun(direction: DVec3) -> Light {
    Light::Directional { direction, irradiance: [3.0; 3], angular_diameter_deg: 0.0 }
}

/// A relight of two PRT objects cancelled while the second is lit leaves the first as it was:
/// its radiance, and the sums its next material edit reweighs (an undo computes the old
/// product again, since a relight writes over its buffer), so the edit equals a fresh bake
/// under the old lights, bit for bit, at every report where the cancel can land.
#[test]
fn a_cancelled_relight_restores_the_first_object() {
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let skin = Medium { eta: 1.3, ..Medium::preset("skin1").unwrap() };
    let lights = vec![sun(DVec3::new(0.2, -0.3, -1.0))];
    let moved = vec![sun(DVec3::new(-0.5, 0.4, -1.0))];
    let options = prt_options();
    let scene = |m: Medium| Scene { objects: vec![ball(m), ball(marble)], lights: lights.clone() };
    let fresh_skin = bake(&scene(skin), &options).unwrap().objects.remove(0).radiance;
    let mut session = Session::bake(&scene(marble), &options, Progress::none()).unwrap();
    let before = session.radiance(0).unwrap();
    let reports = std::sync::atomic::AtomicUsize::new(0);
    let count = |_: &str, _: f64| {
        reports.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        true
    };
    Session::bake(&scene(marble), &options, Progress::none()).unwrap().relight(&moved, Progress::new(&count)).unwrap();
    let total = reports.load(std::sync::atomic::Ordering::SeqCst);
    let mut cancelled_in_second = 0;
    for k in total / 2..total {
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let cancel = |_: &str, _: f64| calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst) < k;
        if session.relight(&moved, Progress::new(&cancel)).is_ok() {
            continue;
        }
        cancelled_in_second += 1;
        assert!(session.radiance(0).unwrap() == before, "cancel at report {k} of {total}: the radiance changed");
        session.edit_medium(0, &MediumEdit { region: Region::All, op: MediumOp::Assign(skin) }, Progress::none()).unwrap();
        let edited = session.radiance(0).unwrap().unwrap();
        assert!(edited == fresh_skin, "cancel at report {k}: the edit after the undo is not a fresh bake");
        session.edit_medium(0, &MediumEdit { region: Region::All, op: MediumOp::Assign(marble) }, Progress::none()).unwrap();
    }
    assert!(cancelled_in_second > 0, "no cancel landed in the second object's relight ({total} reports)");
}

/// A material edit, a relight and a new scale in a session equal fresh bakes of the same state:
/// bit for bit for the edit and the relight (the transfer does not depend on the medium and
/// every sum runs in a fixed order), within 1e-12 for the scale (the scale identity).
#[test]
fn edits_equal_fresh_bakes() {
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let skin = Medium { eta: 1.3, ..Medium::preset("skin1").unwrap() };
    let lights = vec![sun(DVec3::new(0.2, -0.3, -1.0))];
    let options = prt_options();
    let scene = |m: Medium, lights: &[Light]| Scene { objects: vec![ball(m)], lights: lights.to_vec() };
    let mut session = Session::bake(&scene(marble, &lights), &options, Progress::none()).unwrap();

    let edit = MediumEdit { region: Region::All, op: MediumOp::Assign(skin) };
    session.edit_medium(0, &edit, Progress::none()).unwrap();
    let fresh = bake(&scene(skin, &lights), &options).unwrap().objects.remove(0).radiance;
    assert_eq!(session.radiance(0).unwrap().unwrap(), fresh, "a medium edit is a fresh bake of the new medium");

    let moved = vec![sun(DVec3::new(-0.5, 0.4, -1.0))];
    session.relight(&moved, Progress::none()).unwrap();
    let fresh = bake(&scene(skin, &moved), &options).unwrap().objects.remove(0).radiance;
    assert_eq!(session.radiance(0).unwrap().unwrap(), fresh, "a relight is a fresh bake under the new lights");

    // Twice the millimetres per unit is the medium with twice the coefficients on the same
    // transfer (the object is baked at 1 mm per unit).
    session.set_mm_per_unit(0, 2.0, Progress::none()).unwrap();
    let doubled = session.radiance(0).unwrap().unwrap();
    let denser = Medium { sigma_a: skin.sigma_a.map(|s| 2.0 * s), sigma_s_prime: skin.sigma_s_prime.map(|s| 2.0 * s), ..skin };
    session.set_mm_per_unit(0, 1.0, Progress::none()).unwrap();
    session.edit_medium(0, &MediumEdit { region: Region::All, op: MediumOp::Assign(denser) }, Progress::none()).unwrap();
    let assigned = session.radiance(0).unwrap().unwrap();
    let scale = assigned.iter().flatten().fold(0.0f64, |m, x| m.max(*x));
    for (a, b) in doubled.iter().flatten().zip(assigned.iter().flatten()) {
        assert!((a - b).abs() <= 1e-12 * scale, "scale identity: {a} vs {b}");
    }
    // The doubled medium at 2 mm per unit is a genuinely different picture.
    assert!(relative_l2(&doubled, &fresh) > 0.01);
}

/// The bake does not depend on the number of threads: every row is one vertex's, summed in a
/// fixed order.
#[test]
fn the_bake_does_not_depend_on_the_thread_count() {
    let scene = Scene { objects: vec![ball(Medium::preset("marble").unwrap())], lights: vec![sun(DVec3::new(0.3, -0.2, -1.0))] };
    let one = bake(&scene, &BakeOptions { threads: 1, ..prt_options() }).unwrap().objects.remove(0).radiance;
    let two = bake(&scene, &BakeOptions { threads: 2, ..prt_options() }).unwrap().objects.remove(0).radiance;
    assert_eq!(one, two);
}

/// What the method cannot represent is refused with the method named, before any work, and an
/// update it cannot do leaves the object as it was.
#[test]
fn what_the_method_cannot_represent_is_refused() {
    let options = prt_options();
    let lights = vec![sun(DVec3::NEG_Z)];
    let refused = |e: &SceneError| matches!(e, SceneError::Unsupported { method: "prt", .. });
    // A layered medium (heterogeneous).
    let marble = Medium::preset("marble").unwrap();
    let layers = Layers::new(&[(1.0, Medium::preset("skin1").unwrap()), (f64::INFINITY, marble)], 0.2).unwrap();
    let e = bake(&Scene { objects: vec![ball(MediumSource::Layers(layers))], lights: lights.clone() }, &options).unwrap_err();
    assert!(refused(&e) && e.to_string().contains("heterogeneous"), "{e}");
    // Too dense for 2¹² samples on a 10 mm sphere (h = 0.55 mm): σ′t = 20/mm.
    let dense = Medium::new([0.01; 3], [20.0; 3], 1.3, 0.0).unwrap();
    let e = bake(&Scene { objects: vec![ball(dense)], lights: lights.clone() }, &options).unwrap_err();
    assert!(refused(&e) && e.to_string().contains("too dense"), "{e}");
    // Options out of range name the method.
    let bad = BakeOptions { method: PrtOptions { terms_per_vertex: 3, ..PrtOptions::default() }.into(), ..options.clone() };
    let e = bake(&Scene { objects: vec![ball(marble)], lights: lights.clone() }, &bad).unwrap_err();
    assert!(matches!(e, SceneError::InvalidOptions(_)) && e.to_string().contains("prt"), "{e}");

    let mut session = Session::bake(&Scene { objects: vec![ball(marble)], lights }, &options, Progress::none()).unwrap();
    let before = session.radiance(0).unwrap().unwrap();
    let sphere = Region::Sphere { center: DVec3::ZERO, radius: 3.0 };
    let edit = MediumEdit { region: sphere, op: MediumOp::Scale { sigma_a: [2.0; 3], sigma_s: [1.0; 3] } };
    assert!(matches!(session.edit_medium(0, &edit, Progress::none()), Err(SessionError::Edit { .. })));
    let stroke = PaintStroke { points: vec![DVec3::new(0.0, 0.0, 10.0)], radius: 1.0, medium: marble, strength: 1.0 };
    assert!(session.paint(0, &stroke, Progress::none()).is_err());
    let too_dense = MediumEdit { region: Region::All, op: MediumOp::Scale { sigma_a: [1.0; 3], sigma_s: [20.0; 3] } };
    let e = session.edit_medium(0, &too_dense, Progress::none()).unwrap_err();
    assert!(e.to_string().contains("too dense"), "{e}");
    assert!(matches!(session.fracture(0, Progress::none()), Err(SessionError::Unsupported { method: "prt", .. })));
    assert_eq!(session.radiance(0).unwrap().unwrap(), before, "nothing changed");
    assert!(Method::from_name("PRT").is_some());
}

/// A sky brighter towards the zenith and towards `sun` (a broad lobe), as an equirect map.
fn sky(sun: DVec3) -> Light {
    let sun = sun.normalize();
    let map = EquirectMap::from_fn(128, 64, 1.0, |d| {
        let lobe = 4.0 * (3.0 * (d.dot(sun) - 1.0)).exp();
        [0.3 + 0.5 * d.z.max(0.0) + lobe, 0.4 + 0.4 * d.z.max(0.0) + 0.8 * lobe, 0.6 + 0.2 * d.z.max(0.0) + 0.5 * lobe]
    })
    .unwrap();
    Light::Environment(Environment::Equirect(map))
}

/// Environments go through the samples' SH transfer, made once: a relight under another
/// environment (a turned sky, a constant one, with a sun beside it) equals a fresh bake of the
/// one-object scene bit for bit, and casts no new shadow rays for the environment (the state's
/// transfer is the bake's).
#[test]
fn environment_relights_equal_fresh_bakes() {
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let options = prt_options();
    let scene = |lights: &[Light]| Scene { objects: vec![ball(marble)], lights: lights.to_vec() };
    let first = vec![sky(DVec3::new(0.3, 0.2, 1.0))];
    let mut session = Session::bake(&scene(&first), &options, Progress::none()).unwrap();
    let made = session.prt_state(0).unwrap().and_then(|s| s.env_sh.current()).expect("the bake made the SH transfer");
    for lights in [
        vec![sky(DVec3::new(-0.6, 0.5, 0.4))],
        vec![Light::Environment(Environment::Constant([0.2, 0.5, 1.0])), sun(DVec3::new(0.1, 0.3, -1.0))],
        first.clone(),
    ] {
        session.relight(&lights, Progress::none()).unwrap();
        let fresh = bake(&scene(&lights), &options).unwrap().objects.remove(0).radiance;
        assert_eq!(session.radiance(0).unwrap().unwrap(), fresh, "a relight is a fresh bake under the new lights");
        let held = session.prt(0).unwrap().unwrap().state().env_sh.current().unwrap();
        assert!(std::sync::Arc::ptr_eq(&made, &held), "the session's relights reuse the bake's transfer");
    }
}

/// (e) A bake under an environment, shadowed by a second object: the exitance at every vertex
/// through the SH transfer (order 5) against the old sampled path (q at the samples by
/// multiple importance sampling with shadow rays, `transmitted_source`), both with 1024
/// directions per sample, through the same transfer.
///
/// Tolerance: the sky's truncation to l ≤ 4 (its lobe of sharpness 3 keeps ~1e-3 of its power
/// above l = 4, the cosine lobe's Â₆/Â₀ = 1/64 weighs that) and the two estimates' independent
/// noise at the blocker's penumbra, averaged by the dipole over many samples. Measured: relative
/// L² 1.1e-3, worst vertex 4.7e-3 (the blocker takes 9.9% of the light); asserted 5e-3 and 2e-2.
#[test]
fn a_shadowed_environment_bake_matches_the_sampled_path() {
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let blocker =
        Object::new("blocker", icosphere(8.0, 3).transformed(&DMat4::from_translation(DVec3::new(6.0, 0.0, 22.0))), marble, 1.0);
    let lights = vec![sky(DVec3::new(0.2, 0.1, 1.0)), Light::Environment(Environment::Constant([0.1; 3]))];
    let scene = Scene { objects: vec![ball(marble), blocker], lights: lights.clone() };
    let source = SourceOptions { environment_samples: 1024, ..SourceOptions::default() };
    let options = BakeOptions { source, ..prt_options() };
    let baked = bake(&scene, &options).unwrap();
    let state = baked.objects[0].prt().expect("a PRT state");
    let surfaces: Vec<TriMesh> = scene.objects.iter().map(|o| o.world_surface().unwrap()).collect();
    let occluder = Lighting::occluder_of(&surfaces);
    let points: Vec<DVec3> = state.samples.positions.iter().map(|p| *p / state.transfer_mm_per_unit).collect();
    let normals = &state.samples.normals;
    let (transfer, made) = state.env_sh.transfer(&points, normals, 1.3, Some(&occluder), &source, &|_| Ok(())).unwrap();
    assert!(!made, "the bake's transfer is the one for the scene's occluder");
    assert_eq!((transfer.order(), transfer.len()), (5, points.len()));
    let q_sh = state.env_sh.transmitted_source(&lights, &points, normals, 1.3, Some(&occluder), &source, &|_| Ok(())).unwrap();
    let q_old = transmitted_source(&lights, &points, normals, 1.3, Some(&occluder), &source).unwrap();
    let unshadowed = transmitted_source(&lights, &points, normals, 1.3, None, &source).unwrap();
    let basis = RdBasis::get(state.basis());
    let b_sh = exitance(&state.transfer, basis, &marble, &q_sh);
    let b_old = exitance(&state.transfer, basis, &marble, &q_old);
    let b_open = exitance(&state.transfer, basis, &marble, &unshadowed);
    let error = relative_l2(&b_sh, &b_old);
    let worst = b_sh.iter().zip(&b_old).flat_map(|(a, b)| (0..3).map(move |c| (a[c] / b[c] - 1.0).abs())).fold(0.0, f64::max);
    let shadow = 1.0 - b_old.iter().map(|b| b[1]).sum::<f64>() / b_open.iter().map(|b| b[1]).sum::<f64>();
    eprintln!(
        "SH against sampled: relative L2 {error:.2e}, worst vertex {worst:.2e}; the blocker takes {shadow:.3} of the light"
    );
    assert!(shadow > 0.05, "the blocker shadows the ball ({shadow})");
    assert!(error < 5e-3 && worst < 2e-2, "relative L2 {error:.2e}, worst {worst:.2e}");
}
