//! Scenes and objects: create, destroy, add meshes (translucent solids, or opaque diffuse
//! surfaces for translucent radiosity), place them, set a diffuse surface's albedo, emission
//! and sides.

use glam::{DMat4, DVec3};
use transcut_core::mesh::{TetMesh, TriMesh};
use transcut_core::optics::Medium;
use transcut_core::{Diffuse, Material, MediumSource, Object, Shape, Sides};

use super::convert::mesh_failure;
use super::handle::{self, with_scene, SceneState, TcScene, LIVE_SCENES};
use super::ptr;
use super::status::{run, run_on_workers, Failure, TcStatus, TC_INTERNAL_ERROR, TC_INVALID_MESH, TC_UNSUPPORTED};

/// `tc_object_set_sides`: both sides of the surface reflect, each with its own radiosity (a
/// wall seen from either side; the default).
pub const TC_SIDES_BOTH: u32 = 0;
/// `tc_object_set_sides`: only the front reflects: the outside of a closed surface (closed
/// shells are oriented outwards when the mesh is added), the side of the winding of most of
/// the area of an open one. The back absorbs whatever reaches it.
pub const TC_SIDES_FRONT: u32 = 1;
/// `tc_object_set_sides`: only the back reflects: the inside of a closed surface (a room
/// modelled as a box, an enclosure). The front absorbs whatever reaches it.
pub const TC_SIDES_BACK: u32 = 2;

/// `tc_object_material`: a translucent object (a medium under its surface; every method).
pub const TC_MATERIAL_TRANSLUCENT: u32 = 0;
/// `tc_object_material`: an opaque diffuse surface (`tc_scene_add_diffuse_mesh`; only
/// `TC_METHOD_RADIOSITY` bakes it).
pub const TC_MATERIAL_DIFFUSE: u32 = 1;

/// The medium of a new object until one is set: the "marble" preset.
pub(crate) fn default_medium() -> Result<Medium, Failure> {
    Medium::preset("marble").map_err(|e| Failure::new(TC_INTERNAL_ERROR, e.to_string()))
}

/// Adds `object` to the scene and returns its index.
fn push_object(state: &mut SceneState, object: Object) -> Result<u32, Failure> {
    let index = u32::try_from(state.scene.objects.len()).map_err(|_| Failure::invalid("the scene already has 2^32 objects"))?;
    state.scene.objects.push(object);
    state.changed();
    Ok(index)
}

/// The caller's triangle mesh: `vertex_count` x, y, z floats and `index_count` indices.
///
/// # Safety
/// The arrays must hold the given numbers of values (either may be NULL when its count is 0).
unsafe fn tri_mesh(
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    index_count: usize,
) -> Result<TriMesh, Failure> {
    let floats = ptr::times(vertex_count, 3, "vertex_count")?;
    // SAFETY: the caller's contract (arrays of the given lengths).
    let positions = unsafe { ptr::slice(positions, floats, "positions")? };
    // SAFETY: as above.
    let indices = unsafe { ptr::slice(indices, index_count, "indices")? };
    let xyz: Vec<[f32; 3]> = positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    if !index_count.is_multiple_of(3) {
        return Err(Failure::new(TC_INVALID_MESH, format!("index_count = {index_count} is not a multiple of 3")));
    }
    TriMesh::from_triangles(&xyz, indices).map_err(|e| mesh_failure(&e))
}

/// The number of vertices an object's radiance has (its user vertices, or a tet mesh's
/// vertices).
pub(crate) fn output_vertex_count(object: &Object) -> usize {
    object.shape.output_vertex_count()
}

/// Creates an empty scene (no objects, no lights) and stores its handle in `*out`.
///
/// The caller owns the scene and frees it with `tc_scene_destroy(&scene)`. On failure `*out` is
/// left unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_create(out: *mut *mut TcScene) -> TcStatus {
    run("tc_scene_create", || {
        check_not_null!(out);
        let scene = Box::into_raw(Box::new(TcScene::new()));
        // SAFETY: checked above; the caller's contract.
        unsafe { ptr::write(out, scene) };
        Ok(())
    })
}

