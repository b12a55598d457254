//! Surface mesh input: OBJ and PLY readers, welding, triangulation, validation errors.
//!
//! Uses only the public API (`transcut::mesh::*`). The test meshes are the repository's
//! `assets/meshes` (or `$TRANSCUT_MESH_DIR`).

use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};
use transcut::mesh::{self, load_obj, load_ply, parse_obj, parse_ply, MeshError, TriMesh, WeldOptions};

// ---------------------------------------------------------------------------------------------
// Helpers

fn mesh_dir() -> PathBuf {
    let mut candidates = Vec::new();
    if let Some(dir) = std::env::var_os("TRANSCUT_MESH_DIR") {
        candidates.push(PathBuf::from(dir));
    }
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    candidates.push(manifest.join("../assets/meshes"));
    candidates
        .into_iter()
        .find(|d| d.join("spot.obj").is_file())
        .expect("test meshes not found: set TRANSCUT_MESH_DIR to the folder with spot.obj")
}

/// A file in the system temp folder, unique to this process and test, removed on drop.
struct TempFile(PathBuf);

impl TempFile {
    fn new(name: &str, contents: &[u8]) -> TempFile {
        let path = std::env::temp_dir().join(format!("transcut-mesh-input-{}-{name}", std::process::id()));
        std::fs::write(&path, contents).unwrap();
        TempFile(path)
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// The raw vertices and polygons of an OBJ file, read by a minimal independent parser
/// (positive indices only), to cross-check the library's reader.
fn raw_obj(text: &str) -> (Vec<DVec3>, Vec<Vec<u32>>) {
    let mut v = Vec::new();
    let mut f = Vec::new();
    for line in text.lines() {
        let mut t = line.split_whitespace();
        match t.next() {
            Some("v") => {
                let c: Vec<f64> = t.take(3).map(|s| s.parse().unwrap()).collect();
                v.push(DVec3::new(c[0], c[1], c[2]));
            }
            Some("f") => f.push(t.map(|s| s.split('/').next().unwrap().parse::<u32>().unwrap() - 1).collect()),
            _ => {}
        }
    }
    (v, f)
}

#[derive(Clone, Copy)]
enum PlyFormat {
    Ascii,
    LittleEndian,
    BigEndian,
}

/// A minimal PLY writer: positions as `double` (or `float`), an extra `uchar` vertex property,
/// polygon faces as `list uchar int`, and an extra `edge` element with a list to be skipped.
fn write_ply(format: PlyFormat, single: bool, v: &[DVec3], f: &[Vec<u32>]) -> Vec<u8> {
    let name = match format {
        PlyFormat::Ascii => "ascii",
        PlyFormat::LittleEndian => "binary_little_endian",
        PlyFormat::BigEndian => "binary_big_endian",
    };
    let ty = if single { "float" } else { "double" };
    let mut out = format!(
        "ply\nformat {name} 1.0\ncomment written by the mesh_input test\n\
         element vertex {}\nproperty {ty} x\nproperty uchar quality\nproperty {ty} y\nproperty {ty} z\n\
         element face {}\nproperty list uchar int vertex_indices\n\
         element edge 1\nproperty list int uint vertex_indices\nproperty short crease\n\
         end_header\n",
        v.len(),
        f.len()
    )
    .into_bytes();
    let big = matches!(format, PlyFormat::BigEndian);
    let float = |out: &mut Vec<u8>, x: f64| {
        if single {
            let b = if big { (x as f32).to_be_bytes() } else { (x as f32).to_le_bytes() };
            out.extend(b);
        } else {
            out.extend(if big { x.to_be_bytes() } else { x.to_le_bytes() });
        }
    };
    let int = |out: &mut Vec<u8>, x: i32| out.extend(if big { x.to_be_bytes() } else { x.to_le_bytes() });
    match format {
        PlyFormat::Ascii => {
            let mut s = String::new();
            for p in v {
                if single {
                    s += &format!("{} 7 {} {}\n", p.x as f32, p.y as f32, p.z as f32);
                } else {
                    s += &format!("{} 7 {} {}\n", p.x, p.y, p.z);
                }
            }
            for poly in f {
                s += &poly.len().to_string();
                for i in poly {
                    s += &format!(" {i}");
                }
                s += "\n";
            }
            s += "2 0 1 -3\n";
            out.extend(s.into_bytes());
        }
        PlyFormat::LittleEndian | PlyFormat::BigEndian => {
            for p in v {
                float(&mut out, p.x);
                out.push(7);
                float(&mut out, p.y);
                float(&mut out, p.z);
            }
            for poly in f {
                out.push(u8::try_from(poly.len()).unwrap());
                for &i in poly {
                    int(&mut out, i as i32);
                }
            }
            int(&mut out, 2);
            int(&mut out, 0);
            int(&mut out, 1);
            out.extend(if big { (-3i16).to_be_bytes() } else { (-3i16).to_le_bytes() });
        }
    }
    out
}

fn unit_cube_as_separate_quads() -> (Vec<DVec3>, Vec<Vec<u32>>) {
    // Six faces, each with its own four vertices, counter-clockwise seen from outside.
    let c = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let faces = [
        [c(0., 0., 0.), c(0., 1., 0.), c(1., 1., 0.), c(1., 0., 0.)], // z = 0, normal -z
        [c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)], // z = 1, normal +z
        [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)], // y = 0, normal -y
        [c(0., 1., 0.), c(0., 1., 1.), c(1., 1., 1.), c(1., 1., 0.)], // y = 1, normal +y
        [c(0., 0., 0.), c(0., 0., 1.), c(0., 1., 1.), c(0., 1., 0.)], // x = 0, normal -x
        [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)], // x = 1, normal +x
    ];
    let mut v = Vec::new();
    let mut f = Vec::new();
    for quad in faces {
        let base = v.len() as u32;
        v.extend(quad);
        f.push((base..base + 4).collect());
    }
    (v, f)
}

