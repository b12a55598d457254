//! The hierarchical dipole on the device (`gpu::GpuDipole`, `shaders/dipole_*.wgsl`) against
//! its CPU twin (the same hierarchy's on-the-fly update, in f64) kernel by kernel and over
//! deforming frames, and against what does not depend on either: the O(n²) sum and the uniform
//! sphere's closed form (design/hierarchical-dipole.md §3.2, §3.4).
//!
//! These tests need a GPU adapter (lavapipe where no GPU is present; see `gpu.rs`).
#![cfg(feature = "gpu")]

mod dipole_common;
mod gpu_common;
use dipole_common::{displaced, errors, go, hierarchy, marble, moved_mesh, sun_lit_from};
use gpu_common::{device, lock};

use transcut::gpu::{GpuDipole, GpuError};
use transcut::hierarchy::{
    reference_quadratic, DipoleHierarchy, DipoleOptions, DipoleRadiance, HierarchyError, Oracle, Receivers,
};
use transcut::light::Light;
use transcut::mesh::icosphere;
use transcut::optics::{f_ext, DipoleGeometry, EdgeRule};
use transcut::volume::noise::PerlinNoise;
use transcut::DVec3;

/// q at every vertex under a sun from a direction off every axis (irradiance 3), no shadows.
fn sun_lit(h: &DipoleHierarchy) -> Vec<[f64; 3]> {
    sun_lit_from(h, DVec3::new(-0.3, -0.2, -1.0).normalize())
}

#[test]
fn the_device_refit_matches_the_cpu_refit_node_by_node() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let base = icosphere(10.0, 4);
    for receivers in [Receivers::Vertices, Receivers::FaceCentroids] {
        let mut h = hierarchy(&base, DipoleOptions { receivers, ..DipoleOptions::default() });
        let mut gpu = GpuDipole::for_device(ctx, &mut h).unwrap();
        let moved = displaced(&base, &PerlinNoise::new(3), 5);
        h.set_positions(&moved).unwrap();
        gpu.set_positions(&moved).unwrap();
        let (emitters, receiving) = gpu.trees().unwrap();
        let total_area = h.emitter_tree().node(0).weight;
        for (name, cpu, dev) in [("emitter", h.emitter_tree(), &emitters), ("receiver", h.receiver_tree(), &receiving)] {
            assert_eq!(cpu.nodes().len(), dev.len());
            let (mut centre, mut radius, mut weight, mut normal) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            for (c, g) in cpu.nodes().iter().zip(dev) {
                assert_eq!((c.leaf, c.right_or_item), (g.leaf, g.right_or_item), "{name}: the topology is kept");
                centre = centre.max(c.centre.distance(g.centre));
                radius = radius.max((c.radius - g.radius).abs());
                weight = weight.max((c.weight - g.weight).abs() / c.weight);
                // Normals of coherent patches (a closed surface's large clusters have none).
                if name == "emitter" && c.weight < 0.01 * total_area {
                    normal = normal.max(c.normal.distance(g.normal));
                }
            }
            eprintln!(
                "{receivers:?} {name}: centre {centre:.1e} mm, radius {radius:.1e} mm, weight {weight:.1e}, normal {normal:.1e}"
            );
            // f32 carries 6e-8 relative: about 1e-6 mm on a 10 mm sphere per rounding, and the
            // refit's weighted means and distances add a few per level over 13 levels.
            assert!(centre < 2e-5 && radius < 2e-5, "{name}: centre {centre}, radius {radius}");
            assert!(weight < 1e-5 && normal < 1e-4, "{name}: weight {weight}, normal {normal}");
        }
    }
}

