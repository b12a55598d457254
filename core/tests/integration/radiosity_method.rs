//! Translucent radiosity as a method (design/radiosity.md §3, §7: A3 through the bake, A4, A5,
//! A6, A10): opaque objects in scenes, the coupling of translucent objects with them through
//! the TransCut diffusion solve, against closed forms and against TransCut itself.

use glam::DVec3;
use transcut::light::Light;
use transcut::mesh::icosphere;
use transcut::optics::Medium;
use transcut::radiosity::{Iteration, SolveOptions};
use transcut::{bake, Bake, BakeOptions, Diffuse, Object, RadiosityOptions, Scene, SceneError, Sides, TransCutOptions};

/// Radiosity options with `tets` per translucent object, patches of at most `patch_mm`.
fn options(tets: usize, patch_mm: f64, solve: SolveOptions) -> BakeOptions {
    BakeOptions::with_method(RadiosityOptions {
        patch_size_mm: Some(patch_mm),
        solve,
        transcut: TransCutOptions { tets, tolerance: 1e-8, ..TransCutOptions::default() },
        ..RadiosityOptions::default()
    })
}

/// Marble with the architecture's η = 1.3 (the closed forms of design/radiosity.md §3.3).
fn marble() -> Medium {
    Medium { eta: 1.3, ..Medium::preset("marble").unwrap() }
}

/// The largest relative difference between two radiance lists, over channels whose value is at
/// least `floor` of the largest.
fn worst_relative(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let top = b.iter().flatten().fold(0.0f64, |m, &x| m.max(x));
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c], y[c])))
        .filter(|&(_, y)| y > 1e-3 * top)
        .map(|(x, y)| (x - y).abs() / y)
        .fold(0.0, f64::max)
}

/// The inside of a closed sphere of radius R with a point light of intensity I at `light`:
/// every kernel is 1/(4πR²), so B(x) = ρE_d(x) + ρ²Ē/(1 − ρ) with Ē = I/R², and Lo = B/π
/// (design §3.2), here through the whole bake: scene, patches, form factors, direct light.
#[test]
fn the_inside_of_a_closed_sphere_matches_its_closed_form_through_the_bake() {
    let (radius, intensity) = (1.0, 2.0);
    let light = DVec3::new(0.3, -0.2, 0.1);
    for rho in [0.5, 0.9] {
        let room = Diffuse { sides: Sides::Back, ..Diffuse::new([rho; 3]) };
        let scene = Scene {
            objects: vec![Object::diffuse("room", icosphere(radius, 4), room, 1.0)],
            lights: vec![Light::Point { position: light, intensity: [intensity; 3] }],
        };
        let solve = SolveOptions { tolerance: 1e-4, ..SolveOptions::default() };
        let baked = bake(&scene, &options(1, 10.0, solve)).unwrap();
        let stats = baked.radiosity.as_ref().unwrap();
        let mesh = icosphere(radius, 4);
        let expected: Vec<[f64; 3]> = mesh
            .user_to_internal()
            .iter()
            .map(|&v| {
                let x = mesh.positions()[v as usize];
                let to_light = light - x;
                let direct = intensity * (-x.normalize()).dot(to_light.normalize()) / to_light.length_squared();
                let b = rho * direct + rho * rho * intensity / (radius * radius) / (1.0 - rho);
                [b / std::f64::consts::PI; 3]
            })
            .collect();
        let worst = worst_relative(&baked.objects[0].radiance, &expected);
        assert!(worst < 0.02, "ρ = {rho}: worst {worst}");
        assert!(stats.energy_defect < 10.0 * 1e-4, "ρ = {rho}: energy defect {}", stats.energy_defect);
        assert_eq!(stats.translucent_patches, 0);
        assert_eq!(stats.patches, mesh.positions().len());
        // Iterations as the rate ρ predicts: ln(tol)/ln ρ, within 1.2× (A3).
        let predicted = (1e-4f64).ln() / rho.ln();
        assert!((stats.iterations as f64) <= 1.2 * predicted + 2.0, "ρ = {rho}: {} sweeps", stats.iterations);
    }
}