fn cube_obj_text() -> String {
    let (v, f) = unit_cube_as_separate_quads();
    let mut s = String::from("# cube as 6 separate quads\no cube\n");
    for p in &v {
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for poly in &f {
        s += "f";
        for i in poly {
            s += &format!(" {}", i + 1);
        }
        s += "\n";
    }
    s
}

/// Asserts two meshes are the same: positions, triangles and user map.
fn assert_same_mesh(a: &TriMesh, b: &TriMesh, position_tolerance: f64) {
    assert_eq!(a.user_to_internal(), b.user_to_internal());
    assert_eq!(a.triangles(), b.triangles());
    assert_eq!(a.positions().len(), b.positions().len());
    for (p, q) in a.positions().iter().zip(b.positions()) {
        assert!(p.distance(*q) <= position_tolerance, "{p} vs {q}");
    }
}

// ---------------------------------------------------------------------------------------------
// The shared test meshes

#[test]
fn every_test_mesh_loads_with_the_documented_counts() {
    let dir = mesh_dir();
    // (file, vertices, triangles) from the README; suzanne: 32 triangles + 468 quads.
    let table = [
        ("stanford-bunny.obj", 35_947, 69_451),
        ("spot.obj", 2_930, 5_856),
        ("cow.obj", 2_903, 5_804),
        ("suzanne.obj", 507, 32 + 2 * 468),
        ("rocker-arm.obj", 10_044, 20_088),
        ("fandisk.obj", 6_475, 12_946),
        ("cheburashka.obj", 6_669, 13_334),
        ("homer.obj", 6_002, 12_000),
    ];
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("obj") {
            continue;
        }
        let name = path.file_name().unwrap().to_str().unwrap().to_owned();
        let &(_, vertices, triangles) =
            table.iter().find(|t| t.0 == name).unwrap_or_else(|| panic!("{name} is not in the table"));
        let m = mesh::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(m.user_vertex_count(), vertices, "{name}: user vertices");
        assert_eq!(m.triangles().len(), triangles, "{name}: triangles");
        assert!(m.positions().len() <= vertices, "{name}");
        assert!(m.user_to_internal().iter().all(|&i| (i as usize) < m.positions().len()), "{name}");
        assert!(m.area() > 0.0, "{name}");
        // load_obj and mesh::load agree.
        let direct = load_obj(&path).unwrap();
        assert_same_mesh(&m, &direct, 0.0);
        seen += 1;
    }
    assert_eq!(seen, table.len(), "every mesh of the README was found");
}

