//! Ready tet meshes and heterogeneous media through the ABI.

use std::ptr;

use transcut_core::volume::VoxelGrid;
use transcut_core::DVec3;

use super::abi::*;
use super::common::*;

/// The cube [0, n·h]³ as n³ cells of 6 Kuhn tets (every tet contains the cell's main diagonal),
/// vertex (i, j, k) at index i + (n+1)(j + (n+1)k). The triangulation is mapped onto itself by
/// permutations of the axes and by the point reflection through the centre.
struct TetCube {
    n: u32,
    positions: Vec<f32>,
    tets: Vec<u32>,
    /// Material id per tet: 1 where the tet's centroid has x > half, else 0.
    ids: Vec<u32>,
}

impl TetCube {
    fn new(n: u32, h: f32) -> Self {
        let m = n + 1;
        let idx = |i: u32, j: u32, k: u32| i + m * (j + m * k);
        let mut positions = Vec::new();
        for k in 0..m {
            for j in 0..m {
                for i in 0..m {
                    positions.extend([i as f32 * h, j as f32 * h, k as f32 * h]);
                }
            }
        }
        let (mut tets, mut ids) = (Vec::new(), Vec::new());
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let c = |d: u32| idx(i + (d & 1), j + ((d >> 1) & 1), k + ((d >> 2) & 1));
                    for [a, b] in [[1, 3], [1, 5], [2, 3], [2, 6], [4, 5], [4, 6]] {
                        tets.extend([c(0), c(a), c(b), c(7)]);
                        ids.push(u32::from(2 * i + 1 > n));
                    }
                }
            }
        }
        Self { n, positions, tets, ids }
    }

    fn vertex_count(&self) -> usize {
        self.positions.len() / 3
    }

    fn tet_count(&self) -> usize {
        self.tets.len() / 4
    }

    fn index(&self, i: u32, j: u32, k: u32) -> usize {
        let m = self.n + 1;
        (i + m * (j + m * k)) as usize
    }

    fn add(&self, s: *mut TcScene, with_ids: bool) -> u32 {
        let mut object = u32::MAX;
        let ids = if with_ids { self.ids.as_ptr() } else { ptr::null() };
        // SAFETY: arrays of the given lengths.
        let status = unsafe {
            tc_scene_add_tet_mesh(
                s,
                self.positions.as_ptr(),
                self.vertex_count(),
                self.tets.as_ptr(),
                self.tet_count(),
                ids,
                &mut object,
            )
        };
        ok(status, "tc_scene_add_tet_mesh");
        object
    }
}

const MARBLE: TcMedium = TcMedium { sigma_a: [0.0021, 0.0041, 0.0071], sigma_s_prime: [2.19, 2.62, 3.00], eta: 1.3, g: 0.0 };
/// Absorbing, but resolved by the test's coarse tet mesh (σtr·h under TransCut's bound).
const INKY: TcMedium = TcMedium { sigma_a: [0.05, 0.06, 0.07], sigma_s_prime: [2.19, 2.62, 3.00], eta: 1.3, g: 0.0 };

/// Bakes a scene with a constant sky, no shadows, and returns the radiance of object 0 (a
/// surface object is meshed with 3000 tets; a tet mesh is solved as given).
fn bake_sky(s: *mut TcScene) -> Vec<f32> {
    let mut o = options(3_000);
    o.shadows = 0;
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_add_environment(s, [1.0; 3].as_ptr()), "sky");
        ok(tc_scene_bake(s, &o, None, ptr::null_mut()), "bake");
    }
    radiance(s, 0)
}

fn close(a: &[f32], b: &[f32], rel: f32) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() <= rel * x.abs().max(y.abs()).max(1e-6))
}