/// Frees a scene and sets the caller's handle to NULL.
///
/// Takes the address of the handle: `tc_scene_destroy(&scene);`. Destroying twice through the
/// same variable is harmless (the second call sees NULL), as are `tc_scene_destroy(NULL)` and a
/// NULL handle. If the scene is in use by a call that has not returned (another thread, or from
/// inside its progress callback) nothing is freed, the handle is kept and the last error says
/// why; call it again later.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_destroy(scene: *mut *mut TcScene) {
    let _ = run("tc_scene_destroy", || {
        if scene.is_null() {
            return Ok(());
        }
        check_not_null!(scene);
        // SAFETY: the caller's contract: the address of a handle variable.
        let handle = unsafe { *scene };
        if handle.is_null() {
            return Ok(());
        }
        // SAFETY: a live handle (caller's contract).
        unsafe { handle::destroy(handle)? };
        // SAFETY: as above.
        unsafe { *scene = std::ptr::null_mut() };
        Ok(())
    });
}

/// The number of objects in the scene, in `*out`.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_object_count(scene: *const TcScene, out: *mut u32) -> TcStatus {
    run("tc_scene_object_count", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let n = unsafe { with_scene(scene, |s| Ok(s.scene.objects.len() as u32))? };
        // SAFETY: checked above.
        unsafe { ptr::write(out, n) };
        Ok(())
    })
}

/// Adds an object from a triangle mesh and stores its index in `*out_object` (objects are
/// numbered 0, 1, … in the order they are added).
///
/// `positions` holds `vertex_count` vertices as x, y, z floats (3 × `vertex_count` floats) in
/// object space, scene units; `indices` holds `index_count` vertex indices (a multiple of 3),
/// three per triangle, counter-clockwise seen from outside. The mesh should be closed (it is
/// the surface of a solid); vertices closer than 1e-7 × the bounding-box diagonal are merged,
/// degenerate triangles dropped. Radiance is later returned for every one of the
/// `vertex_count` vertices, in this order.
///
/// The new object is filled with the "marble" preset, has the identity transform and
/// 1 mm per scene unit; see `tc_object_set_medium*`, `tc_object_set_transform`,
/// `tc_object_set_scale`.
///
/// The library copies the arrays; the caller keeps ownership of `positions` and `indices`.
/// `TC_INVALID_MESH` for an empty mesh, an index count that is not a multiple of 3, an index
/// `>= vertex_count`, a NaN or infinite coordinate, or when every triangle is degenerate; the
/// scene and `*out_object` are then unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_mesh(
    scene: *mut TcScene,
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    index_count: usize,
    out_object: *mut u32,
) -> TcStatus {
    run("tc_scene_add_mesh", || {
        check_not_null!(out_object);
        // SAFETY: the caller's contract (arrays of the given lengths).
        let mesh = unsafe { tri_mesh(positions, vertex_count, indices, index_count)? };
        // SAFETY: the caller's contract.
        let index = unsafe {
            with_scene(scene, |s| {
                let name = format!("object {}", s.scene.objects.len());
                push_object(s, Object::new(name, mesh, default_medium()?, 1.0))
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out_object, index) };
        Ok(())
    })
}

/// Replaces the triangle mesh of object `object` (added by `tc_scene_add_mesh`,
/// `tc_scene_add_mesh_file` or `tc_scene_add_diffuse_mesh`) with a new one, as
/// `tc_scene_add_mesh` takes it: the object keeps its name, medium or diffuse material,
/// transform and scale, and its radiance is returned for the new vertices. The host's way to
/// follow an edited model (a modifier, a sculpt): the next `tc_scene_bake` meshes this object
/// again and keeps the tetrahedra of the others.
///
/// The library copies the arrays. `TC_INVALID_MESH` as `tc_scene_add_mesh`,
/// `TC_INVALID_HANDLE` for no such object, `TC_UNSUPPORTED` for an object given as a
/// tetrahedral mesh (add a new object instead); the scene is then unchanged. Like any change
/// to an object, it discards the results of the last bake.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_mesh(
    scene: *mut TcScene,
    object: u32,
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    index_count: usize,
) -> TcStatus {
    run("tc_object_set_mesh", || {
        // SAFETY: the caller's contract (arrays of the given lengths).
        let mesh = unsafe { tri_mesh(positions, vertex_count, indices, index_count)? };
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                let o = &mut s.scene.objects[i];
                if matches!(o.shape, Shape::Tetrahedra(_)) {
                    return Err(Failure::new(
                        TC_UNSUPPORTED,
                        format!(
                            "object {object} ('{}') was given as a tetrahedral mesh: add the new mesh as a new object",
                            o.name
                        ),
                    ));
                }
                o.shape = Shape::Surface(mesh);
                s.changed();
                Ok(())
            })
        }
    })
}

