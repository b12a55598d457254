//! The radiosity session (design/radiosity.md §1.6): every update of a radiosity bake (a light
//! moved, a light's colour, an albedo, an emission, a medium) against a fresh bake of the scene
//! as changed, which computes the form factors and every solve again from nothing; linear
//! combinations of per-light responses exact; warm starts measurably shorter; failures and
//! cancellations change nothing.

use glam::DVec3;
use transcut::light::Light;
use transcut::mesh::{icosphere, TriMesh};
use transcut::optics::Medium;
use transcut::radiosity::SolveOptions;
use transcut::{
    bake, BakeOptions, Diffuse, MediumSource, Object, Progress, RadiosityOptions, Scene, Session, SessionError, Sides,
    TransCutOptions,
};

/// Tight tolerances, so that two solutions of one scene agree to about 1e-5.
fn options() -> BakeOptions {
    BakeOptions::with_method(RadiosityOptions {
        patch_size_mm: Some(8.0),
        solve: SolveOptions { tolerance: 1e-7, ..SolveOptions::default() },
        transcut: TransCutOptions { tets: 20_000, tolerance: 1e-9, ..TransCutOptions::default() },
        ..RadiosityOptions::default()
    })
}

fn marble() -> Medium {
    Medium { eta: 1.3, ..Medium::preset("marble").unwrap() }
}

/// A 100 mm square floor at z = −12 facing up, as two triangles (the patches refine it).
fn floor(albedo: [f64; 3]) -> Object {
    let h = 50.0;
    let mesh =
        TriMesh::from_triangles(&[[-h, -h, -12.0], [h, -h, -12.0], [h, h, -12.0], [-h, h, -12.0]], &[0, 1, 2, 0, 2, 3]).unwrap();
    Object::diffuse("floor", mesh, Diffuse { sides: Sides::Front, ..Diffuse::new(albedo) }, 1.0)
}

fn point(position: DVec3, intensity: [f64; 3]) -> Light {
    Light::Point { position, intensity }
}

/// A marble ball over a red floor, lit by `lights`.
fn scene(lights: Vec<Light>) -> Scene {
    Scene { objects: vec![Object::new("ball", icosphere(10.0, 3), marble(), 1.0), floor([0.7, 0.3, 0.2])], lights }
}

/// The light above the ball, turned by `degrees` about the y axis.
fn above(degrees: f64) -> DVec3 {
    let a = degrees.to_radians();
    DVec3::new(60.0 * a.sin(), 0.0, 60.0 * a.cos())
}

/// The largest relative difference over channels at least 1e-3 of the largest value.
fn worst_relative(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let top = b.iter().flatten().fold(0.0f64, |m, &x| m.max(x));
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c], y[c])))
        .filter(|&(_, y)| y > 1e-3 * top)
        .map(|(x, y)| (x - y).abs() / y)
        .fold(0.0, f64::max)
}

/// Every object of the session against the bake of `scene`.
fn assert_matches_a_fresh_bake(session: &Session, scene: &Scene, what: &str) {
    let fresh = bake(scene, &options()).unwrap();
    for (i, object) in fresh.objects.iter().enumerate() {
        let got = session.radiance(i).unwrap().unwrap();
        let worst = worst_relative(&got, &object.radiance);
        assert!(worst < 1e-4, "{what}: object {i} is {worst} off a fresh bake");
    }
}