#[test]
fn suzanne_has_several_shells_and_spot_is_one_closed_shell() {
    let dir = mesh_dir();
    let suzanne = load_obj(&dir.join("suzanne.obj")).unwrap();
    let (count, ids) = suzanne.shells();
    assert!(count > 1, "suzanne's eyes are separate shells, got {count}");
    assert_eq!(ids.len(), suzanne.triangles().len());
    assert!(ids.iter().all(|&s| (s as usize) < count));
    assert!(!suzanne.is_closed());

    let spot = load_obj(&dir.join("spot.obj")).unwrap();
    let (count, ids) = spot.shells();
    assert_eq!(count, 1);
    assert!(ids.iter().all(|&s| s == 0));
    assert!(spot.is_closed());
    assert!(spot.boundary_edges().is_empty());
    assert!(spot.signed_volume() > 0.0, "spot's faces point outwards");

    // The bunny scan has holes.
    let bunny = load_obj(&dir.join("stanford-bunny.obj")).unwrap();
    assert!(!bunny.is_closed());
    assert!(!bunny.boundary_edges().is_empty());
}

#[test]
fn obj_reader_agrees_with_an_independent_parse() {
    let path = mesh_dir().join("suzanne.obj");
    let text = std::fs::read_to_string(&path).unwrap();
    let (v, f) = raw_obj(&text);
    assert_eq!(v.len(), 507);
    assert_eq!(f.len(), 500);
    let from_arrays = TriMesh::from_polygons(v, &f, &WeldOptions::default()).unwrap();
    let from_file = parse_obj(&text, "suzanne.obj").unwrap();
    assert_same_mesh(&from_arrays, &from_file, 0.0);
}

// ---------------------------------------------------------------------------------------------
// Triangulation and welding

#[test]
fn quad_becomes_two_triangles_with_the_same_area_and_winding() {
    let v = vec![DVec3::new(0., 0., 0.), DVec3::new(2., 0., 0.), DVec3::new(2., 1., 0.), DVec3::new(0., 1., 0.)];
    let m = TriMesh::from_polygons(v, &[vec![0, 1, 2, 3]], &WeldOptions::default()).unwrap();
    assert_eq!(m.triangles().len(), 2);
    assert!((m.area() - 2.0).abs() < 1e-15);
    for t in 0..2 {
        assert!(m.triangle_cross(t).z > 0.0);
    }
}

#[test]
fn l_shaped_hexagon_is_triangulated_inside_the_polygon() {
    let corners = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)];
    // Every starting corner, so that the reflex corner is met in every position.
    for start in 0..6 {
        let mut c = corners.to_vec();
        c.rotate_left(start);
        let v: Vec<DVec3> = c.iter().map(|&(x, y)| DVec3::new(x, y, 0.5)).collect();
        let m = TriMesh::from_polygons(v, &[(0..6).collect()], &WeldOptions::default()).unwrap();
        assert_eq!(m.triangles().len(), 4);
        assert_eq!(m.area(), 3.0, "area preserved exactly");
        for t in 0..4 {
            assert!(m.triangle_cross(t).z > 0.0, "winding kept");
            let [a, b, c] = m.triangle(t);
            // No triangle reaches into the notch x > 1, y > 1 (centroid and corners).
            for p in [a, b, c, (a + b + c) / 3.0] {
                assert!(!(p.x > 1.0 && p.y > 1.0), "triangle {t} lies outside the L");
            }
            let g = (a + b + c) / 3.0;
            assert!(g.x > 0.0 && g.y > 0.0 && g.x < 2.0 && g.y < 2.0);
        }
    }
}

#[test]
fn cube_of_separate_quads_welds_to_eight_vertices_and_unit_volume() {
    let (v, f) = unit_cube_as_separate_quads();
    let m = TriMesh::from_polygons(v, &f, &WeldOptions::default()).unwrap();
    assert_eq!(m.user_vertex_count(), 24);
    assert_eq!(m.positions().len(), 8);
    assert_eq!(m.triangles().len(), 12);
    assert!((m.signed_volume() - 1.0).abs() < 1e-12, "volume {}", m.signed_volume());
    assert!(m.is_closed());
    assert_eq!(m.shells().0, 1);
    // Every user vertex maps to a welded vertex at its own position.
    let (v, _) = unit_cube_as_separate_quads();
    for (i, p) in v.iter().enumerate() {
        assert_eq!(m.positions()[m.user_to_internal()[i] as usize], *p);
    }
    // The representative is the lowest user index: user vertex 0 is internal vertex 0.
    assert_eq!(m.user_to_internal()[0], 0);

    // The same from an OBJ file.
    let from_obj = parse_obj(&cube_obj_text(), "cube.obj").unwrap();
    assert_same_mesh(&m, &from_obj, 0.0);

    // Tolerance 0 still merges identical positions.
    let unwelded = TriMesh::from_polygons(v, &f, &WeldOptions { relative_tolerance: 0.0 });
    assert_eq!(unwelded.unwrap().positions().len(), 8, "identical positions weld even at tolerance 0");
}

