//! The profile S through heterogeneous media (issue 21, 3(b); Sheng et al. 2014 eq. 16 and the
//! consistent rule, design/radiosity.md pitfall 4) through the method: layers, voxels and veins
//! bake to finite positive radiance; identical layers are the homogeneous bake; the two rules
//! differ where paths cross media; a session's new medium equals a fresh bake; what the profile
//! S cannot take is refused by name. The matrix entries themselves are checked against a brute
//! force in `radiosity::profile_media`'s unit tests.

use glam::DVec3;
use transcut::light::Light;
use transcut::mesh::icosphere;
use transcut::optics::Medium;
use transcut::radiosity::{HetRule, SolveOptions};
use transcut::volume::{Coefficients, Layers, VeinParams, Veins, VoxelGrid};
use transcut::{
    bake, BakeOptions, MediumSource, Object, OpticalDistance, ProfileKind, ProfileScatteringOptions, Progress, RadiosityOptions,
    Scene, Shape, TranslucentScattering,
};

fn marble() -> Medium {
    Medium { eta: 1.3, ..Medium::preset("marble").unwrap() }
}

/// Marble ten times as absorbing and twice as scattering.
fn dense() -> Medium {
    let m = marble();
    Medium { sigma_a: m.sigma_a.map(|x| 10.0 * x), sigma_s_prime: m.sigma_s_prime.map(|x| 2.0 * x), ..m }
}

fn options(profile: ProfileKind, het: HetRule, distance: OpticalDistance) -> BakeOptions {
    BakeOptions::with_method(RadiosityOptions {
        patch_size_mm: Some(3.0),
        solve: SolveOptions { tolerance: 1e-10, ..SolveOptions::default() },
        scattering: TranslucentScattering::Profile(ProfileScatteringOptions { profile, het, distance, ..Default::default() }),
        ..RadiosityOptions::default()
    })
}

fn dipole(het: HetRule) -> BakeOptions {
    options(ProfileKind::Dipole, het, OpticalDistance::Chord)
}

/// A ball of radius 8 mm of `medium` under a point light above it.
fn ball(medium: MediumSource) -> Scene {
    Scene {
        objects: vec![Object::with_shape("ball", Shape::Surface(icosphere(8.0, 2)), medium, 1.0)],
        lights: vec![Light::Point { position: DVec3::new(10.0, 0.0, 40.0), intensity: [2000.0; 3] }],
    }
}

/// Marble down to 1.5 mm, the dense medium below (no blending).
fn layered() -> MediumSource {
    MediumSource::Layers(Layers::new(&[(1.5, marble()), (f64::INFINITY, dense())], 0.0).unwrap())
}

fn radiance(scene: &Scene, options: &BakeOptions) -> Vec<[f64; 3]> {
    bake(scene, options).unwrap().objects[0].radiance.clone()
}

fn assert_finite_positive(lo: &[[f64; 3]], what: &str) {
    assert!(lo.iter().flatten().all(|x| x.is_finite() && *x >= 0.0), "{what}: not finite or negative");
    let top = lo.iter().flatten().fold(0.0f64, |m, &x| m.max(x));
    assert!(top > 0.0, "{what}: all dark");
}

/// Worst relative difference over values above 10⁻³ of the largest.
fn worst(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let top = b.iter().flatten().fold(0.0f64, |m, &x| m.max(x));
    a.iter()
        .flatten()
        .zip(b.iter().flatten())
        .filter(|(_, &y)| y > 1e-3 * top)
        .map(|(x, y)| (x - y).abs() / y)
        .fold(0.0, f64::max)
}

#[test]
fn layers_bake_under_both_rules_and_the_rules_differ() {
    let scene = ball(layered());
    let consistent = radiance(&scene, &dipole(HetRule::Consistent));
    let sheng = radiance(&scene, &dipole(HetRule::Sheng2014));
    assert_finite_positive(&consistent, "consistent");
    assert_finite_positive(&sheng, "sheng2014");
    // Paths below 1.5 mm cross both media, where eq. 16 and the geometric mean differ.
    let apart = worst(&sheng, &consistent);
    eprintln!("sheng2014 vs consistent: worst {apart:.3}");
    assert!(apart > 0.01, "{apart}");
    // The dense core absorbs: darker than all marble, brighter than all dense (red, lit pole).
    let all_marble = radiance(&ball(marble().into()), &dipole(HetRule::Consistent));
    let all_dense = radiance(&ball(dense().into()), &dipole(HetRule::Consistent));
    let sum = |lo: &[[f64; 3]]| lo.iter().map(|x| x[0]).sum::<f64>();
    assert!(sum(&consistent) < sum(&all_marble) && sum(&consistent) > sum(&all_dense));
}