/// A light moved 5° is a warm-started solve that agrees with a fresh bake, in fewer sweeps
/// than the bake's; the same light in another colour is its response scaled, with no solve.
#[test]
fn relighting_agrees_with_a_fresh_bake_and_reuses_the_response() {
    let baked_scene = scene(vec![point(above(0.0), [2000.0; 3])]);
    let mut session = Session::bake(&baked_scene, &options(), Progress::none()).unwrap();
    let bake_sweeps = session.radiosity().unwrap().stats().iterations;

    let moved = scene(vec![point(above(5.0), [2000.0; 3])]);
    let stats = session.relight(&moved.lights, Progress::none()).unwrap();
    assert_eq!(stats.len(), 2);
    let update = session.radiosity().unwrap().stats().clone();
    assert_matches_a_fresh_bake(&session, &moved, "moved 5°");
    let fresh_sweeps = bake(&moved, &options()).unwrap().radiosity.unwrap().iterations;
    assert!(
        update.iterations < fresh_sweeps,
        "warm start: {} sweeps, a cold bake {fresh_sweeps} (the first bake {bake_sweeps})",
        update.iterations
    );
    assert!(update.estimated_error <= 1e-7, "{}", update.estimated_error);

    // The same light, coloured: the response scaled exactly, nothing solved.
    let before: Vec<Vec<[f64; 3]>> = (0..2).map(|i| session.radiance(i).unwrap().unwrap()).collect();
    let strength = [1.5, 0.25, 1.0];
    let coloured = scene(vec![point(above(5.0), strength.map(|s| 2000.0 * s))]);
    session.relight(&coloured.lights, Progress::none()).unwrap();
    for (i, old) in before.iter().enumerate() {
        for (new, old) in session.radiance(i).unwrap().unwrap().iter().zip(old) {
            for c in 0..3 {
                assert!((new[c] - strength[c] * old[c]).abs() <= 1e-12 * old[c].max(1e-300), "object {i}: {new:?} vs {old:?}");
            }
        }
    }
    assert_eq!(session.last_update(0).unwrap().unwrap().pieces_solved, 0, "a scaled response solves nothing");
}

/// Two lights: the first relight solves each alone; moving one of them solves that one only;
/// the sum agrees with a fresh bake under both.
#[test]
fn moving_one_light_of_two_solves_only_that_light() {
    let two = |a: f64| vec![point(above(a), [1500.0; 3]), point(DVec3::new(-40.0, 30.0, 20.0), [800.0, 900.0, 1000.0])];
    let mut session = Session::bake(&scene(two(0.0)), &options(), Progress::none()).unwrap();
    session.relight(&two(10.0), Progress::none()).unwrap();
    assert_matches_a_fresh_bake(&session, &scene(two(10.0)), "two lights, the first moved");
    let radiosity = session.radiosity().unwrap();
    let first = radiosity.stats().iterations;
    session.relight(&two(20.0), Progress::none()).unwrap();
    assert_matches_a_fresh_bake(&session, &scene(two(20.0)), "two lights, the first moved again");
    let second = session.radiosity().unwrap().stats().iterations;
    assert!(second < first, "one light solved ({second} sweeps) against both ({first})");
}

/// A new albedo, emission or medium: the scene solved again from the last solution, equal to a
/// fresh bake of the changed scene; an emissive floor's response joins the lights' on the next
/// relight.
#[test]
fn material_changes_agree_with_fresh_bakes() {
    let lights = vec![point(above(0.0), [2000.0; 3])];
    let mut session = Session::bake(&scene(lights.clone()), &options(), Progress::none()).unwrap();

    session.set_albedo(1, [0.2, 0.6, 0.3], Progress::none()).unwrap();
    let mut changed = scene(lights.clone());
    changed.objects[1] = floor([0.2, 0.6, 0.3]);
    assert_matches_a_fresh_bake(&session, &changed, "green floor");

    session.set_emission(1, [3.0, 2.0, 1.0], Progress::none()).unwrap();
    if let Some(d) = changed.objects[1].material.diffuse().copied() {
        changed.objects[1].material = Diffuse { emission: [3.0, 2.0, 1.0], ..d }.into();
    }
    assert_matches_a_fresh_bake(&session, &changed, "glowing floor");

    let m = marble();
    let jade = Medium { sigma_a: m.sigma_a.map(|x| 3.0 * x), sigma_s_prime: m.sigma_s_prime.map(|x| 0.5 * x), eta: 1.5, ..m };
    session.set_medium(0, MediumSource::Homogeneous(jade), Progress::none()).unwrap();
    changed.objects[0].material = MediumSource::Homogeneous(jade).into();
    assert_matches_a_fresh_bake(&session, &changed, "another medium and η");
    assert_eq!(session.eta(0).unwrap(), 1.5, "the session reports the new medium's η");

    // The emission and the light as two responses: a relight is their sum.
    let moved = vec![point(above(5.0), [2000.0; 3])];
    session.relight(&moved, Progress::none()).unwrap();
    changed.lights = moved;
    assert_matches_a_fresh_bake(&session, &changed, "glowing floor, light moved");
}