#[test]
fn near_duplicates_weld_within_the_relative_tolerance_only() {
    let (mut v, f) = unit_cube_as_separate_quads();
    // Nudge a copy of a corner by 1e-9 (diagonal √3, default tolerance 1.7e-7): welded.
    v[8].x += 1e-9;
    let m = TriMesh::from_polygons(v.clone(), &f, &WeldOptions::default()).unwrap();
    assert_eq!(m.positions().len(), 8);
    // A tolerance of 0 keeps it apart, and the cube is no longer closed.
    let m = TriMesh::from_polygons(v, &f, &WeldOptions { relative_tolerance: 0.0 }).unwrap();
    assert_eq!(m.positions().len(), 9);
    assert!(!m.is_closed());
}

#[test]
fn unreferenced_vertices_keep_their_entry_in_the_user_map() {
    let v = vec![
        DVec3::new(5., 5., 5.), // unused
        DVec3::new(0., 0., 0.),
        DVec3::new(1., 0., 0.),
        DVec3::new(0., 1., 0.),
        DVec3::new(1., 0., 0.), // unused duplicate of 2
    ];
    let m = TriMesh::from_polygons(v, &[vec![1, 2, 3]], &WeldOptions::default()).unwrap();
    assert_eq!(m.user_vertex_count(), 5);
    assert_eq!(m.user_to_internal(), &[0, 1, 2, 3, 2]);
    assert_eq!(m.triangles(), &[[1, 2, 3]]);
}

#[test]
fn faces_collapsed_by_welding_are_dropped() {
    let v = vec![
        DVec3::new(0., 0., 0.),
        DVec3::new(1., 0., 0.),
        DVec3::new(1., 0., 1e-12), // welds onto 1
        DVec3::new(0., 1., 0.),
    ];
    // The quad loses a corner and becomes a triangle; the sliver triangle vanishes.
    let m = TriMesh::from_polygons(v, &[vec![0, 1, 2, 3], vec![0, 1, 2]], &WeldOptions::default()).unwrap();
    assert_eq!(m.user_to_internal(), &[0, 1, 1, 2]);
    assert_eq!(m.triangles(), &[[0, 1, 2]]);
    assert!((m.area() - 0.5).abs() < 1e-15);
}

#[test]
fn from_triangles_accepts_f32_and_f64() {
    let p32: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]];
    let idx = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
    let a = TriMesh::from_triangles(&p32, &idx).unwrap();
    let p64: Vec<[f64; 3]> = p32.iter().map(|p| p.map(f64::from)).collect();
    let b = TriMesh::from_triangles(&p64, &idx).unwrap();
    assert_same_mesh(&a, &b, 0.0);
    assert!(a.is_closed());
    assert!((a.signed_volume() - 1.0 / 6.0).abs() < 1e-15);
}

#[test]
fn shells_are_edge_connected_components() {
    // Two tetrahedra sharing only a vertex: two shells.
    let p = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [-1., 0., 0.], [0., -1., 0.], [0., 0., -1.]];
    let idx = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3, 0, 4, 5, 0, 6, 4, 0, 5, 6, 4, 6, 5];
    let m = TriMesh::from_triangles(&p, &idx).unwrap();
    let (count, ids) = m.shells();
    assert_eq!(count, 2);
    assert_eq!(ids, vec![0, 0, 0, 0, 1, 1, 1, 1]);
}

#[test]
fn transformed_moves_positions_and_keeps_the_user_map() {
    let (v, f) = unit_cube_as_separate_quads();
    let m = TriMesh::from_polygons(v, &f, &WeldOptions::default()).unwrap();
    let scaled = m.transformed(&(DMat4::from_translation(DVec3::new(3., 0., 0.)) * DMat4::from_scale(DVec3::splat(2.))));
    assert_eq!(scaled.user_to_internal(), m.user_to_internal());
    assert!((scaled.signed_volume() - 8.0).abs() < 1e-12);
    assert_eq!(scaled.bounds(), (DVec3::new(3., 0., 0.), DVec3::new(5., 2., 2.)));
    // A mirror keeps the faces pointing outwards.
    let mirrored = m.transformed(&DMat4::from_scale(DVec3::new(-1., 1., 1.)));
    assert!((mirrored.signed_volume() - 1.0).abs() < 1e-12);
    assert_eq!(mirrored.user_to_internal(), m.user_to_internal());
}