#[test]
fn identical_layers_are_the_homogeneous_bake() {
    for kind in [ProfileKind::HalfSpace, ProfileKind::Dipole] {
        let same = MediumSource::Layers(Layers::new(&[(1.5, marble()), (f64::INFINITY, marble())], 0.0).unwrap());
        let o = options(kind, HetRule::Consistent, OpticalDistance::Chord);
        let het = radiance(&ball(same), &o);
        let homogeneous = radiance(&ball(marble().into()), &o);
        for (a, b) in het.iter().flatten().zip(homogeneous.iter().flatten()) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "{kind:?}: {a} vs {b}");
        }
    }
}

#[test]
fn voxels_and_veins_bake() {
    // A grid whose lower half is dense: trilinear between the two at z = 0 (quantised).
    let grid = VoxelGrid::from_fn([4, 4, 8], DVec3::splat(-9.0), DVec3::new(4.5, 4.5, 2.25), |p| {
        Coefficients::from(if p.z < 0.0 { dense() } else { marble() })
    })
    .unwrap();
    let voxels = MediumSource::Voxels { grid, eta: 1.3, g: 0.0 };
    let veins = Veins::new(marble(), dense(), 7, VeinParams { period: 6.0, noise_scale: 6.0, ..VeinParams::default() }).unwrap();
    let homogeneous = radiance(&ball(marble().into()), &dipole(HetRule::Consistent));
    for (medium, what) in [(voxels, "voxels"), (MediumSource::Veins(veins), "veins")] {
        let lo = radiance(&ball(medium), &dipole(HetRule::Consistent));
        assert_finite_positive(&lo, what);
        assert!(worst(&lo, &homogeneous) > 0.01, "{what} is the homogeneous marble");
    }
}

#[test]
fn a_session_takes_heterogeneous_media() {
    let scene = ball(marble().into());
    let o = dipole(HetRule::Consistent);
    let coupled = bake(&scene, &o).unwrap().coupled.unwrap();
    let mut session = std::sync::Arc::try_unwrap(coupled).unwrap();
    for (medium, what) in [(layered(), "layers (rebuilt)"), (MediumSource::Homogeneous(dense()), "back to homogeneous (rebuilt)")]
    {
        session.set_medium(0, medium.clone(), Progress::none()).unwrap();
        let fresh = radiance(&ball(medium), &o);
        let got = session.radiance(0).unwrap();
        let off = worst(got, &fresh);
        assert!(off < 1e-6, "{what}: {off} off a fresh bake");
    }
}

#[test]
fn what_the_profile_s_cannot_take_is_named() {
    let message = |scene: &Scene, o: &BakeOptions| bake(scene, o).unwrap_err().to_string();
    let e = message(&ball(MediumSource::Table(vec![marble()])), &dipole(HetRule::Consistent));
    assert!(e.contains("ball") && e.contains("material table") && e.contains("homogeneous"), "{e}");
    let interior = options(ProfileKind::Dipole, HetRule::Consistent, OpticalDistance::INTERIOR);
    let e = message(&ball(layered()), &interior);
    assert!(e.contains("chord") && e.contains("heterogeneous"), "{e}");
    let sheng_half_space = options(ProfileKind::HalfSpace, HetRule::Sheng2014, OpticalDistance::Chord);
    let e = message(&ball(layered()), &sheng_half_space);
    assert!(e.contains("sheng2014") && e.contains("half-space") && e.contains("dipole"), "{e}");
    let glass = Medium { eta: 1.5, ..dense() };
    let mixed = MediumSource::Layers(Layers::new(&[(1.5, marble()), (f64::INFINITY, glass)], 0.0).unwrap());
    let e = message(&ball(mixed), &dipole(HetRule::Consistent));
    assert!(e.contains("one refractive index") && e.contains("1.5"), "{e}");
}