/// Bad values and wrong kinds are refused by name; a cancelled update and a failed one change
/// nothing; per-object edits are refused naming radiosity.
#[test]
fn failures_change_nothing() {
    let lights = vec![point(above(0.0), [2000.0; 3])];
    let mut session = Session::bake(&scene(lights), &options(), Progress::none()).unwrap();
    let before: Vec<Vec<[f64; 3]>> = (0..2).map(|i| session.radiance(i).unwrap().unwrap()).collect();
    let unchanged = |session: &Session| {
        for (i, old) in before.iter().enumerate() {
            assert_eq!(&session.radiance(i).unwrap().unwrap(), old, "object {i} changed");
        }
    };

    let e = session.set_albedo(1, [1.0, 0.5, 0.5], Progress::none()).unwrap_err();
    assert!(matches!(e, SessionError::Coupled(_)) && e.to_string().contains("albedo") && e.to_string().contains("floor"), "{e}");
    let e = session.set_emission(1, [0.0, f64::NAN, 0.0], Progress::none()).unwrap_err();
    assert!(e.to_string().contains("emission"), "{e}");
    let e = session.set_albedo(0, [0.5; 3], Progress::none()).unwrap_err();
    assert!(e.to_string().contains("ball") && e.to_string().contains("translucent"), "{e}");
    let e = session.set_medium(1, MediumSource::Homogeneous(marble()), Progress::none()).unwrap_err();
    assert!(e.to_string().contains("floor") && e.to_string().contains("opaque"), "{e}");
    let bad = Medium { sigma_a: [-1.0, 0.0, 0.0], ..marble() };
    assert!(session.set_medium(0, MediumSource::Homogeneous(bad), Progress::none()).is_err());
    let e = session.relight(&[point(DVec3::new(f64::NAN, 0.0, 0.0), [1.0; 3])], Progress::none()).unwrap_err();
    assert!(e.to_string().contains("point"), "{e}");
    unchanged(&session);

    let stop = |_: &str, _: f64| false;
    let e = session.relight(&[point(above(5.0), [2000.0; 3])], Progress::new(&stop)).unwrap_err();
    assert!(matches!(e, SessionError::Cancelled(_)), "{e}");
    assert!(matches!(session.set_albedo(1, [0.1; 3], Progress::new(&stop)), Err(SessionError::Cancelled(_))));
    let thicker = Medium { sigma_s_prime: marble().sigma_s_prime.map(|s| 2.0 * s), ..marble() };
    let e = session.set_medium(0, MediumSource::Homogeneous(thicker), Progress::new(&stop)).unwrap_err();
    assert!(matches!(e, SessionError::Cancelled(_)), "{e}");
    unchanged(&session);
    // The old system is back: a relight to the same lights reproduces the radiance (to the
    // rounding of the kept response, which is the solution divided by the light's strength).
    session.relight(&[point(above(0.0), [2000.0; 3])], Progress::none()).unwrap();
    for (i, old) in before.iter().enumerate() {
        assert!(worst_relative(&session.radiance(i).unwrap().unwrap(), old) < 1e-12, "object {i} changed");
    }
    let objects = session.radiosity().unwrap().objects();
    assert!(matches!(objects[0].medium(), Some(MediumSource::Homogeneous(m)) if *m == marble()), "{:?}", objects[0].medium());
    assert_eq!(session.lights().len(), 1);

    // The radiosity bake offers no per-object edits; a TransCut bake no albedo.
    let e = session.fracture(0, Progress::none()).unwrap_err();
    assert!(matches!(e, SessionError::Unsupported { method: "radiosity", .. }), "{e}");
    let ball = Scene { objects: vec![Object::new("ball", icosphere(10.0, 3), marble(), 1.0)], lights: vec![] };
    let transcut = BakeOptions::with_method(TransCutOptions { tets: 20_000, ..TransCutOptions::default() });
    let mut alone = Session::bake(&ball, &transcut, Progress::none()).unwrap();
    let e = alone.set_albedo(0, [0.5; 3], Progress::none()).unwrap_err();
    assert!(matches!(e, SessionError::Unsupported { method: "transcut", .. }), "{e}");
}