// ---------------------------------------------------------------------------------------------
// PLY

#[test]
fn obj_to_ply_round_trip_gives_the_same_mesh() {
    let path = mesh_dir().join("suzanne.obj");
    let text = std::fs::read_to_string(&path).unwrap();
    let from_obj = parse_obj(&text, "suzanne.obj").unwrap();
    let (v, f) = raw_obj(&text);
    for format in [PlyFormat::Ascii, PlyFormat::LittleEndian, PlyFormat::BigEndian] {
        let bytes = write_ply(format, false, &v, &f);
        let from_ply = parse_ply(&bytes, "suzanne.ply").unwrap();
        assert_same_mesh(&from_obj, &from_ply, 0.0);
        // Single precision: the same topology, positions within float rounding.
        let bytes = write_ply(format, true, &v, &f);
        let from_ply = parse_ply(&bytes, "suzanne32.ply").unwrap();
        assert_same_mesh(&from_obj, &from_ply, 1e-6);
    }
    // Through a file, with mesh::load choosing the reader by extension and by content.
    let bytes = write_ply(PlyFormat::LittleEndian, false, &v, &f);
    let file = TempFile::new("suzanne.ply", &bytes);
    assert_same_mesh(&from_obj, &load_ply(&file.0).unwrap(), 0.0);
    assert_same_mesh(&from_obj, &mesh::load(&file.0).unwrap(), 0.0);
    let file = TempFile::new("suzanne.mesh", &bytes);
    assert_same_mesh(&from_obj, &mesh::load(&file.0).unwrap(), 0.0);
}

