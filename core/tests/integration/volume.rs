//! Heterogeneous media (`transcut::volume`): the TCVOX1 voxel file format, trilinear sampling,
//! per-tet averaging, depth layers on a meshed sphere, marble veins, and the hand-off to the
//! diffusion assembly.

#![allow(clippy::needless_range_loop)] // per-channel loops read best indexed

use std::path::PathBuf;
use std::sync::OnceLock;

use transcut::diffusion::assemble;
use transcut::mesh::TetMesh;
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::Medium;
use transcut::volume::{Coefficients, Layers, PerTetMedia, TableLayout, TetSampling, VeinParams, Veins, VolumeError, VoxelGrid};
use transcut::DVec3;

/// Sphere radius (scene units = mm).
const RADIUS: f64 = 10.0;

use crate::common;
use common::uv_sphere;

/// The sphere of radius [`RADIUS`] meshed with about 20 000 tets, built once.
fn sphere() -> &'static TetMesh {
    static MESH: OnceLock<TetMesh> = OnceLock::new();
    MESH.get_or_init(|| tetrahedralize(&uv_sphere(RADIUS, 96, 48), &MesherOptions::with_tets(20_000)).unwrap())
}

/// A fresh path in the temporary directory for this test.
fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("transcut-volume-{}-{name}.tcvox", std::process::id()))
}

/// Writes `bytes` to a temporary file, reads it as a voxel grid and removes it.
fn read_bytes(name: &str, bytes: &[u8]) -> Result<VoxelGrid, VolumeError> {
    let path = temp_path(name);
    std::fs::write(&path, bytes).unwrap();
    let result = VoxelGrid::read(&path);
    std::fs::remove_file(&path).unwrap();
    result
}

fn marble() -> Medium {
    Medium::preset("marble").unwrap()
}