/// A translucent object alone, with one bounce of light: the radiosity bake is its TransCut
/// bake (the same tets, q and solve) to 1e-6 (A6). With every bounce, only the few rays that
/// the tets' nearly convex boundary (its vertices moved onto the surface) sends back to itself
/// add light: never less than TransCut, and less than 0.1% more.
#[test]
fn a_translucent_object_alone_is_its_transcut_bake() {
    let scene = Scene {
        objects: vec![Object::new("ball", icosphere(10.0, 3), marble(), 1.0)],
        lights: vec![Light::Directional {
            direction: DVec3::new(-1.0, -0.5, -0.2),
            irradiance: [1.0; 3],
            angular_diameter_deg: 0.0,
        }],
    };
    let transcut =
        bake(&scene, &BakeOptions::with_method(TransCutOptions { tets: 20_000, tolerance: 1e-8, ..TransCutOptions::default() }))
            .unwrap();
    let one = SolveOptions { bounces: Some(1), ..SolveOptions::default() };
    let radiosity = bake(&scene, &options(20_000, 10.0, one)).unwrap();
    let worst = worst_relative(&radiosity.objects[0].radiance, &transcut.objects[0].radiance);
    assert!(worst < 1e-6, "one bounce: {worst}");
    let all = bake(&scene, &options(20_000, 10.0, SolveOptions::default())).unwrap();
    let worst = worst_relative(&all.objects[0].radiance, &transcut.objects[0].radiance);
    assert!(worst < 1e-3, "every bounce: {worst}");
    for (a, b) in all.objects[0].radiance.iter().zip(&transcut.objects[0].radiance) {
        assert!((0..3).all(|c| a[c] >= b[c] * (1.0 - 1e-9)), "{a:?} below TransCut's {b:?}");
    }
    assert_eq!(all.radiosity.as_ref().unwrap().translucent_patches, all.objects[0].stats.boundary_vertices);
}