#[test]
fn ply_with_integer_coordinates_and_aliases() {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
        property int32 x\nproperty uint8 y\nproperty int16 z\nproperty float32 nx\n\
        element face 1\nproperty list uint8 uint16 vertex_indices\nend_header\n"
        .to_vec();
    for (x, y, z) in [(0i32, 0u8, 0i16), (-4, 0, 0), (0, 200, 0)] {
        b.extend(x.to_le_bytes());
        b.push(y);
        b.extend(z.to_le_bytes());
        b.extend(1.5f32.to_le_bytes());
    }
    b.push(3);
    for i in [0u16, 1, 2] {
        b.extend(i.to_le_bytes());
    }
    let m = parse_ply(&b, "ints.ply").unwrap();
    assert_eq!(m.positions(), &[DVec3::ZERO, DVec3::new(-4., 0., 0.), DVec3::new(0., 200., 0.)]);
    assert!((m.area() - 400.0).abs() < 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Bad input: each error names what is wrong and where

#[test]
fn error_empty_file() {
    let file = TempFile::new("empty.obj", b"");
    let e = load_obj(&file.0).unwrap_err();
    assert!(matches!(e, MeshError::Empty(_)), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("empty.obj") && msg.contains("no vertices"), "{msg}");

    // Vertices but no faces.
    let e = parse_obj("v 0 0 0\nv 1 0 0\n", "points.obj").unwrap_err();
    assert!(matches!(e, MeshError::Empty(_)), "{e:?}");
    assert!(e.to_string().contains("points.obj: there are no faces"), "{e}");

    // An empty PLY file, and a PLY with no elements.
    let e = parse_ply(b"", "empty.ply").unwrap_err();
    assert!(matches!(e, MeshError::Parse { line: 1, .. }), "{e:?}");
    let e = parse_ply(
        b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        "none.ply",
    )
    .unwrap_err();
    assert!(matches!(e, MeshError::Empty(_)), "{e:?}");
    assert!(e.to_string().contains("none.ply"), "{e}");

    // Empty arrays.
    let e = TriMesh::from_polygons(vec![], &[], &WeldOptions::default()).unwrap_err();
    assert!(matches!(e, MeshError::Empty(_)), "{e:?}");
}

#[test]
fn error_nan_coordinate() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n";
    let e = parse_obj(text, "nan.obj").unwrap_err();
    match e {
        MeshError::NonFinite { vertex: 2, x, y, line: Some(3), .. } => {
            assert_eq!(x, 0.0);
            assert!(y.is_nan());
        }
        ref other => panic!("{other:?}"),
    }
    assert!(e.to_string().starts_with("nan.obj:3: vertex 2 has a non-finite coordinate (0, NaN, 0)"), "{e}");

    let v = vec![DVec3::ZERO, DVec3::X, DVec3::new(f64::NAN, 0., 0.)];
    let e = TriMesh::from_polygons(v, &[vec![0, 1, 2]], &WeldOptions::default()).unwrap_err();
    assert!(matches!(e, MeshError::NonFinite { vertex: 2, line: None, .. }), "{e:?}");
    assert!(e.to_string().starts_with("vertex 2 has"), "{e}");
}

#[test]
fn error_infinite_coordinate() {
    // 1e400 overflows to infinity; "inf" is infinity too.
    for (token, line) in [("1e400", 2), ("-inf", 2)] {
        let text = format!("v 0 0 0\nv 1 0 {token}\nv 0 1 0\nf 1 2 3\n");
        let e = parse_obj(&text, "inf.obj").unwrap_err();
        assert!(matches!(e, MeshError::NonFinite { vertex: 1, z, line: Some(l), .. } if z.is_infinite() && l == line), "{e:?}");
        assert!(e.to_string().starts_with("inf.obj:2: vertex 1"), "{e}");
    }
    // In a binary PLY.
    let v = [DVec3::ZERO, DVec3::new(0., f64::INFINITY, 0.), DVec3::Y];
    let bytes = write_ply(PlyFormat::LittleEndian, false, &v, &[vec![0, 1, 2]]);
    let e = parse_ply(&bytes, "inf.ply").unwrap_err();
    assert!(matches!(e, MeshError::NonFinite { vertex: 1, line: None, .. }), "{e:?}");
    assert!(e.to_string().starts_with("inf.ply: vertex 1 has a non-finite coordinate (0, inf, 0)"), "{e}");
}

#[test]
fn error_index_out_of_range() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n";
    let e = parse_obj(text, "range.obj").unwrap_err();
    assert!(matches!(e, MeshError::IndexOutOfRange { face: 1, index: 9, vertex_count: 3, line: Some(5), .. }), "{e:?}");
    assert_eq!(e.to_string(), "range.obj:5: face 1 refers to vertex 9, but there are 3 vertices");

    // Arrays (0-based).
    let v = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
    let e = TriMesh::from_polygons(v, &[vec![0, 1, 2], vec![0, 3, 1]], &WeldOptions::default()).unwrap_err();
    assert!(matches!(e, MeshError::IndexOutOfRange { face: 1, index: 3, vertex_count: 3, .. }), "{e:?}");
    assert_eq!(e.to_string(), "face 1 refers to vertex 3, but there are 3 vertices");

    // PLY: past the end, and negative.
    let v = [DVec3::ZERO, DVec3::X, DVec3::Y];
    for (bad, format) in [(3u32, PlyFormat::Ascii), (u32::MAX, PlyFormat::BigEndian)] {
        let bytes = write_ply(format, false, &v, &[vec![0, 1, 2], vec![2, 1, bad]]);
        let e = parse_ply(&bytes, "range.ply").unwrap_err();
        // u32::MAX is written as the int -1.
        let expected = if bad == 3 { 3 } else { -1 };
        assert!(matches!(e, MeshError::IndexOutOfRange { face: 1, index, vertex_count: 3, .. } if index == expected), "{e:?}");
        assert!(e.to_string().contains(&format!("face 1 refers to vertex {expected}")), "{e}");
        if let PlyFormat::Ascii = format {
            assert!(e.to_string().starts_with("range.ply:19: "), "{e}");
        }
    }
}

#[test]
fn error_negative_relative_index_too_far_back() {
    let text = "v 0 0 0\nv 1 0 0\nf -1 -2 -3\n";
    let e = parse_obj(text, "rel.obj").unwrap_err();
    assert!(matches!(e, MeshError::IndexOutOfRange { face: 0, index: -3, vertex_count: 2, line: Some(3), .. }), "{e:?}");
    assert_eq!(e.to_string(), "rel.obj:3: face 0 refers to vertex -3, but there are 2 vertices");
    // Relative indices count from the vertices defined so far, not from the end of the file.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 9 9 9\n";
    let m = parse_obj(text, "rel.obj").unwrap();
    assert_eq!(m.triangles(), &[[0, 1, 2]]);
}