/// The number of scenes created by `tc_scene_create` and not yet destroyed in this process,
/// for a host that keeps scenes between bakes to check that it frees them.
#[no_mangle]
pub extern "C" fn tc_live_scene_count() -> usize {
    LIVE_SCENES.load(std::sync::atomic::Ordering::Relaxed)
}

/// Adds an object from a ready tetrahedral mesh and stores its index in `*out_object`. The
/// bake solves on these tets as given (no meshing; `TcBakeOptions.tets` does not apply) and
/// returns radiance for every one of the `vertex_count` vertices, in this order (interior
/// vertices get 0: no light leaves there).
///
/// `positions`: 3 floats per vertex (object space, scene units); `tets`: 4 vertex indices per
/// tetrahedron (`4 × tet_count` values; either orientation); `tet_medium`: NULL, or one
/// material id per tet indexing the table given later with `tc_object_set_media_table`. The new
/// object is filled with the "marble" preset until a medium is set.
///
/// The library copies the arrays; the caller keeps ownership. `TC_INVALID_MESH` for no tets or
/// vertices, a NaN or infinite coordinate, an index `>= vertex_count`, a degenerate
/// (zero-volume) tet, or a face shared by more than two tets (the message names the tet or
/// face); the scene and `*out_object` are then unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_tet_mesh(
    scene: *mut TcScene,
    positions: *const f32,
    vertex_count: usize,
    tets: *const u32,
    tet_count: usize,
    tet_medium: *const u32,
    out_object: *mut u32,
) -> TcStatus {
    run_on_workers("tc_scene_add_tet_mesh", || {
        check_not_null!(out_object);
        let floats = ptr::times(vertex_count, 3, "vertex_count")?;
        let corners = ptr::times(tet_count, 4, "tet_count")?;
        // SAFETY: the caller's contract (arrays of the given lengths).
        let (positions, tets, ids) = unsafe {
            (
                ptr::slice(positions, floats, "positions")?,
                ptr::slice(tets, corners, "tets")?,
                if tet_medium.is_null() { &[][..] } else { ptr::slice(tet_medium, tet_count, "tet_medium")? },
            )
        };
        let positions: Vec<DVec3> =
            positions.chunks_exact(3).map(|p| DVec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))).collect();
        let tets: Vec<[u32; 4]> = tets.chunks_exact(4).map(|t| [t[0], t[1], t[2], t[3]]).collect();
        let mesh = TetMesh::new(positions, tets, ids.to_vec()).map_err(|e| Failure::new(TC_INVALID_MESH, e.to_string()))?;
        // SAFETY: the caller's contract.
        let index = unsafe {
            with_scene(scene, |s| {
                let name = format!("object {}", s.scene.objects.len());
                let medium = MediumSource::Homogeneous(default_medium()?);
                push_object(s, Object::from_tets(name, mesh, medium, 1.0))
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out_object, index) };
        Ok(())
    })
}

/// Adds an object from an OBJ or PLY file and stores its index in `*out_object`;
/// otherwise as `tc_scene_add_mesh`, with radiance returned per vertex of the file, in file
/// order. `TC_NOT_FOUND` when the file does not exist, `TC_IO_ERROR` when it cannot be read,
/// `TC_INVALID_MESH` when its content is invalid (the message names file, line and element).
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_mesh_file(
    scene: *mut TcScene,
    path: *const std::ffi::c_char,
    out_object: *mut u32,
) -> TcStatus {
    run("tc_scene_add_mesh_file", || {
        check_not_null!(out_object);
        // SAFETY: the caller's contract.
        let path = unsafe { ptr::path(path, "path")? };
        let mesh = transcut_core::mesh::load(path).map_err(|e| mesh_failure(&e))?;
        let name = path.file_stem().map_or_else(|| path.display().to_string(), |s| s.to_string_lossy().into_owned());
        // SAFETY: the caller's contract.
        let index = unsafe { with_scene(scene, |s| push_object(s, Object::new(name, mesh, default_medium()?, 1.0)))? };
        // SAFETY: checked above.
        unsafe { ptr::write(out_object, index) };
        Ok(())
    })
}

/// Names an object (UTF-8) for messages: errors of a bake name the object by index and name.
/// New objects are called "object N"; the caller keeps ownership of `name`.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_name(scene: *mut TcScene, object: u32, name: *const std::ffi::c_char) -> TcStatus {
    run("tc_object_set_name", || {
        // SAFETY: the caller's contract.
        let name = unsafe { ptr::utf8(name, "name")? };
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                s.scene.objects[i].name = name.to_owned();
                Ok(())
            })
        }
    })
}