#[test]
fn the_device_traversal_twins_the_cpu_on_the_fly_update() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mesh = icosphere(10.0, 4);
    let cases = [
        ("θ 0.4, Gauss–Legendre, vertices", DipoleOptions::default()),
        (
            "θ 0.6, the paper's midpoint rule, face centroids",
            DipoleOptions {
                oracle: Oracle::OpeningAngle { theta: 0.6 },
                rule: EdgeRule::PaperMidpoint { max_l_over_r: 0.4, sigma_rule: true },
                receivers: Receivers::FaceCentroids,
                ..DipoleOptions::default()
            },
        ),
        ("the paper's oracle", DipoleOptions { oracle: Oracle::Paper { eps1: 0.05, eps2: 0.05 }, ..DipoleOptions::default() }),
    ];
    for (name, options) in cases {
        let mut h = hierarchy(&mesh, options);
        let mut gpu = GpuDipole::for_device(ctx, &mut h).unwrap();
        let q = sun_lit(&h);
        let (cpu, cpu_stats) = h.update(&q, &go).unwrap();
        let (dev, stats) = gpu.update(&q).unwrap();
        let (rms, max) = errors(&dev, &cpu);
        eprintln!(
            "{name}: GPU vs CPU RMS {rms:.1e}, max {max:.1e}; links {} vs {} ({} vs {} near), {} tasks",
            stats.links, cpu_stats.links, stats.near_links, cpu_stats.near_links, stats.tasks
        );
        // f32 against f64 through the same links: a few 1e-6 of the peak per link sum; an
        // oracle decision on the edge of θ may go the other way in f32 (both are accurate).
        assert!(rms < 1e-5 && max < 5e-5, "{name}: RMS {rms}, max {max}");
        let off = (stats.links as f64 / cpu_stats.links as f64 - 1.0).abs();
        assert!(off < 1e-4, "{name}: {} links on the device, {} on the CPU", stats.links, cpu_stats.links);
        assert!(stats.near_links > 0 && stats.links > stats.near_links);
    }
}

#[test]
fn the_device_meets_the_closed_form_and_the_quadratic_sum() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mesh = icosphere(10.0, 4);
    let mut h = hierarchy(&mesh, DipoleOptions::default());
    let mut gpu = GpuDipole::for_device(ctx, &mut h).unwrap();
    // The uniform sphere: Lo = (0.8465, 0.8187, 0.7875) from B = q ∫₀^{2R} Rd 2πr dr.
    let q = std::f64::consts::PI * (1.0 - f_ext(1.3));
    let scale = DipoleRadiance::MatchTransCut.per_exitance(1.3);
    let (b, _) = gpu.update(&vec![[q; 3]; mesh.positions().len()]).unwrap();
    for (c, want) in [0.8465, 0.8187, 0.7875].into_iter().enumerate() {
        let got = b.iter().map(|x| x[c] * scale).sum::<f64>() / b.len() as f64;
        assert!((got / want - 1.0).abs() < 0.01, "channel {c}: {got} vs {want}");
    }
    // The sun-lit sphere against the O(n²) sum: the gates for the hierarchy.
    let lit = sun_lit(&h);
    let reference = reference_quadratic(&h, &lit).unwrap();
    let (b, _) = gpu.update(&lit).unwrap();
    let (rms, max) = errors(&b, &reference);
    eprintln!("GPU vs O(n²): RMS {rms:.2e}, max {max:.2e}");
    assert!(rms < 0.006 && max < 0.025, "RMS {rms}, max {max}");
}

#[test]
fn deforming_frames_on_the_device_twin_the_cpu_frame_by_frame() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let base = icosphere(10.0, 3);
    let noise = PerlinNoise::new(11);
    let mut h = hierarchy(&base, DipoleOptions::default());
    let mut gpu = GpuDipole::for_device(ctx, &mut h).unwrap();
    let mut worst = (0.0f64, 0.0f64);
    for frame in 1..=8 {
        let moved = displaced(&base, &noise, frame);
        h.set_positions(&moved).unwrap();
        gpu.set_positions(&moved).unwrap();
        let q = sun_lit(&h);
        let (cpu, _) = h.update(&q, &go).unwrap();
        let (dev, stats) = gpu.update(&q).unwrap();
        let (rms, max) = errors(&dev, &cpu);
        worst = (worst.0.max(rms), worst.1.max(max));
        assert!(stats.refit_ms > 0.0 && stats.traverse_ms > 0.0, "frame {frame}: {stats:?}");
    }
    eprintln!("8 frames: worst RMS {:.1e}, max {:.1e}", worst.0, worst.1);
    assert!(worst.0 < 1e-5 && worst.1 < 5e-5, "{worst:?}");
}