#[test]
fn error_zero_index() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 0/1 3\n";
    let e = parse_obj(text, "zero.obj").unwrap_err();
    assert!(matches!(e, MeshError::Parse { line: 5, .. }), "{e:?}");
    let msg = e.to_string();
    assert!(msg.starts_with("zero.obj:5: vertex index 0 in face corner '0/1'"), "{msg}");
}

#[test]
fn error_face_with_two_vertices() {
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n";
    let e = parse_obj(text, "two.obj").unwrap_err();
    assert!(matches!(e, MeshError::TooFewVertices { face: 1, count: 2, line: Some(5), .. }), "{e:?}");
    assert_eq!(e.to_string(), "two.obj:5: face 1 has 2 vertices; a face needs at least 3");

    let v = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let bytes = write_ply(PlyFormat::LittleEndian, false, &v, &[vec![0, 1, 2], vec![0, 1]]);
    let e = parse_ply(&bytes, "two.ply").unwrap_err();
    assert!(matches!(e, MeshError::TooFewVertices { face: 1, count: 2, .. }), "{e:?}");
    assert!(e.to_string().starts_with("two.ply: face 1 has 2 vertices"), "{e}");

    let e = TriMesh::from_polygons(v.to_vec(), &[vec![0, 1, 2], vec![]], &WeldOptions::default()).unwrap_err();
    assert!(matches!(e, MeshError::TooFewVertices { face: 1, count: 0, .. }), "{e:?}");
}

#[test]
fn error_only_zero_area_faces() {
    // Collinear corners, a repeated corner, and a triangle collapsed by welding.
    let text = "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 1 0 1e-12\nf 1 2 3\nf 1 2 2\nf 1 2 4\nf 1 2 3 4\n";
    let e = parse_obj(text, "flat.obj").unwrap_err();
    assert!(matches!(e, MeshError::AllFacesDegenerate { faces: 4, .. }), "{e:?}");
    assert_eq!(e.to_string(), "flat.obj: all 4 faces have zero area: there is no surface");

    // Every vertex at one point.
    let e = TriMesh::from_triangles(&[[1.0f32; 3]; 3], &[0, 1, 2]).unwrap_err();
    assert!(matches!(e, MeshError::AllFacesDegenerate { faces: 1, path: None }), "{e:?}");
}

#[test]
fn error_neither_obj_nor_ply() {
    let junk: Vec<u8> = (0..=255u8).cycle().take(1000).collect();
    let file = TempFile::new("junk.bin", &junk);
    let e = mesh::load(&file.0).unwrap_err();
    assert!(matches!(e, MeshError::UnknownFormat { .. }), "{e:?}");
    assert!(e.to_string().contains("junk.bin") && e.to_string().contains("not an OBJ or PLY"), "{e}");

    // A missing file names the file.
    let missing = std::env::temp_dir().join("transcut-definitely-missing.obj");
    let e = mesh::load(&missing).unwrap_err();
    assert!(matches!(e, MeshError::Io { .. }), "{e:?}");
    assert!(e.to_string().contains("transcut-definitely-missing.obj"), "{e}");

    // A file that claims to be OBJ but has garbage lines.
    let e = parse_obj("v 0 0 0\n\u{1}\u{2}garbage\n", "bad.obj").unwrap_err();
    assert!(matches!(e, MeshError::Parse { line: 2, .. }), "{e:?}");
}

#[test]
fn error_truncated_binary_ply() {
    let (v, f) = unit_cube_as_separate_quads();
    let bytes = write_ply(PlyFormat::LittleEndian, false, &v, &f);
    let header_len = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    // Cut in the middle of the faces: each vertex is 25 bytes, each quad 17 bytes.
    let cut = header_len + 24 * 25 + 2 * 17 + 5;
    let e = parse_ply(&bytes[..cut], "cut.ply").unwrap_err();
    assert!(matches!(e, MeshError::Truncated { .. }), "{e:?}");
    assert_eq!(e.to_string(), "cut.ply: truncated: the data ends in face 2 of 6 (property 'vertex_indices')");
    // Cut in the vertices.
    let cut = header_len + 10 * 25 + 20;
    let e = parse_ply(&bytes[..cut], "cut.ply").unwrap_err();
    assert!(e.to_string().contains("vertex 10 of 24 (property 'z')"), "{e}");
    // Cut in the trailing element that is skipped.
    let e = parse_ply(&bytes[..bytes.len() - 1], "cut.ply").unwrap_err();
    assert!(e.to_string().contains("edge 0 of 1 (property 'crease')"), "{e}");
    // Cut in the header.
    let e = parse_ply(&bytes[..header_len - 11], "cut.ply").unwrap_err();
    assert!(matches!(e, MeshError::Truncated { .. }), "{e:?}");
    assert!(e.to_string().contains("without 'end_header'"), "{e}");
    // ASCII too.
    let text = write_ply(PlyFormat::Ascii, false, &v, &f);
    let e = parse_ply(&text[..text.len() - 20], "cut.ply").unwrap_err();
    assert!(matches!(e, MeshError::Truncated { .. }), "{e:?}");
    assert!(e.to_string().contains("face 5 of 6"), "{e}");
}