/// Sets an object's object → world transform: a 4 × 4 matrix of 16 floats in column-major
/// order (OpenGL / glTF / Blender's `matrix_world` transposed to columns), in scene units.
///
/// The matrix must be finite, affine (last row 0, 0, 0, 1) and invertible. Any change to the
/// scene discards the results of the last bake.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_transform(scene: *mut TcScene, object: u32, matrix: *const f32) -> TcStatus {
    run("tc_object_set_transform", || {
        check_not_null!(matrix);
        // SAFETY: the caller's contract (16 floats).
        let m = unsafe { ptr::slice(matrix, 16, "matrix")? };
        let mut cols = [0.0f64; 16];
        for (c, v) in cols.iter_mut().zip(m) {
            *c = f64::from(*v);
        }
        let t = DMat4::from_cols_array(&cols);
        if !t.is_finite() {
            return Err(Failure::invalid(format!("`matrix` has a NaN or infinite entry: {cols:?}")));
        }
        let last_row = t.row(3);
        if last_row != glam::DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return Err(Failure::invalid(format!(
                "`matrix` is not affine: its last row is {last_row} (expected 0 0 0 1; the matrix is column-major)"
            )));
        }
        let det = t.determinant();
        if det.abs() <= 1e-300 {
            return Err(Failure::invalid(format!("`matrix` is singular (determinant {det:e})")));
        }
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                s.scene.objects[i].transform = t;
                s.changed();
                Ok(())
            })
        }
    })
}

/// Sets how many millimetres one scene unit is for an object (media are in mm⁻¹): 1 for a
/// scene modelled in millimetres, 1000 for metres (Blender's default). Must be positive and
/// finite. Media set later by artist parameters use this value (`tc_object_set_medium_artist`).
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_scale(scene: *mut TcScene, object: u32, mm_per_unit: f64) -> TcStatus {
    run("tc_object_set_scale", || {
        if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
            return Err(Failure::invalid(format!("mm_per_unit = {mm_per_unit}: must be positive and finite")));
        }
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                s.scene.objects[i].mm_per_unit = mm_per_unit;
                s.changed();
                Ok(())
            })
        }
    })
}

/// The number of vertices the object's radiance is returned for, in `*out`: the
/// `vertex_count` the mesh was added with (for a tet mesh, its vertex count). Radiance buffers
/// need 3 floats per vertex.
#[no_mangle]
pub unsafe extern "C" fn tc_object_vertex_count(scene: *const TcScene, object: u32, out: *mut usize) -> TcStatus {
    run("tc_object_vertex_count", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let n = unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                Ok(output_vertex_count(&s.scene.objects[i]))
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out, n) };
        Ok(())
    })
}

/// Adds an opaque diffuse object (a Lambertian surface: walls, floors, the room around the
/// translucent objects) and stores its index in `*out_object`. Only `TC_METHOD_RADIOSITY`
/// bakes it (the other methods fail with `TC_UNSUPPORTED`, naming the object and suggesting
/// radiosity): the objects then light each other, and its radiance is Lo = B/π with B its
/// radiosity (reflected plus emitted exitance), per vertex as for any object.
///
/// The mesh is read as `tc_scene_add_mesh` reads it (same arrays, same checks, radiance per
/// given vertex in this order) but need not be closed: an open surface (a plane, a scan) is a
/// surface only, with no volume. `albedo` (3 doubles, linear RGB) is the fraction of the light
/// it reflects, each channel in [0, 1) (1 would reflect everything, and a closed room of it
/// would never converge). The new object emits nothing and reflects on both sides; see
/// `tc_object_set_emission`, `tc_object_set_sides`, and `tc_object_set_transform` and
/// `tc_object_set_scale` as for any object (every object of a radiosity bake must have the
/// same scale).
///
/// `TC_INVALID_MESH` as for `tc_scene_add_mesh`; `TC_NULL_POINTER` for a NULL `albedo`;
/// `TC_INVALID_ARGUMENT` for an albedo out of [0, 1) or NaN, naming it. The scene and
/// `*out_object` are unchanged on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_diffuse_mesh(
    scene: *mut TcScene,
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    index_count: usize,
    albedo: *const f64,
    out_object: *mut u32,
) -> TcStatus {
    run("tc_scene_add_diffuse_mesh", || {
        check_not_null!(out_object);
        // SAFETY: the caller's contract (3 doubles).
        let albedo = unsafe { ptr::vec3(albedo, "albedo")? };
        let diffuse = Diffuse::new(albedo);
        diffuse.validate().map_err(|e| Failure::invalid(format!("`albedo`: {e}")))?;
        // SAFETY: the caller's contract (arrays of the given lengths).
        let mesh = unsafe { tri_mesh(positions, vertex_count, indices, index_count)? };
        // SAFETY: the caller's contract.
        let index = unsafe {
            with_scene(scene, |s| {
                let name = format!("object {}", s.scene.objects.len());
                push_object(s, Object::diffuse(name, mesh, diffuse, 1.0))
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out_object, index) };
        Ok(())
    })
}

/// Sets a diffuse object's albedo (3 doubles, linear RGB, each in [0, 1)): the fraction of the
/// irradiance it reflects. `TC_INVALID_ARGUMENT` naming the object for a value out of range or
/// NaN, or for a translucent object (its colour comes from its medium); the object is then
/// unchanged. Any change to the scene discards the results of the last bake.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_albedo(scene: *mut TcScene, object: u32, albedo: *const f64) -> TcStatus {
    run("tc_object_set_albedo", || {
        // SAFETY: the caller's contract (3 doubles).
        let albedo = unsafe { ptr::vec3(albedo, "albedo")? };
        // SAFETY: the caller's contract.
        unsafe { with_scene(scene, |s| s.set_diffuse(object, |d| d.albedo = albedo)) }
    })
}