#[test]
fn bad_input_is_refused_by_name_and_changes_nothing() {
    let _g = lock();
    let Some(ctx) = device() else { return };
    let mesh = icosphere(10.0, 2);
    let paper = hierarchy(&mesh, DipoleOptions { geometry: DipoleGeometry::PaperSources, ..DipoleOptions::default() });
    match GpuDipole::new(ctx, &paper) {
        Err(GpuError::Unsupported { what }) => assert!(what.contains("PaperSources"), "{what}"),
        other => panic!("the paper geometry on the GPU: {other:?}"),
    }
    let mut h = hierarchy(&mesh, DipoleOptions::default());
    let mut gpu = GpuDipole::for_device(ctx, &mut h).unwrap();
    let q = sun_lit(&h);
    let (before, _) = gpu.update(&q).unwrap();
    let n = mesh.positions().len();
    assert!(matches!(
        gpu.set_positions(&mesh.positions()[1..]),
        Err(GpuError::Hierarchy(HierarchyError::WrongLength { what: "positions", expected, got })) if expected == n && got == n - 1
    ));
    let mut bad = mesh.positions().to_vec();
    bad[7].y = f64::NAN;
    assert!(matches!(gpu.set_positions(&bad), Err(GpuError::Hierarchy(HierarchyError::NonFinite { vertex: 7, .. }))));
    let mut dark = q.clone();
    dark[3][1] = -1.0;
    assert!(matches!(gpu.update(&dark), Err(GpuError::Hierarchy(HierarchyError::InvalidIrradiance { vertex: 3, .. }))));
    assert!(matches!(gpu.update(&q[1..]), Err(GpuError::Hierarchy(HierarchyError::WrongLength { what: "irradiance", .. }))));
    let (after, _) = gpu.update(&q).unwrap();
    assert_eq!(before, after, "failed calls changed nothing");
}

#[test]
fn transcut_backend_gpu_bakes_and_deforms_a_session_on_the_device() {
    use transcut::gpu::{Backend, BACKEND_ENV};
    use transcut::hierarchy::EvalMode;
    use transcut::{bake, BakeOptions, Object, Progress, Scene, SceneError, Session};
    let _g = lock();
    let Some(ctx) = device() else { return };
    let base = icosphere(10.0, 3);
    let lights =
        vec![Light::Directional { direction: DVec3::new(0.2, 0.1, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 }];
    let scene = Scene { objects: vec![Object::new("ball", base.clone(), marble(), 1.0)], lights };
    let options = BakeOptions::with_method(DipoleOptions::default());
    std::env::set_var(BACKEND_ENV, "cpu");
    let cpu = bake(&scene, &options).unwrap();
    std::env::set_var(BACKEND_ENV, "gpu");
    let on_device = bake(&scene, &options);
    let mut session = Session::bake(&scene, &options, Progress::none());
    let render = bake(&scene, &BakeOptions::with_method(DipoleOptions { mode: EvalMode::Render, ..DipoleOptions::default() }));
    std::env::remove_var(BACKEND_ENV);

    let on_device = on_device.unwrap();
    let stats = &on_device.objects[0].stats;
    assert_eq!(stats.backend, Backend::Gpu);
    assert_eq!(stats.device.as_deref(), Some(ctx.device_name()));
    // The device cuts the receivers finer than the CPU's default (links never cross a cut), so
    // the two are two approximations of the same sum, each within 0.05% RMS of the O(n²) one.
    let (rms, max) = errors(&on_device.objects[0].radiance, &cpu.objects[0].radiance);
    eprintln!("bake on the device vs the CPU: RMS {rms:.1e}, max {max:.1e}");
    assert!(rms < 1e-3 && max < 5e-3, "RMS {rms}, max {max}");

    // A deformed pose on the device against a fresh CPU bake of it.
    let session = session.as_mut().unwrap();
    let pose = displaced(&base, &PerlinNoise::new(11), 4);
    let as_arrays: Vec<[f64; 3]> = pose.iter().map(|p| p.to_array()).collect();
    session.set_positions(0, &as_arrays, Progress::none()).unwrap();
    let moved = moved_mesh(&base, &pose);
    let fresh = bake(&Scene { objects: vec![Object::new("ball", moved, marble(), 1.0)], lights: scene.lights.clone() }, &options)
        .unwrap();
    let (rms, max) = errors(&session.radiance(0).unwrap().unwrap(), &fresh.objects[0].radiance);
    assert!(rms < 1e-3 && max < 5e-3, "deformed on the device: RMS {rms}, max {max}");

    // Render mode keeps its links on the CPU: TRANSCUT_BACKEND=gpu refuses it by name.
    match render {
        Err(SceneError::Gpu { source: GpuError::Unsupported { what }, .. }) => assert!(what.contains("render"), "{what}"),
        other => panic!("render mode on the GPU: {:?}", other.map(|_| ())),
    }
}