#[test]
fn error_ply_bad_header_line() {
    let (v, f) = unit_cube_as_separate_quads();
    let good = String::from_utf8(write_ply(PlyFormat::Ascii, false, &v, &f)).unwrap();
    let cases = [
        ("property double y", "property dubble y", 7, "unknown property type 'dubble'"),
        ("format ascii 1.0", "format ascii 2.0", 2, "unsupported PLY version '2.0'"),
        ("format ascii 1.0", "format utf8 1.0", 2, "unknown format 'utf8'"),
        ("element face 6", "element face six", 9, "cannot read 'six' as the number of 'face' elements"),
        ("comment written", "remark written", 3, "unknown header keyword 'remark'"),
        ("ply\n", "plx\n", 1, "not a PLY file"),
        ("property list uchar int vertex_indices", "property list uchar int corners", 9, "no list property 'vertex_indices'"),
    ];
    for (from, to, line, needle) in cases {
        let bad = good.replacen(from, to, 1);
        let e = parse_ply(bad.as_bytes(), "hdr.ply").unwrap_err();
        assert!(matches!(e, MeshError::Parse { line: l, .. } if l == line), "{to}: {e:?}");
        let msg = e.to_string();
        assert!(msg.starts_with(&format!("hdr.ply:{line}: ")) && msg.contains(needle), "{msg}");
    }
}

#[test]
fn error_obj_bad_number_names_token_and_line() {
    let e = parse_obj("v 0 0 0\nv 1 0,5 0\n", "comma.obj").unwrap_err();
    assert!(matches!(e, MeshError::Parse { line: 2, .. }), "{e:?}");
    assert_eq!(e.to_string(), "comma.obj:2: cannot read '0,5' as the y coordinate of a vertex");
    let e = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "face.obj").unwrap_err();
    assert_eq!(e.to_string(), "face.obj:4: cannot read 'x' in face corner 'x' as a vertex index");
}

#[test]
fn error_bad_arrays() {
    let e = TriMesh::from_triangles(&[[0.0f64; 3]; 3], &[0, 1, 2, 0]).unwrap_err();
    assert!(matches!(e, MeshError::IndexCountNotMultipleOf3 { len: 4 }), "{e:?}");
    assert!(e.to_string().contains("4 entries"), "{e}");
    let v = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
    let e = TriMesh::from_polygons(v, &[vec![0, 1, 2]], &WeldOptions { relative_tolerance: -1.0 }).unwrap_err();
    assert!(matches!(e, MeshError::InvalidTolerance { .. }), "{e:?}");
}

#[test]
fn a_gridded_box_is_closed_with_its_lattice_area_and_volume() {
    let m = mesh::gridded_box(DVec3::new(3.0, 2.0, 1.5), [6, 4, 3]);
    // The surface lattice: (a+1)(b+1)(c+1) − (a−1)(b−1)(c−1) vertices, 4(ab + bc + ca)
    // triangles; wound outwards as built (nothing flipped).
    assert_eq!(m.positions().len(), 7 * 5 * 4 - 5 * 3 * 2);
    assert_eq!(m.triangles().len(), 4 * (6 * 4 + 4 * 3 + 3 * 6));
    assert!(m.is_closed());
    assert_eq!(m.flipped_faces(), 0);
    assert!((m.area() - 2.0 * (6.0 + 3.0 + 4.5)).abs() < 1e-12);
    assert!((m.signed_volume() - 9.0).abs() < 1e-12);
    assert!(m.positions().iter().any(|p| (*p - DVec3::new(0.5, 2.0, 1.0)).length() < 1e-15));
}