/// A TCVOX1 header for the given dims and channel count, origin 0, voxel size 1.
fn header(dims: [u32; 3], channels: u32) -> Vec<u8> {
    let mut b = b"TCVOX1\0\0".to_vec();
    for d in dims {
        b.extend_from_slice(&d.to_le_bytes());
    }
    b.extend_from_slice(&channels.to_le_bytes());
    for v in [0.0f64, 0.0, 0.0, 1.0, 1.0, 1.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b
}

/// An irregular but valid grid (values with full f32 mantissas).
fn irregular_grid() -> VoxelGrid {
    VoxelGrid::from_fn([7, 5, 3], DVec3::new(-1.25, 0.5, 3.0), DVec3::new(0.3, 0.7, 1.1), |p| {
        let s = (3.1 * p.x).sin() * (1.7 * p.y).cos() + 0.37 * p.z;
        Coefficients::new([0.01 + s.abs() * 0.1, 0.02, 0.003 * (1.0 + s * s)], [1.0 + 0.5 * s.sin(), 2.0, 2.5 + s.cos()])
    })
    .unwrap()
}

#[test]
fn voxel_file_round_trip_is_identical() {
    let grid = irregular_grid();
    let path = temp_path("round-trip");
    grid.write(&path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes.len(), 72 + 24 * 7 * 5 * 3);
    assert_eq!(bytes, grid.to_bytes());
    let back = VoxelGrid::read(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(back, grid);
    assert_eq!(back.dims(), [7, 5, 3]);
    assert_eq!(back.origin(), DVec3::new(-1.25, 0.5, 3.0));
    assert_eq!(back.voxel_size(), DVec3::new(0.3, 0.7, 1.1));
    // Bit-identical values, and writing again gives the same bytes.
    assert!(back.data().iter().zip(grid.data()).all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(back.to_bytes(), bytes);
}

#[test]
fn trilinear_sampling_is_exact_on_a_linear_field() {
    // Dyadic origin, spacing and coefficients: the values at the voxel centres are exact in f32.
    let f = |p: DVec3| 3.0 + 0.5 * p.x + 0.25 * p.y - 0.125 * p.z;
    let grid = VoxelGrid::from_fn([7, 5, 4], DVec3::new(-1.5, 0.25, 2.0), DVec3::new(0.5, 0.25, 0.125), |p| {
        Coefficients::new([f(p), 2.0 * f(p), 0.5], [f(p) - 1.0, 1.0, 4.0 * f(p)])
    })
    .unwrap();
    for i in 0..7 {
        for j in 0..5 {
            for k in 0..4 {
                let c = grid.voxel_centre([i, j, k]);
                assert_eq!(grid.voxel([i, j, k]).unwrap().sigma_a[0], f(c));
            }
        }
    }
    let (lo, hi) = grid.bounds();
    let (clo, chi) = (lo + 0.5 * grid.voxel_size(), hi - 0.5 * grid.voxel_size());
    let mut state = 0x1234_5678_u64;
    let mut uniform = || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    for _ in 0..2000 {
        let t = DVec3::new(uniform(), uniform(), uniform());
        let p = clo + t * (chi - clo);
        let c = grid.sample(p);
        let v = f(p);
        for (got, expect) in c.to_array().iter().zip([v, 2.0 * v, 0.5, v - 1.0, 1.0, 4.0 * v]) {
            assert!((got - expect).abs() < 1e-13 * expect.abs().max(1.0), "{p}: {got} vs {expect}");
        }
    }
    // Outside the box of voxel centres the grid is clamped to the border.
    for p in [DVec3::new(-50.0, 0.3, 2.2), DVec3::new(0.0, 40.0, -3.0), DVec3::new(1e12, -1e12, 1e12)] {
        let q = p.clamp(clo, chi);
        assert!((grid.sample(p).sigma_a[0] - f(q)).abs() < 1e-13 * f(q));
    }
}

#[test]
fn per_tet_averaging_of_a_constant_grid_gives_the_constant() {
    let constant = Coefficients::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.0]);
    // Exactly the f32 values the grid stores.
    let stored = Coefficients::from_array(constant.to_array().map(|v| f64::from(v as f32)));
    // The grid covers only the middle of the sphere: the rest is clamped to its border.
    let grid = VoxelGrid::from_fn([6, 4, 5], DVec3::splat(-3.0), DVec3::new(1.0, 1.5, 1.2), |_| constant).unwrap();
    let mesh = sphere();
    for sampling in [TetSampling::FivePoint, TetSampling::Centroid] {
        let media = grid.per_tet(mesh, 1.3, 0.0, sampling).unwrap();
        assert_eq!(media.len(), mesh.tet_count());
        assert_eq!(media.eta(), 1.3);
        for c in media.coefficients() {
            for (got, expect) in c.to_array().iter().zip(stored.to_array()) {
                assert!((got - expect).abs() <= 4.0 * f64::EPSILON * expect, "{got} vs {expect}");
            }
        }
    }
}

#[test]
fn per_tet_averaging_of_a_linear_grid_is_the_centroid_value() {
    // Inside the box of voxel centres, a linear field is sampled exactly, and the five-point
    // rule is exact for linear fields: every tet gets the value at its centroid.
    let f = |p: DVec3| 2.0 + 0.0625 * p.x + 0.03125 * p.y + 0.015625 * p.z;
    let grid =
        VoxelGrid::from_fn([48, 48, 48], DVec3::splat(-12.0), DVec3::splat(0.5), |p| Coefficients::new([f(p); 3], [1.0; 3]))
            .unwrap();
    let mesh = sphere();
    let media = grid.per_tet(mesh, 1.3, 0.0, TetSampling::FivePoint).unwrap();
    for t in 0..mesh.tet_count() {
        let p = mesh.tet_positions(t);
        let centroid = (p[0] + p[1] + p[2] + p[3]) / 4.0;
        assert!((media.coefficients()[t].sigma_a[1] - f(centroid)).abs() < 1e-12);
    }
}

#[test]
fn every_bad_file_gives_its_error() {
    let valid = irregular_grid().to_bytes();
    let path_of = |e: &VolumeError| match e {
        VolumeError::VoxelFile { path, .. } => path.clone(),
        other => panic!("not wrapped in VoxelFile: {other}"),
    };

    // Bad magic.
    let mut bytes = valid.clone();
    bytes[..8].copy_from_slice(b"TCVOX2\0\0");
    let e = read_bytes("magic", &bytes).unwrap_err();
    assert!(path_of(&e).ends_with(format!("transcut-volume-{}-magic.tcvox", std::process::id())));
    assert!(matches!(e.root(), VolumeError::BadMagic { found } if found == b"TCVOX2\0\0"), "{e}");
    assert!(e.to_string().contains("not a TCVOX1 voxel file"), "{e}");
    assert!(e.to_string().contains("magic.tcvox"), "{e}");

    // Truncated header.
    let e = read_bytes("short-header", &valid[..40]).unwrap_err();
    assert!(matches!(e.root(), VolumeError::Truncated { part: "header", expected: 72, found: 40 }), "{e}");
    assert!(e.to_string().contains("truncated header: expected 72 bytes, found 40"), "{e}");

    // Truncated data: 7·5·3 voxels need 72 + 2520 = 2592 bytes.
    let e = read_bytes("short-data", &valid[..valid.len() - 3]).unwrap_err();
    assert!(matches!(e.root(), VolumeError::Truncated { part: "voxel data", expected: 2592, found: 2589 }), "{e}");
    assert!(e.to_string().contains("truncated voxel data: expected 2592 bytes, found 2589"), "{e}");

    // Trailing bytes.
    let mut long = valid.clone();
    long.extend_from_slice(&[0; 8]);
    let e = read_bytes("long", &long).unwrap_err();
    assert!(matches!(e.root(), VolumeError::TrailingBytes { expected: 2592, found: 2600 }), "{e}");
    assert!(e.to_string().contains("8 unexpected bytes after the voxel data"), "{e}");

    // NaN: voxel (2, 1, 0) has linear index 2 + 7·1 = 9; channel 4 is σ′s green.
    let mut nan = valid.clone();
    let at = 72 + 4 * (6 * 9 + 4);
    nan[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let e = read_bytes("nan", &nan).unwrap_err();
    assert!(
        matches!(e.root(), VolumeError::InvalidVoxel { voxel: [2, 1, 0], index: 9, channel: 4, value, .. } if value.is_nan()),
        "{e}"
    );
    assert!(e.to_string().contains("voxel (2, 1, 0) (linear index 9), channel 4 (sigma_s_prime green): value NaN"), "{e}");

    // Negative: voxel (6, 4, 2) is the last one, index 104; channel 0 is σa red.
    let mut negative = valid.clone();
    let at = 72 + 4 * (6 * 104);
    negative[at..at + 4].copy_from_slice(&(-0.5f32).to_le_bytes());
    let e = read_bytes("negative", &negative).unwrap_err();
    assert!(
        matches!(e.root(), VolumeError::InvalidVoxel { voxel: [6, 4, 2], index: 104, channel: 0, value, .. } if *value == -0.5),
        "{e}"
    );
    assert!(e.to_string().contains("channel 0 (sigma_a red): value -0.5: must be finite and >= 0"), "{e}");

    // Infinite values are rejected too.
    let mut inf = valid.clone();
    inf[72..76].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let e = read_bytes("inf", &inf).unwrap_err();
    assert!(matches!(e.root(), VolumeError::InvalidVoxel { voxel: [0, 0, 0], channel: 0, .. }), "{e}");

    // Zero dimensions.
    let e = read_bytes("zero", &header([4, 0, 2], 6)).unwrap_err();
    assert!(matches!(e.root(), VolumeError::ZeroDimension { dims: [4, 0, 2] }), "{e}");
    assert!(e.to_string().contains("grid dimensions 4x0x2"), "{e}");

    // Other channel counts.
    let mut three = header([1, 1, 1], 3);
    three.extend_from_slice(&[0; 12]);
    let e = read_bytes("channels", &three).unwrap_err();
    assert!(matches!(e.root(), VolumeError::UnsupportedChannels { found: 3 }), "{e}");

    // Zero voxel size.
    let mut flat = header([1, 1, 1], 6);
    flat[48..56].copy_from_slice(&0.0f64.to_le_bytes());
    flat.extend_from_slice(&[0; 24]);
    let e = read_bytes("flat", &flat).unwrap_err();
    assert!(matches!(e.root(), VolumeError::InvalidGeometry { field: "voxel_size", .. }), "{e}");

    // A missing file is an I/O error naming it.
    let missing = temp_path("missing");
    let e = VoxelGrid::read(&missing).unwrap_err();
    assert!(matches!(&e, VolumeError::Io { path, .. } if *path == missing), "{e}");
}

#[test]
fn layers_on_a_meshed_sphere_follow_the_depth() {
    let mesh = sphere();
    assert!((mesh.tet_count() as f64 - 20_000.0).abs() < 0.3 * 20_000.0, "{} tets", mesh.tet_count());
    let epidermis = Medium::preset("skin1").unwrap();
    let dermis = Medium { sigma_a: [0.05, 0.1, 0.2], sigma_s_prime: [1.5, 1.8, 2.0], ..epidermis };
    let fat = Medium { sigma_a: [0.002, 0.003, 0.004], sigma_s_prime: [1.0, 1.0, 1.0], ..epidermis };
    // The tets are about 1.35 mm across: layers thick enough to hold the boundary tets' centroids.
    let layers = Layers::new(&[(1.2, epidermis), (4.0, dermis), (f64::INFINITY, fat)], 0.2).unwrap();
    let field = layers.field(mesh, 1.0).unwrap();
    let media = layers.per_tet(mesh, 1.0, TetSampling::Centroid).unwrap();
    assert_eq!((media.eta(), media.g()), (epidermis.eta, epidermis.g));

    let centroid = |t: usize| {
        let p = mesh.tet_positions(t);
        (p[0] + p[1] + p[2] + p[3]) / 4.0
    };
    // The depth is the distance to the (faceted) sphere.
    for t in (0..mesh.tet_count()).step_by(7) {
        let c = centroid(t);
        let (depth, expect) = (field.depth_mm(c), RADIUS - c.length());
        // The boundary is inscribed in the sphere: at most the sagitta of its faces closer.
        assert!(depth <= expect + 1e-9 && depth > expect - 0.1, "tet {t} at {c}: depth {depth}, R - |c| = {expect}");
    }
    // Every tet on the surface gets the outer layer.
    let mut on_surface = vec![false; mesh.tet_count()];
    for f in mesh.boundary_faces() {
        on_surface[f.tet as usize] = true;
    }
    let outer = Coefficients::from(&epidermis);
    for t in (0..mesh.tet_count()).filter(|&t| on_surface[t]) {
        assert_eq!(media.coefficients()[t], outer, "tet {t} at depth {}", field.depth_mm(centroid(t)));
    }
    // The centre gets the innermost layer, and so does everything deeper than 4.1 mm.
    let inner = Coefficients::from(&fat);
    let middle = Coefficients::from(&dermis);
    let mut counts = [0usize; 3];
    for t in 0..mesh.tet_count() {
        let depth = field.depth_mm(centroid(t));
        let c = media.coefficients()[t];
        if depth < 1.1 {
            assert_eq!(c, outer);
            counts[0] += 1;
        } else if depth > 1.3 && depth < 3.9 {
            assert_eq!(c, middle);
            counts[1] += 1;
        } else if depth > 4.1 {
            assert_eq!(c, inner);
            counts[2] += 1;
        }
        if centroid(t).length() < 2.0 {
            assert_eq!(c, inner, "tet {t} near the centre");
        }
    }
    assert!(counts.iter().all(|&n| n > 500), "{counts:?}");
    // The tet containing the centre.
    let centre_tet = (0..mesh.tet_count()).min_by(|&a, &b| centroid(a).length().total_cmp(&centroid(b).length())).unwrap();
    assert_eq!(media.coefficients()[centre_tet], inner);
}

#[test]
fn veins_are_deterministic_for_a_seed_and_differ_between_seeds() {
    let mesh = sphere();
    let base = marble();
    let vein = Medium { sigma_a: [0.08, 0.09, 0.1], sigma_s_prime: [0.8, 0.9, 1.0], ..base };
    let params = VeinParams { period: 4.0, noise_scale: 5.0, direction: DVec3::new(1.0, 0.4, 0.2), ..VeinParams::default() };
    let a = Veins::new(base, vein, 11, params).unwrap().per_tet(mesh, TetSampling::FivePoint).unwrap();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = one.install(|| Veins::new(base, vein, 11, params).unwrap().per_tet(mesh, TetSampling::FivePoint).unwrap());
    assert_eq!(a, b, "same seed, same media (bit-identical, any thread count)");
    let c = Veins::new(base, vein, 12, params).unwrap().per_tet(mesh, TetSampling::FivePoint).unwrap();
    let differ = a.coefficients().iter().zip(c.coefficients()).filter(|(x, y)| x != y).count();
    assert!(differ > mesh.tet_count() / 2, "only {differ} tets differ between seeds");
    assert_eq!((a.eta(), a.g()), (base.eta, base.g));
}

#[test]
fn vein_volume_mean_lies_between_the_two_media() {
    let mesh = sphere();
    let base = marble();
    let vein = Medium { sigma_a: [0.08, 0.09, 0.1], sigma_s_prime: [0.8, 0.9, 1.0], ..base };
    for seed in [1, 2, 3] {
        let veins = Veins::new(base, vein, seed, VeinParams { period: 3.0, noise_scale: 4.0, ..VeinParams::default() }).unwrap();
        let media = veins.per_tet(mesh, TetSampling::FivePoint).unwrap();
        let mean = media.volume_mean(mesh).unwrap().to_array();
        let (b, v) = (Coefficients::from(&base).to_array(), Coefficients::from(&vein).to_array());
        for ch in 0..6 {
            let (lo, hi) = (b[ch].min(v[ch]), b[ch].max(v[ch]));
            // Strictly inside, and not pinned to either end: both media are present.
            let s = (mean[ch] - lo) / (hi - lo);
            assert!(s > 0.02 && s < 0.98, "seed {seed}, channel {ch}: mean {} at {s} of [{lo}, {hi}]", mean[ch]);
        }
        // Each tet is a convex combination too.
        for c in media.coefficients() {
            for ch in 0..3 {
                let (lo, hi) = (b[ch].min(v[ch]), b[ch].max(v[ch]));
                assert!(c.sigma_a[ch] >= lo - 1e-15 && c.sigma_a[ch] <= hi + 1e-15);
            }
        }
    }
}

/// The largest absolute difference between two equally long 3-channel arrays (∞ otherwise).
fn max_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    if a.len() != b.len() {
        return f64::INFINITY;
    }
    a.iter().zip(b).flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs())).fold(0.0, f64::max)
}