/// A ready tet mesh is solved as given: one value per tet-mesh vertex, 0 inside, positive on the
/// surface, and symmetric as the mesh is (axis swaps, point reflection) under a uniform sky.
#[test]
fn a_tet_mesh_is_solved_as_given() {
    let cube = TetCube::new(12, 2.0);
    let s = scene();
    let cube_object = cube.add(s, false);
    let mut n = 0usize;
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_vertex_count(s, cube_object, &mut n), "vertex count");
        ok(tc_object_set_medium(s, cube_object, &MARBLE), "medium");
    }
    assert_eq!(n, cube.vertex_count());
    let lo = bake_sky(s);
    assert_eq!(lo.len(), 3 * n);
    let mut stats: TcBakeStats = unsafe { std::mem::zeroed() };
    stats.size = size_of::<TcBakeStats>() as u32;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_stats(s, 0, &mut stats) }, "stats");
    assert_eq!((stats.tets as usize, stats.vertices as usize), (cube.tet_count(), n), "solved on the given tets");
    let m = cube.n;
    let at = |i, j, k, c: usize| lo[3 * cube.index(i, j, k) + c];
    for k in 0..=m {
        for j in 0..=m {
            for i in 0..=m {
                let surface = [i, j, k].iter().any(|&x| x == 0 || x == m);
                for c in 0..3 {
                    let v = at(i, j, k, c);
                    if surface {
                        assert!(v > 0.1, "surface vertex ({i},{j},{k}) = {v}");
                        for w in [at(j, i, k, c), at(k, j, i, c), at(i, k, j, c), at(m - i, m - j, m - k, c)] {
                            assert!((v - w).abs() <= 1e-3 * v, "symmetry at ({i},{j},{k}): {v} vs {w}");
                        }
                    } else {
                        assert_eq!(v, 0.0, "interior vertex ({i},{j},{k})");
                    }
                }
            }
        }
    }
    destroy(s);
}

/// Agreement between the ways of giving the same homogeneous medium: coefficients, a table of
/// two equal entries, per-tet arrays, a uniform voxel grid in memory and from a TCVOX1 file.
/// A table whose entry 1 absorbs strongly darkens the x > half side only.
#[test]
fn heterogeneous_media_agree_with_homogeneous_ones() {
    let cube = TetCube::new(10, 2.0);
    let bake_with = |set: &dyn Fn(*mut TcScene, u32)| {
        let s = scene();
        let object = cube.add(s, true);
        set(s, object);
        let lo = bake_sky(s);
        destroy(s);
        lo
    };
    // SAFETY (all closures): valid pointers and lengths.
    let homogeneous = bake_with(&|s, o| ok(unsafe { tc_object_set_medium(s, o, &MARBLE) }, "medium"));
    let table = bake_with(&|s, o| ok(unsafe { tc_object_set_media_table(s, o, [MARBLE, MARBLE].as_ptr(), 2) }, "table"));
    assert!(close(&homogeneous, &table, 1e-6), "table");

    // f32 arrays: compare with the f32-rounded coefficients.
    let a32 = MARBLE.sigma_a.map(|x| x as f32);
    let s32 = MARBLE.sigma_s_prime.map(|x| x as f32);
    let rounded = TcMedium { sigma_a: a32.map(f64::from), sigma_s_prime: s32.map(f64::from), ..MARBLE };
    let reference = bake_with(&|s, o| ok(unsafe { tc_object_set_medium(s, o, &rounded) }, "rounded medium"));
    assert!(close(&homogeneous, &reference, 1e-5));
    let t = cube.tet_count();
    let (sa, ss): (Vec<f32>, Vec<f32>) = (a32.repeat(t), s32.repeat(t));
    let per_tet =
        bake_with(&|s, o| ok(unsafe { tc_object_set_media_per_tet(s, o, sa.as_ptr(), ss.as_ptr(), t, 1.3, 0.0) }, "per tet"));
    assert!(close(&reference, &per_tet, 1e-6), "per-tet");

    let voxel: Vec<f32> = a32.iter().chain(&s32).copied().collect();
    let data = voxel.repeat(4 * 4 * 4);
    let dims = [4u32; 3];
    let voxels = bake_with(&|s, o| {
        let status = unsafe {
            tc_object_set_medium_voxels(
                s,
                o,
                dims.as_ptr(),
                [-1.0; 3].as_ptr(),
                [6.0; 3].as_ptr(),
                data.as_ptr(),
                data.len(),
                1.3,
                0.0,
            )
        };
        ok(status, "voxels");
    });
    assert!(close(&reference, &voxels, 1e-6), "voxels");

    let path = std::env::temp_dir().join(format!("transcut-capi-{}.tcvox", std::process::id()));
    VoxelGrid::new(dims, DVec3::splat(-1.0), DVec3::splat(6.0), data.clone()).unwrap().write(&path).unwrap();
    let c_path = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    let from_file = bake_with(&|s, o| ok(unsafe { tc_object_set_medium_voxel_file(s, o, c_path.as_ptr(), 1.3, 0.0) }, "file"));
    std::fs::remove_file(&path).unwrap();
    assert_eq!(voxels, from_file, "voxel file");

    let inky = bake_with(&|s, o| ok(unsafe { tc_object_set_media_table(s, o, [MARBLE, INKY].as_ptr(), 2) }, "inky table"));
    let m = cube.n;
    let (near, far) = (3 * cube.index(0, m / 2, m / 2), 3 * cube.index(m, m / 2, m / 2));
    assert!(inky[far] < 0.8 * homogeneous[far], "absorbing side darker: {} vs {}", inky[far], homogeneous[far]);
    assert!(inky[near] > inky[far] && inky[near] < homogeneous[near] * 1.001);
}

