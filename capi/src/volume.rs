//! Heterogeneous media: a material table for a tet mesh's ids, per-tet coefficients, voxel
//! grids (in memory or a TCVOX1 file). Each call checks the scene and the object index before
//! it reads any of the caller's data or files, and the medium against the object's shape when
//! it is set; the object keeps its previous medium on any error.

use std::ffi::c_char;

use glam::DVec3;
use transcut_core::volume::{Coefficients, PerTetMedia, VolumeError, VoxelGrid};
use transcut_core::MediumSource;

use super::convert::{medium_from, TcMedium};
use super::handle::{with_scene, TcScene};
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_IO_ERROR, TC_NOT_FOUND};

/// Fills a tet-mesh object with a table of media indexed by its per-tet material ids (the
/// `tet_medium` array of `tc_scene_add_tet_mesh`; all 0 when it was NULL, and for a surface
/// object, whose tets all use entry 0). Every entry must be a valid medium with the same `eta`
/// (one refractive index per object); every id must be `< count`. The library copies the
/// table.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_media_table(
    scene: *mut TcScene,
    object: u32,
    table: *const TcMedium,
    count: usize,
) -> TcStatus {
    run("tc_object_set_media_table", || {
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                s.object_index(object)?;
                check_not_null!(table);
                // SAFETY: the caller's contract (`count` media).
                let table = ptr::slice(table, count, "table")?;
                let media = table
                    .iter()
                    .enumerate()
                    .map(|(i, m)| medium_from(m, &format!("table[{i}]")))
                    .collect::<Result<Vec<_>, _>>()?;
                if let Some((i, m)) = media.iter().enumerate().find(|(_, m)| m.eta != media[0].eta) {
                    return Err(Failure::invalid(format!(
                        "table[{i}].eta = {} but table[0].eta = {}: one refractive index per object",
                        m.eta, media[0].eta
                    )));
                }
                s.set_medium(object, MediumSource::Table(media))
            })
        }
    })
}

/// Fills a tet-mesh object with one medium per tet: `sigma_a` and `sigma_s_prime` hold 3
/// floats (R, G, B, mm⁻¹) per tet, `tet_count` tets in the mesh's order, which must be the
/// object's tet count; `eta` and `g` are the object's. `TC_INVALID_ARGUMENT` naming the first
/// invalid tet (negative or non-finite coefficient, σa + σ′s = 0), a count mismatch, or a
/// surface object (whose tets are not known before the bake: use a voxel grid). The library
/// copies the arrays.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_media_per_tet(
    scene: *mut TcScene,
    object: u32,
    sigma_a: *const f32,
    sigma_s_prime: *const f32,
    tet_count: usize,
    eta: f64,
    g: f64,
) -> TcStatus {
    run("tc_object_set_media_per_tet", || {
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |st| {
                st.object_index(object)?;
                check_not_null!(sigma_a, sigma_s_prime);
                let floats = ptr::times(tet_count, 3, "tet_count")?;
                // SAFETY: the caller's contract (3 × tet_count floats each).
                let (a, s) = (ptr::slice(sigma_a, floats, "sigma_a")?, ptr::slice(sigma_s_prime, floats, "sigma_s_prime")?);
                let f = |v: &[f32]| [f64::from(v[0]), f64::from(v[1]), f64::from(v[2])];
                let coefficients = a.chunks_exact(3).zip(s.chunks_exact(3)).map(|(a, s)| Coefficients::new(f(a), f(s))).collect();
                let media = PerTetMedia::new(coefficients, eta, g).map_err(|e| Failure::invalid(e.to_string()))?;
                st.set_medium(object, MediumSource::PerTet(media))
            })
        }
    })
}

/// Fills an object (surface or tet mesh) with a voxel grid of coefficients, sampled per tet
/// when baking (trilinear between voxel centres, clamped at the border, averaged over five
/// points per tet). The grid lies in OBJECT space (scene units): `dims` voxels along x, y, z
/// from `origin` (the corner of voxel 0), each `voxel_size` big. `data` holds 6 floats per
/// voxel (σa R, G, B then σ′s R, G, B, mm⁻¹), x fastest: voxel (i, j, k) starts at
/// 6·(i + nx·(j + ny·k)); `data_len` must be 6·nx·ny·nz. `eta` and `g` are the object's. The
/// library copies the data.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_medium_voxels(
    scene: *mut TcScene,
    object: u32,
    dims: *const u32,
    origin: *const f64,
    voxel_size: *const f64,
    data: *const f32,
    data_len: usize,
    eta: f64,
    g: f64,
) -> TcStatus {
    run("tc_object_set_medium_voxels", || {
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                s.object_index(object)?;
                check_not_null!(dims, data);
                // SAFETY: the caller's contract (3 values each; `data_len` floats).
                let d = ptr::slice(dims, 3, "dims")?;
                let (origin, voxel_size) = (ptr::vec3(origin, "origin")?, ptr::vec3(voxel_size, "voxel_size")?);
                let data = ptr::slice(data, data_len, "data")?;
                let grid =
                    VoxelGrid::new([d[0], d[1], d[2]], DVec3::from_array(origin), DVec3::from_array(voxel_size), data.to_vec())
                        .map_err(|e| Failure::invalid(e.to_string()))?;
                s.set_medium(object, MediumSource::Voxels { grid, eta, g })
            })
        }
    })
}

/// As `tc_object_set_medium_voxels`, with the grid read from a TCVOX1 file (format:
/// core/src/volume/VOXEL_FORMAT.md). `TC_NOT_FOUND` when the file does not exist,
/// `TC_IO_ERROR` when it cannot be read or is not a valid TCVOX1 file.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_medium_voxel_file(
    scene: *mut TcScene,
    object: u32,
    path: *const c_char,
    eta: f64,
    g: f64,
) -> TcStatus {
    run("tc_object_set_medium_voxel_file", || {
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                s.object_index(object)?;
                // SAFETY: the caller's contract.
                let path = ptr::path(path, "path")?;
                let grid = VoxelGrid::read(path).map_err(|e| match &e {
                    VolumeError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
                        Failure::new(TC_NOT_FOUND, e.to_string())
                    }
                    _ => Failure::new(TC_IO_ERROR, e.to_string()),
                })?;
                s.set_medium(object, MediumSource::Voxels { grid, eta, g })
            })
        }
    })
}