#[test]
fn per_tet_media_plug_into_the_diffusion_assembly() {
    // A material table, re-expressed as per-tet media, assembles to the same matrix in both
    // layouts.
    let base = sphere().clone();
    let skin = Medium { eta: marble().eta, ..Medium::preset("skin1").unwrap() };
    let table = [marble(), skin];
    let ids: Vec<u32> = (0..base.tet_count())
        .map(|t| {
            let p = base.tet_positions(t);
            u32::from((p[0] + p[1] + p[2] + p[3]).x > 0.0)
        })
        .collect();
    let mut reference_mesh = base.clone();
    reference_mesh.set_materials(ids).unwrap();
    let reference = assemble(&reference_mesh, &table, 1.0).unwrap();
    let media = PerTetMedia::from_materials(&reference_mesh, &table).unwrap();
    for layout in [TableLayout::Compact, TableLayout::PerTet] {
        let mut mesh = base.clone();
        let media_table = media.apply(&mut mesh, layout).unwrap();
        assert_eq!(media_table.len(), if layout == TableLayout::Compact { 2 } else { mesh.tet_count() });
        let system = assemble(&mesh, &media_table, 1.0).unwrap();
        let diff = max_difference(system.matrix().values(), reference.matrix().values());
        assert_eq!(diff, 0.0, "{layout:?}");
    }

    // Painting: per-tet ids stay, set_media refills the matrix as a fresh assembly would.
    let mut mesh = base.clone();
    let mut painted = media.clone();
    let table = painted.apply(&mut mesh, TableLayout::PerTet).unwrap();
    let mut system = assemble(&mesh, &table, 1.0).unwrap();
    for t in (0..painted.len()).step_by(13) {
        painted.set(t, Coefficients::new([0.3, 0.2, 0.1], [1.0, 1.0, 1.0])).unwrap();
    }
    system.set_media(&painted.material_table(TableLayout::PerTet).media).unwrap();
    let fresh = assemble(&mesh, &painted.material_table(TableLayout::PerTet).media, 1.0).unwrap();
    assert_eq!(max_difference(system.matrix().values(), fresh.matrix().values()), 0.0);

    // A voxel grid's media assemble too.
    let grid = irregular_grid();
    let mut mesh = base;
    let voxel_media = grid.per_tet(&mesh, 1.4, 0.0, TetSampling::FivePoint).unwrap();
    let voxel_table = voxel_media.apply(&mut mesh, TableLayout::PerTet).unwrap();
    let system = assemble(&mesh, &voxel_table, 1.0).unwrap();
    assert_eq!(system.boundary_terms().a, transcut::optics::BoundaryTerms::new(1.4).unwrap().a);
}