/// A voxel grid also fills a surface object (sampled on the tets the bake makes).
#[test]
fn voxels_fill_a_surface_object() {
    let mesh = Mesh::uv_sphere(10.0, 24, 12);
    let voxel = [0.01f32, 0.01, 0.01, 1.0, 1.0, 1.0];
    let data = voxel.repeat(8);
    let bake = |voxels: bool| {
        let s = scene();
        let ball = add(s, &mesh);
        // SAFETY: valid pointers.
        unsafe {
            if voxels {
                let status = tc_object_set_medium_voxels(
                    s,
                    ball,
                    [2u32; 3].as_ptr(),
                    [-12.0; 3].as_ptr(),
                    [12.0; 3].as_ptr(),
                    data.as_ptr(),
                    data.len(),
                    1.4,
                    0.0,
                );
                ok(status, "voxels");
            } else {
                let m = TcMedium { sigma_a: [0.01; 3], sigma_s_prime: [1.0; 3], eta: 1.4, g: 0.0 };
                ok(tc_object_set_medium(s, ball, &m), "medium");
            }
        }
        let lo = bake_sky(s);
        destroy(s);
        lo
    };
    assert!(close(&bake(true), &bake(false), 1e-5));
}

/// Invalid tet meshes and media: each names what is wrong; nothing changes.
#[test]
fn invalid_tet_meshes_and_media() {
    let cube = TetCube::new(2, 1.0);
    let s = scene();
    let add_raw = |positions: &[f32], tets: &[u32], ids: Option<&[u32]>| {
        let mut object = 77u32;
        // SAFETY: arrays of the given lengths.
        let status = unsafe {
            tc_scene_add_tet_mesh(
                s,
                positions.as_ptr(),
                positions.len() / 3,
                tets.as_ptr(),
                tets.len() / 4,
                ids.map_or(ptr::null(), <[u32]>::as_ptr),
                &mut object,
            )
        };
        if status != TC_OK {
            assert_eq!(object, 77, "out_object untouched");
        }
        status
    };
    let mut nan = cube.positions.clone();
    nan[7] = f32::NAN;
    fails(add_raw(&nan, &cube.tets, None), TC_INVALID_MESH, &["vertex 2", "non-finite"]);
    let mut out_of_range = cube.tets.clone();
    out_of_range[9] = 1000;
    fails(add_raw(&cube.positions, &out_of_range, None), TC_INVALID_MESH, &["tet 2", "1000"]);
    let mut degenerate = cube.tets.clone();
    degenerate[4..8].copy_from_slice(&[0, 1, 2, 2]);
    fails(add_raw(&cube.positions, &degenerate, None), TC_INVALID_MESH, &["tet 1", "degenerate"]);
    let mut tripled = cube.tets.clone();
    tripled.extend_from_slice(&cube.tets[..4]);
    tripled.extend_from_slice(&cube.tets[..4]);
    fails(add_raw(&cube.positions, &tripled, None), TC_INVALID_MESH, &["shared by"]);
    fails(add_raw(&[], &[], None), TC_INVALID_MESH, &["empty"]);

    let mut ids = cube.ids.clone();
    ids[3] = 5;
    let object = {
        assert_eq!(add_raw(&cube.positions, &cube.tets, Some(&ids)), TC_OK);
        0
    };
    let t = cube.tet_count();
    let mut sa = vec![0.01f32; 3 * t];
    let ss = vec![1.0f32; 3 * t];
    let dims = [2u32; 3];
    let data = [0.01f32, 0.01, 0.01, 1.0, 1.0, 1.0].repeat(8);
    // SAFETY: valid pointers and lengths.
    unsafe {
        fails(tc_object_set_media_table(s, object, [MARBLE, INKY].as_ptr(), 2), TC_INVALID_ARGUMENT, &["tet 3", "material id 5"]);
        let other_eta = TcMedium { eta: 1.5, ..INKY };
        fails(tc_object_set_media_table(s, object, [MARBLE, other_eta].as_ptr(), 2), TC_INVALID_ARGUMENT, &["table[1].eta"]);
        let bad = TcMedium { sigma_s_prime: [1.0, f64::NAN, 1.0], ..MARBLE };
        fails(
            tc_object_set_media_table(s, object, [MARBLE, bad].as_ptr(), 2),
            TC_INVALID_ARGUMENT,
            &["table[1]", "sigma_s_prime[1]"],
        );
        fails(tc_object_set_media_table(s, object, ptr::null(), 2), TC_NULL_POINTER, &["`table`"]);
        sa[3 * 5 + 2] = -1.0;
        fails(tc_object_set_media_per_tet(s, object, sa.as_ptr(), ss.as_ptr(), t, 1.3, 0.0), TC_INVALID_ARGUMENT, &["tet 5"]);
        sa[3 * 5 + 2] = 0.01;
        fails(
            tc_object_set_media_per_tet(s, object, sa.as_ptr(), ss.as_ptr(), t - 1, 1.3, 0.0),
            TC_INVALID_ARGUMENT,
            &[&format!("{}", t - 1), &format!("{t}")],
        );
        fails(tc_object_set_media_per_tet(s, object, sa.as_ptr(), ss.as_ptr(), t, 0.5, 0.0), TC_INVALID_ARGUMENT, &["eta"]);
        fails(
            tc_object_set_medium_voxels(
                s,
                object,
                dims.as_ptr(),
                [0.0; 3].as_ptr(),
                [1.0; 3].as_ptr(),
                data.as_ptr(),
                data.len() - 1,
                1.3,
                0.0,
            ),
            TC_INVALID_ARGUMENT,
            &["47"],
        );
        fails(
            tc_object_set_medium_voxels(
                s,
                object,
                dims.as_ptr(),
                [0.0; 3].as_ptr(),
                [0.0, 1.0, 1.0].as_ptr(),
                data.as_ptr(),
                data.len(),
                1.3,
                0.0,
            ),
            TC_INVALID_ARGUMENT,
            &["voxel_size"],
        );
        fails(
            tc_object_set_medium_voxel_file(s, object, cstr(c"/nonexistent/grid.tcvox"), 1.3, 0.0),
            TC_NOT_FOUND,
            &["grid.tcvox"],
        );
        // Per-tet media on a surface object: its tets are not known before the bake.
        let ball = add(s, &Mesh::uv_sphere(5.0, 12, 6));
        fails(
            tc_object_set_media_per_tet(s, ball, sa.as_ptr(), ss.as_ptr(), t, 1.3, 0.0),
            TC_INVALID_ARGUMENT,
            &["ready tet mesh"],
        );
        // The tet object still has its default medium and bakes.
        ok(tc_scene_add_environment(s, [1.0; 3].as_ptr()), "sky");
        ok(tc_scene_bake(s, &options(500), None, ptr::null_mut()), "bake");
    }
    destroy(s);
}