/// Sets the exitance a diffuse object emits (3 doubles, linear RGB, each finite and ≥ 0; 0
/// by default), in the units of the lights' irradiance: a surface emitting M and reflecting
/// nothing has radiance M/π. An emissive surface lights the scene in a radiosity bake like an
/// area light (its light is spread through the form factors, not sampled as the lights are).
/// `TC_INVALID_ARGUMENT` naming the object for a negative, NaN or infinite value, or for a
/// translucent object; the object is then unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_emission(scene: *mut TcScene, object: u32, emission: *const f64) -> TcStatus {
    run("tc_object_set_emission", || {
        // SAFETY: the caller's contract (3 doubles).
        let emission = unsafe { ptr::vec3(emission, "emission")? };
        // SAFETY: the caller's contract.
        unsafe { with_scene(scene, |s| s.set_diffuse(object, |d| d.emission = emission)) }
    })
}

/// Sets which sides of a diffuse object reflect (and emit): `TC_SIDES_BOTH` (the default),
/// `TC_SIDES_FRONT` or `TC_SIDES_BACK` (the inside of a closed room). The other side absorbs
/// whatever reaches it, and patches behind one-sided surfaces take their neighbours' radiance.
/// The radiance returned per vertex is that of the reflecting side (the front of a two-sided
/// surface). `TC_INVALID_ARGUMENT` for another value or a translucent object; the object is
/// then unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_sides(scene: *mut TcScene, object: u32, sides: u32) -> TcStatus {
    run("tc_object_set_sides", || {
        let sides = match sides {
            TC_SIDES_BOTH => Sides::Both,
            TC_SIDES_FRONT => Sides::Front,
            TC_SIDES_BACK => Sides::Back,
            other => {
                return Err(Failure::invalid(format!(
                    "sides = {other}: unknown sides (TC_SIDES_BOTH = 0, TC_SIDES_FRONT = 1, TC_SIDES_BACK = 2)"
                )))
            }
        };
        // SAFETY: the caller's contract.
        unsafe { with_scene(scene, |s| s.set_diffuse(object, |d| d.sides = sides)) }
    })
}

/// What an object is made of, in `*out`: `TC_MATERIAL_TRANSLUCENT` (added by
/// `tc_scene_add_mesh`, `tc_scene_add_tet_mesh` or `tc_scene_add_mesh_file`) or
/// `TC_MATERIAL_DIFFUSE` (added by `tc_scene_add_diffuse_mesh`). An object keeps its kind:
/// `tc_object_set_medium*` refuses a diffuse object, `tc_object_set_albedo`, `_emission` and
/// `_sides` a translucent one.
#[no_mangle]
pub unsafe extern "C" fn tc_object_material(scene: *const TcScene, object: u32, out: *mut u32) -> TcStatus {
    run("tc_object_material", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let kind = unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                Ok(match &s.scene.objects[i].material {
                    Material::Diffuse(_) => TC_MATERIAL_DIFFUSE,
                    _ => TC_MATERIAL_TRANSLUCENT,
                })
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out, kind) };
        Ok(())
    })
}