/// A strongly absorbing channel lit by a sun has a negative exitance B = (φ − 2q)/(2A) at lit
/// points (TransCut's eq. 3 is negative there too); the radiosity gathers it as it is (the
/// system is linear) and the bake succeeds, its first bounce TransCut's.
#[test]
fn a_negative_exitance_is_gathered_as_it_is() {
    let medium = Medium { sigma_a: [0.002, 0.25, 0.25], sigma_s_prime: [1.0, 0.25, 0.25], eta: 1.3, g: 0.0 };
    // examples/box.obj (2 × 1 × 1) at 30 mm across, as the CLI's fit_size_mm = 30 puts it.
    let block = transcut::mesh::load(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/box.obj")).unwrap();
    let sun = Light::Directional { direction: DVec3::new(0.7, -1.0, 0.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
    let scene = Scene { objects: vec![Object::new("block", block, medium, 30.0 / 6f64.sqrt())], lights: vec![sun] };
    let transcut =
        bake(&scene, &BakeOptions::with_method(TransCutOptions { tets: 8_000, ..TransCutOptions::default() })).unwrap();
    // The CLI's options for this scene (TransCut's tolerance, 256 rays).
    let cli = |solve: SolveOptions| {
        BakeOptions::with_method(RadiosityOptions {
            patch_size_mm: Some(2.5),
            form_factors: transcut::radiosity::FormFactorOptions { rays_per_patch: 256, ..Default::default() },
            solve,
            transcut: TransCutOptions { tets: 8_000, ..TransCutOptions::default() },
            ..RadiosityOptions::default()
        })
    };
    let one = bake(&scene, &cli(SolveOptions { bounces: Some(1), ..SolveOptions::default() })).unwrap();
    assert!(worst_relative(&one.objects[0].radiance, &transcut.objects[0].radiance) < 1e-6);
    for iteration in [Iteration::Jacobi, Iteration::GaussSeidel, Iteration::BiCgStab] {
        let all = bake(&scene, &cli(SolveOptions { iteration, ..SolveOptions::default() })).unwrap();
        assert!(all.objects[0].radiance.iter().flatten().all(|x| x.is_finite() && *x >= 0.0), "{iteration:?}");
    }
}

/// A marble sphere (R = 10 mm, η = 1.3) inside an emissive enclosure (R = 30 mm, ρ = 0.5,
/// M = 1), no lights: the closed forms of design §3.3 (F₁₂ = 1, F₂₁ = 1/9, F₂₂ = 8/9, the
/// uniformly lit sphere's B/q) give the inner Lo(n) and the enclosure's Lo (A4, S through the
/// diffusion solve); inter-reflection never lowers B (A10); the energy balances (A5).
#[test]
fn concentric_spheres_match_their_closed_forms() {
    let enclosure = Diffuse { emission: [1.0; 3], sides: Sides::Back, ..Diffuse::new([0.5; 3]) };
    let scene = Scene {
        objects: vec![
            Object::new("marble", icosphere(10.0, 4), marble(), 1.0),
            Object::diffuse("enclosure", icosphere(30.0, 4), enclosure, 1.0),
        ],
        lights: vec![],
    };
    let solve = SolveOptions { iteration: Iteration::GaussSeidel, tolerance: 1e-4, ..SolveOptions::default() };
    let baked = bake(&scene, &options(210_000, 10.0, solve)).unwrap();
    let stats = baked.radiosity.clone().unwrap();
    let mean = |b: &Bake, o: usize| -> [f64; 3] {
        let r = &b.objects[o].radiance;
        std::array::from_fn(|c| r.iter().map(|x| x[c]).sum::<f64>() / r.len() as f64)
    };
    let (inner, outer) = (mean(&baked, 0), mean(&baked, 1));
    for (got, want, what) in [(inner, [0.59132, 0.56911, 0.54427], "inner"), (outer, [0.62944, 0.62731, 0.62494], "enclosure")] {
        for c in 0..3 {
            let error = (got[c] - want[c]).abs() / want[c];
            assert!(error < 0.01, "{what} channel {c}: {} against {} ({error})", got[c], want[c]);
        }
    }
    assert!(baked.objects[0].stats.tets >= 200_000, "{} tets", baked.objects[0].stats.tets);
    assert!(stats.energy_defect < 10.0 * 1e-4, "energy defect {}", stats.energy_defect);

    // BiCGSTAB and Jacobi reach the same answer at 20k tets.
    let krylov = SolveOptions { iteration: Iteration::BiCgStab, tolerance: 1e-5, ..SolveOptions::default() };
    let jacobi = SolveOptions { tolerance: 1e-5, ..SolveOptions::default() };
    let (k, j) = (bake(&scene, &options(20_000, 10.0, krylov)).unwrap(), bake(&scene, &options(20_000, 10.0, jacobi)).unwrap());
    for o in 0..2 {
        let worst = worst_relative(&k.objects[o].radiance, &j.objects[o].radiance);
        assert!(worst < 1e-4, "object {o}: BiCGSTAB is {worst} off Jacobi");
    }
    let (ks, js) = (k.radiosity.unwrap(), j.radiosity.unwrap());
    assert!(ks.energy_defect < 1e-4 && ks.estimated_error <= 1e-5, "{ks:?}");
    assert!(ks.scatterings < js.scatterings, "BiCGSTAB scattered {} times, Jacobi {}", ks.scatterings, js.scatterings);

    // One bounce: the enclosure's own emission, the sphere lit by it directly; all bounces only add.
    let first = bake(&scene, &options(20_000, 10.0, SolveOptions { bounces: Some(1), ..SolveOptions::default() })).unwrap();
    let again = bake(&scene, &options(20_000, 10.0, SolveOptions::default())).unwrap();
    for o in 0..2 {
        let top = again.objects[o].radiance.iter().flatten().fold(0.0f64, |m, &x| m.max(x));
        for (a, b) in again.objects[o].radiance.iter().zip(&first.objects[o].radiance) {
            for c in 0..3 {
                assert!(a[c] >= b[c] - 1e-9 * top, "object {o}: {a:?} below its first bounce {b:?}");
            }
        }
    }
    // The enclosure alone emits M = 1: Lo = M/π on it after one bounce; the sphere gets none yet.
    assert!(first.objects[1].radiance.iter().all(|l| l.iter().all(|&x| (x - 1.0 / std::f64::consts::PI).abs() < 1e-12)));
    assert!(first.objects[0].radiance.iter().all(|l| l.iter().all(|&x| x == 0.0)));
}

/// Diffuse objects in a scene baked by a method that bakes objects alone are refused by name;
/// bad radiosity input is named, and nothing of the scene changes.
#[test]
fn bad_input_is_named() {
    let wall = || Object::diffuse("wall", icosphere(30.0, 2), Diffuse::new([0.5; 3]), 1.0);
    let ball = || Object::new("ball", icosphere(10.0, 2), marble(), 1.0);
    let lights = vec![Light::Point { position: DVec3::new(0.0, 0.0, 20.0), intensity: [1.0; 3] }];
    let scene = Scene { objects: vec![ball(), wall()], lights: lights.clone() };
    let e = bake(&scene, &BakeOptions::default()).unwrap_err();
    assert!(matches!(e, SceneError::Unsupported { index: 1, method: "transcut", .. }), "{e}");
    assert!(e.to_string().contains("radiosity"), "{e}");

    let bad =
        |objects: Vec<Object>, options: &BakeOptions| bake(&Scene { objects, lights: lights.clone() }, options).unwrap_err();
    let o = options(2_000, 10.0, SolveOptions::default());
    let white = Object::diffuse("white", icosphere(30.0, 2), Diffuse::new([1.0, 0.5, 0.5]), 1.0);
    let e = bad(vec![white], &o);
    assert!(matches!(e, SceneError::InvalidObject { index: 0, .. }) && e.to_string().contains("albedo"), "{e}");
    let glowing = Object::diffuse("glow", icosphere(30.0, 2), Diffuse { emission: [-1.0, 0.0, 0.0], ..Diffuse::default() }, 1.0);
    assert!(bad(vec![glowing], &o).to_string().contains("emission"));
    let mut inches = wall();
    inches.mm_per_unit = 25.4;
    let e = bad(vec![ball(), inches], &o);
    assert!(e.to_string().contains("mm_per_unit") && e.to_string().contains("wall"), "{e}");
    let zero = BakeOptions::with_method(RadiosityOptions { patch_size_mm: Some(0.0), ..RadiosityOptions::default() });
    assert!(bad(vec![wall()], &zero).to_string().contains("patch_size_mm"));
    let tiny = BakeOptions::with_method(RadiosityOptions { patch_size_mm: Some(1e-6), ..RadiosityOptions::default() });
    let e = bad(vec![wall()], &tiny);
    assert!(e.to_string().contains("wall") && e.to_string().contains("patch_size_mm"), "{e}");
    // Opaque objects only: plain radiosity, fine.
    assert!(bake(&Scene { objects: vec![wall()], lights }, &o).is_ok());
}
