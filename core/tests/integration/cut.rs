//! Cutting and fracture geometry (`transcut::edit::cut`, `transcut::edit::pieces`), checked on a
//! meshed unit sphere against closed forms: spherical-cap volumes, the exact volume of the input
//! mesh clipped by the plane, the dihedral bound, the cut surface lying on the cutter, original tet
//! ids, complementary halves, strokes equal to planes, solids, components and welding.

use crate::common;

use std::collections::HashSet;
use std::f64::consts::PI;
use std::sync::OnceLock;

use common::uv_sphere;
use glam::DMat4;
use transcut::edit::cut::{cut, CutOptions, CutResult, CutStats};
use transcut::edit::pieces::{check_rigid, connected_components, extract, weld};
use transcut::edit::EditError;
use transcut::edit::{Cutter, SweptStroke};
use transcut::mesh::{tet_volume, TetMesh, TriMesh};
use transcut::mesher::{tetrahedralize, tetrahedralize_with, Grading, MesherOptions};
use transcut::DVec3;
use transcut::Progress;

const RADIUS: f64 = 1.0;

/// The unit sphere meshed with about 30k tets (shared by the tests).
fn sphere() -> &'static TetMesh {
    static MESH: OnceLock<TetMesh> = OnceLock::new();
    MESH.get_or_init(|| tetrahedralize(&uv_sphere(RADIUS, 96, 48), &MesherOptions::with_tets(30_000)).unwrap())
}

/// The unit sphere meshed graded (one cube per size) with about 30k tets: the cuts cross its
/// transition tets as well as the stuffed surface layer.
fn graded_sphere() -> &'static TetMesh {
    static MESH: OnceLock<TetMesh> = OnceLock::new();
    MESH.get_or_init(|| {
        let options = MesherOptions { grading: Grading::Graded { layers: 1 }, ..MesherOptions::with_tets(30_000) };
        let t = tetrahedralize_with(&uv_sphere(RADIUS, 96, 48), &options, Progress::none()).unwrap();
        assert!(t.stats.cubes_per_level.len() >= 3 && t.stats.cubes_per_level[1] > 0, "{:?}", t.stats.cubes_per_level);
        t.mesh
    })
}

fn identity_ids(mesh: &TetMesh) -> Vec<u32> {
    (0..mesh.tet_count() as u32).collect()
}

/// Mean edge length of a mesh.
fn mean_edge(mesh: &TetMesh) -> f64 {
    let p = mesh.positions();
    mesh.edges().iter().map(|&[a, b]| (p[a as usize] - p[b as usize]).length()).sum::<f64>() / mesh.edges().len() as f64
}

/// Exact volume of `{x : (x − point)·n̂ ≤ 0}` inside the tets of `mesh` (each tet clipped by the
/// plane: a corner tet, its complement, or a triangular prism).
fn clipped_volume(mesh: &TetMesh, point: DVec3, normal: DVec3) -> f64 {
    let n = normal.normalize();
    let mut total = 0.0;
    for t in 0..mesh.tet_count() {
        let p = mesh.tet_positions(t);
        let d = p.map(|x| (x - point).dot(n));
        let neg: Vec<usize> = (0..4).filter(|&i| d[i] <= 0.0).collect();
        let pos: Vec<usize> = (0..4).filter(|&i| d[i] > 0.0).collect();
        let cross = |i: usize, j: usize| p[i] + (d[i] / (d[i] - d[j])) * (p[j] - p[i]);
        let v = tet_volume(p).abs();
        total += match neg.len() {
            0 => 0.0,
            4 => v,
            1 => {
                let i = neg[0];
                tet_volume([p[i], cross(i, pos[0]), cross(i, pos[1]), cross(i, pos[2])]).abs()
            }
            3 => {
                let i = pos[0];
                v - tet_volume([p[i], cross(i, neg[0]), cross(i, neg[1]), cross(i, neg[2])]).abs()
            }
            _ => {
                let (a, b, c, e) = (neg[0], neg[1], pos[0], pos[1]);
                let (a0, a1, a2) = (p[a], cross(a, c), cross(a, e));
                let (b0, b1, b2) = (p[b], cross(b, c), cross(b, e));
                tet_volume([a0, a1, a2, b0]).abs() + tet_volume([a1, a2, b0, b1]).abs() + tet_volume([a2, b0, b1, b2]).abs()
            }
        };
    }
    total
}

/// Volume of a ball of radius r on the side of a plane at signed distance `s` from its centre
/// that does NOT contain the centre direction... precisely: the part `{x : x·n̂ ≤ c}` with
/// `c = point·n̂`: the whole ball minus the cap of height `r − c` (for |c| ≤ r).
fn ball_below(r: f64, c: f64) -> f64 {
    let h = r - c;
    4.0 / 3.0 * PI * r.powi(3) - PI * h * h * (3.0 * r - h) / 3.0
}

/// Boundary faces of `result` that are not boundary faces of `input` (the new cut surface), as
/// result vertex triples.
fn new_faces(input: &TetMesh, result: &CutResult) -> Vec<[u32; 3]> {
    let sorted = |mut f: [u32; 3]| {
        f.sort_unstable();
        f
    };
    let old: HashSet<[u32; 3]> = input.boundary_faces().iter().map(|f| sorted(f.vertices)).collect();
    result
        .mesh
        .boundary_faces()
        .iter()
        .map(|f| f.vertices)
        .filter(|f| !old.contains(&sorted(f.map(|v| result.kept_vertex[v as usize]))))
        .collect()
}

fn min_dihedral_deg(mesh: &TetMesh) -> f64 {
    mesh.quality().min_dihedral_deg
}

#[test]
fn plane_cut_of_a_sphere_keeps_quality_and_lies_on_the_plane() {
    plane_cut_keeps_quality_and_lies_on_the_plane(sphere());
}

/// The same on a graded mesh: the plane passes through cubes of three sizes and the tets between
/// them, and every property holds as on the uniform mesh.
#[test]
fn plane_cut_of_a_graded_sphere_keeps_quality_and_lies_on_the_plane() {
    plane_cut_keeps_quality_and_lies_on_the_plane(graded_sphere());
}

fn plane_cut_keeps_quality_and_lies_on_the_plane(mesh: &TetMesh) {
    let ids = identity_ids(mesh);
    let point = DVec3::new(0.05, -0.02, 0.3);
    let normal = DVec3::new(0.1, 0.2, 1.0);
    let cutter = Cutter::Plane { point, normal };
    let r = cut(mesh, &ids, &cutter, &CutOptions::default()).unwrap();
    let s = &r.stats;
    eprintln!("{s:#?}, input worst {}", min_dihedral_deg(mesh));
    let h = mean_edge(mesh);

    // The bound: the mesher's tets are ≥ 10.7°, so the 5° floor is the bound; every tet meets it.
    assert!(min_dihedral_deg(mesh) > 10.0);
    assert_eq!(s.bound_degrees, 5.0);
    assert!(min_dihedral_deg(&r.mesh) >= s.bound_degrees, "{}", min_dihedral_deg(&r.mesh));
    assert!((min_dihedral_deg(&r.mesh) - s.min_dihedral_degrees).abs() < 1e-9);

    // The cut surface lies on the plane within the reported tolerance, which is tiny.
    let faces = new_faces(mesh, &r);
    assert!(faces.len() > 100, "{} cut faces", faces.len());
    let d = |x: DVec3| (x - point).dot(normal.normalize());
    let on_cut: HashSet<u32> = faces.iter().flatten().copied().collect();
    let worst = on_cut.iter().map(|&v| d(r.mesh.positions()[v as usize]).abs()).fold(0.0, f64::max);
    assert!(worst <= s.max_cut_distance + 1e-15, "{worst} > {}", s.max_cut_distance);
    assert!(s.max_cut_distance <= 1e-3 * h, "tolerance {} vs edge {h}", s.max_cut_distance);
    // … and its faces are flat on it, facing out along the normal.
    let area: f64 = faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| r.mesh.positions()[v as usize]);
            0.5 * (b - a).cross(c - a).dot(normal.normalize())
        })
        .sum();
    let c = point.dot(normal.normalize());
    let disc = PI * (RADIUS * RADIUS - c * c);
    assert!((area / disc - 1.0).abs() < 0.01, "cut area {area} vs disc {disc}");

    // No tet reaches into the removed side.
    let far = r.mesh.positions().iter().map(|&x| d(x)).fold(f64::NEG_INFINITY, f64::max);
    assert!(far <= s.max_cut_distance + 1e-15, "{far}");

    // Volume: the exact clip of the input mesh (tight) and the spherical cap (mesh fidelity).
    let exact = clipped_volume(mesh, point, normal);
    let v = r.mesh.volume();
    eprintln!("volume {v}, exact clip {exact}, analytic {}", ball_below(RADIUS, c));
    assert!((v / exact - 1.0).abs() < 0.003, "{v} vs clipped {exact}");
    assert!((v / ball_below(RADIUS, c) - 1.0).abs() < 0.01, "{v} vs cap {}", ball_below(RADIUS, c));

    // Ids: every tet is the input tet it says it is (same vertices), unmoved tets unchanged.
    assert_eq!(r.original_tet.len(), r.mesh.tet_count());
    assert_eq!(r.kept_vertex.len(), r.mesh.vertex_count());
    assert!(r.kept_vertex.windows(2).all(|w| w[0] < w[1]));
    let mut unmoved = 0;
    for (t, &o) in r.original_tet.iter().enumerate() {
        let mut mine = r.mesh.tets()[t].map(|v| r.kept_vertex[v as usize]);
        let mut theirs = mesh.tets()[o as usize];
        mine.sort_unstable();
        theirs.sort_unstable();
        assert_eq!(mine, theirs, "tet {t}");
        let c_new: DVec3 = r.mesh.tet_positions(t).iter().sum::<DVec3>() / 4.0;
        let c_old: DVec3 = mesh.tet_positions(o as usize).iter().sum::<DVec3>() / 4.0;
        let moved = r.mesh.tets()[t]
            .iter()
            .any(|&v| r.mesh.positions()[v as usize] != mesh.positions()[r.kept_vertex[v as usize] as usize]);
        if !moved {
            assert_eq!(c_new, c_old);
            unmoved += 1;
        }
        assert_eq!(r.mesh.materials()[t], mesh.materials()[o as usize]);
    }
    assert!(unmoved > r.mesh.tet_count() / 2);
    assert_eq!(s.removed_tets, mesh.tet_count() - r.mesh.tet_count());
    assert_eq!(s.removed_vertices, mesh.vertex_count() - r.mesh.vertex_count());
}

#[test]
fn the_flipped_cutter_keeps_the_complement() {
    let mesh = sphere();
    let ids = identity_ids(mesh);
    let cutter = Cutter::Plane { point: DVec3::new(0.0, 0.1, 0.0), normal: DVec3::new(1.0, -0.3, 0.5) };
    let a = cut(mesh, &ids, &cutter, &CutOptions::default()).unwrap();
    let b = cut(mesh, &ids, &cutter.flipped(), &CutOptions::default()).unwrap();
    let (va, vb, whole) = (a.mesh.volume(), b.mesh.volume(), mesh.volume());
    eprintln!("{va} + {vb} = {} vs {whole}; {:?} {:?}", va + vb, a.stats, b.stats);
    assert!(((va + vb) / whole - 1.0).abs() < 0.01);
    // Every input tet is kept on at least one side; the two sides overlap only near the cut.
    let mut kept = vec![0u8; mesh.tet_count()];
    for &t in a.original_tet.iter().chain(&b.original_tet) {
        kept[t as usize] += 1;
    }
    let lost = kept.iter().filter(|&&k| k == 0).count();
    assert!(lost < mesh.tet_count() / 100, "{lost} tets on neither side");
    for r in [&a, &b] {
        assert!(min_dihedral_deg(&r.mesh) >= r.stats.bound_degrees);
    }
}

#[test]
fn an_orthographic_two_point_stroke_is_the_plane_through_it() {
    let mesh = sphere();
    let ids = identity_ids(mesh);
    let dir = DVec3::new(0.1, -0.05, -1.0);
    let (o0, o1) = (DVec3::new(-3.0, 0.2, 4.0), DVec3::new(3.0, 0.35, 4.0));
    let stroke = SweptStroke::new(vec![o0, o1], vec![dir, dir]).unwrap();
    let plane = Cutter::Plane { point: o0, normal: (o1 - o0).cross(dir) };
    let a = cut(mesh, &ids, &Cutter::Stroke(stroke), &CutOptions::default()).unwrap();
    let b = cut(mesh, &ids, &plane, &CutOptions::default()).unwrap();
    assert_eq!(a.mesh.positions(), b.mesh.positions());
    assert_eq!(a.mesh.tets(), b.mesh.tets());
    assert_eq!(a.original_tet, b.original_tet);
    let untimed = |s: &CutStats| CutStats { classify_ms: 0.0, separate_ms: 0.0, snap_ms: 0.0, total_ms: 0.0, ..s.clone() };
    assert_eq!(untimed(&a.stats), untimed(&b.stats));
    // Drawn left to right along +x looking along −z: the upper (+y) side is removed.
    assert!(a.mesh.positions().iter().all(|p| p.y < 0.5));
}

#[test]
fn a_perspective_stroke_removes_its_left_side() {
    let mesh = sphere();
    let ids = identity_ids(mesh);
    let eye = DVec3::new(0.0, 0.0, 5.0);
    // Screen points on the plane z = 0, drawn from left (−x) to right (+x) at y = 0.25: the
    // viewer looks along −z with y up, so the left of the stroke is above it (+y).
    let dirs = [DVec3::new(-2.0, 0.25, 0.0), DVec3::new(0.0, 0.3, 0.0), DVec3::new(2.0, 0.25, 0.0)].map(|p| p - eye);
    let stroke = SweptStroke::perspective(eye, dirs.to_vec()).unwrap();
    let cutter = Cutter::Stroke(stroke);
    assert!(cutter.signed_distance(DVec3::new(0.0, 0.9, 0.0)) > 0.0);
    assert!(cutter.signed_distance(DVec3::new(0.0, -0.9, 0.0)) < 0.0);
    let r = cut(mesh, &ids, &cutter, &CutOptions::default()).unwrap();
    eprintln!("{:?}", r.stats);
    // The surface through the eye and the screen line y = 0.25 (x ≤ 0 half): y = 0.25 (5 − z)/5
    // for the outer quads; every kept vertex lies below the swept surface.
    for p in r.mesh.positions() {
        assert!(cutter.signed_distance(*p) <= r.stats.max_cut_distance + 1e-12);
    }
    assert!(r.stats.max_cut_distance < 1e-6);
    let top = r.mesh.positions().iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
    assert!(top < 0.36 && top > 0.2, "{top}");
    // The flipped stroke (drawn right to left) keeps the top instead.
    let f = cut(mesh, &ids, &cutter.flipped(), &CutOptions::default()).unwrap();
    let bottom = f.mesh.positions().iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    assert!(bottom > 0.2, "{bottom}");
    assert!(((r.mesh.volume() + f.mesh.volume()) / mesh.volume() - 1.0).abs() < 0.01);
}

/// An axis-aligned cube `[c − a, c + a]³` as a closed outward triangle mesh.
fn cube(c: DVec3, a: f64) -> TriMesh {
    let mut positions = Vec::new();
    for i in 0..8 {
        positions.push(
            c + a * DVec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            ),
        );
    }
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let polys: Vec<Vec<u32>> = quads.iter().map(|q| q.to_vec()).collect();
    TriMesh::from_polygons(positions, &polys, &Default::default()).unwrap()
}

#[test]
fn a_solid_cube_removes_its_inside() {
    let mesh = sphere();
    let ids = identity_ids(mesh);
    let box_ = cube(DVec3::new(0.05, -0.03, 0.02), 0.4);
    assert!(box_.signed_volume() > 0.0);
    let cutter = Cutter::Solid(box_);
    assert!(cutter.signed_distance(DVec3::new(0.05, -0.03, 0.02)) > 0.35);
    assert!(cutter.signed_distance(DVec3::new(0.9, 0.0, 0.0)) < 0.0);
    let r = cut(mesh, &ids, &cutter, &CutOptions::default()).unwrap();
    eprintln!("{:?}", r.stats);
    let expected = mesh.volume() - 0.8f64.powi(3);
    assert!((r.mesh.volume() / expected - 1.0).abs() < 0.01, "{} vs {expected}", r.mesh.volume());
    assert!(min_dihedral_deg(&r.mesh) >= r.stats.bound_degrees);
    // The flipped cube keeps only the cube.
    let f = cut(mesh, &ids, &cutter.flipped(), &CutOptions::default()).unwrap();
    eprintln!("{:?}", f.stats);
    assert!((f.mesh.volume() / 0.512 - 1.0).abs() < 0.02, "{}", f.mesh.volume());
}

/// The sphere and a copy translated by `offset`, as one mesh.
fn two_spheres(offset: DVec3) -> TetMesh {
    let m = sphere();
    let mut positions = m.positions().to_vec();
    positions.extend(m.positions().iter().map(|p| *p + offset));
    let n = m.vertex_count() as u32;
    let mut tets = m.tets().to_vec();
    tets.extend(m.tets().iter().map(|t| t.map(|v| v + n)));
    let materials = (0..2 * m.tet_count() as u32).map(|t| t % 3).collect();
    TetMesh::new(positions, tets, materials).unwrap()
}

#[test]
fn components_and_extract_round_trip() {
    let offset = DVec3::new(3.0, 0.0, 0.0);
    let both = two_spheres(offset);
    let m = sphere();
    let comps = connected_components(&both);
    assert_eq!(comps.len(), 2);
    let n = m.tet_count() as u32;
    assert_eq!(comps[0], (0..n).collect::<Vec<_>>());
    assert_eq!(comps[1], (n..2 * n).collect::<Vec<_>>());
    let ids: Vec<u32> = (100..100 + 2 * n).collect();
    let (second, second_ids) = extract(&both, &ids, &comps[1]).unwrap();
    assert_eq!(second.tets(), m.tets());
    assert_eq!(second_ids, (100 + n..100 + 2 * n).collect::<Vec<_>>());
    assert!(second.positions().iter().zip(m.positions()).all(|(a, b)| *a == *b + offset));
    assert_eq!(second.materials(), &both.materials()[n as usize..]);
    assert!(matches!(extract(&both, &ids, &[]), Err(EditError::InvalidOptions(_))));
    assert!(matches!(extract(&both, &ids, &[2 * n]), Err(EditError::InvalidOptions(_))));
    assert!(matches!(extract(&both, &ids, &[1, 1]), Err(EditError::InvalidOptions(_))));
    assert!(matches!(extract(&both, &ids[1..], &[1]), Err(EditError::InvalidOptions(_))));
}

#[test]
fn a_slab_cut_fractures_the_sphere_in_two() {
    slab_cut_fractures_in_two(sphere(), 0.15);
}

/// The graded sphere's interior tets are larger than these slabs are thick: tets whose four
/// vertices lie outside the slab on both sides of it must still go, or the two parts stay joined.
#[test]
fn a_slab_thinner_than_the_interior_tets_fractures_the_graded_sphere_in_two() {
    let mesh = graded_sphere();
    let longest = mesh
        .edges()
        .iter()
        .map(|&[a, b]| (mesh.positions()[a as usize] - mesh.positions()[b as usize]).length())
        .fold(0.0, f64::max);
    for half in [0.08, 0.04, 0.02] {
        assert!(2.0 * half < longest, "{half} vs {longest}");
        slab_cut_fractures_in_two(mesh, half);
    }
}

/// The flipped slab keeps only the disc of the sphere inside it: on the uniform sphere its
/// volume `π (2a − 2a³/3)` (half-thickness a, R = 1) within 2%, every vertex inside the slab to
/// the cut's tolerance. On the graded sphere a slab thinner than the tets keeps a valid piece
/// inside it or, when nothing is left, says so, never a panic or a piece outside it. What it
/// keeps is less than the disc: a kept part thinner than the snap band (`SNAP_BAND` times the
/// local edge) has every vertex in the band, so its tets go (measured: 93% of the disc at
/// a = 0.08, 0.3% at a = 0.02, with interior edges up to 0.23).
#[test]
fn the_flipped_slab_keeps_the_disc_inside_it() {
    let slab =
        |half: f64| Cutter::Solid(cube(DVec3::ZERO, 1.0).transformed(&DMat4::from_scale(DVec3::new(2.0, 2.0, half)))).flipped();
    let inside = |r: &CutResult, half: f64| {
        let tolerance = r.stats.max_cut_distance + 1e-9;
        r.mesh.positions().iter().all(|p| p.z.abs() <= half + tolerance)
    };
    let half = 0.15;
    let mesh = sphere();
    let r = cut(mesh, &identity_ids(mesh), &slab(half), &CutOptions::default()).unwrap();
    let expected = PI * (2.0 * half - 2.0 * half.powi(3) / 3.0);
    eprintln!("flipped slab |z| < {half}: {} vs {expected}, {:?}", r.mesh.volume(), r.stats);
    assert!((r.mesh.volume() / expected - 1.0).abs() < 0.02, "{} vs {expected}", r.mesh.volume());
    assert!(inside(&r, half));
    assert!(r.stats.min_dihedral_degrees >= r.stats.bound_degrees);
    let graded = graded_sphere();
    for half in [0.08, 0.02] {
        match cut(graded, &identity_ids(graded), &slab(half), &CutOptions::default()) {
            Ok(r) => {
                eprintln!("graded, flipped slab |z| < {half}: volume {}, {:?}", r.mesh.volume(), r.stats);
                assert!(inside(&r, half), "graded, flipped slab |z| < {half}");
                assert!(r.stats.min_dihedral_degrees >= r.stats.bound_degrees);
            }
            Err(e) => assert!(matches!(e, EditError::NothingLeft { .. }), "{e}"),
        }
    }
}

/// Cuts `mesh` with the slab `|z| < half` and checks two parts, each on its own side of the slab
/// (within the cut's own tolerance) and with the volume of the ball's cap beyond it.
fn slab_cut_fractures_in_two(mesh: &TetMesh, half: f64) {
    let slab = cube(DVec3::ZERO, 1.0).transformed(&DMat4::from_scale(DVec3::new(2.0, 2.0, half)));
    let r = cut(mesh, &identity_ids(mesh), &Cutter::Solid(slab), &CutOptions::default()).unwrap();
    eprintln!("slab |z| < {half}: {:?}", r.stats);
    let comps = connected_components(&r.mesh);
    assert_eq!(comps.len(), 2, "slab |z| < {half}");
    let expected = ball_below(RADIUS, -half);
    let tolerance = r.stats.max_cut_distance + 1e-9;
    for c in &comps {
        let part = extract(&r.mesh, &r.original_tet, c).unwrap().0;
        let (lo, hi) = part.positions().iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.z), hi.max(p.z)));
        assert!(hi <= -half + tolerance || lo >= half - tolerance, "slab |z| < {half}: a part spans z {lo}..{hi}");
        assert!((part.volume() / expected - 1.0).abs() < 0.02, "slab |z| < {half}: {} vs {expected}", part.volume());
    }
}

#[test]
fn weld_glues_two_halves_back() {
    let mesh = sphere();
    let ids = identity_ids(mesh);
    // Halves by tet centroid: they share the faces between them exactly.
    let n = DVec3::new(0.3, 1.0, -0.2);
    let side = |t: usize| mesh.tet_positions(t).iter().sum::<DVec3>().dot(n) > 0.0;
    let a_tets: Vec<u32> = (0..mesh.tet_count() as u32).filter(|&t| side(t as usize)).collect();
    let b_tets: Vec<u32> = (0..mesh.tet_count() as u32).filter(|&t| !side(t as usize)).collect();
    let (a, a_ids) = extract(mesh, &ids, &a_tets).unwrap();
    let (b, b_ids) = extract(mesh, &ids, &b_tets).unwrap();
    let shift = DVec3::new(0.37, -1.9, 2.3);
    let away = b.clone().map_positions(|p| p + shift).unwrap();
    assert!(weld(&a, &a_ids, &away, &b_ids, 1e-9).unwrap().is_none());
    let back = away.map_positions(|p| p - shift).unwrap();
    let (w, w_ids) = weld(&a, &a_ids, &back, &b_ids, 1e-9).unwrap().expect("the halves touch");
    assert_eq!(w.tet_count(), a.tet_count() + b.tet_count());
    assert_eq!(w.vertex_count(), mesh.vertex_count());
    let mut sorted = w_ids.clone();
    sorted.sort_unstable();
    assert_eq!(sorted, ids);
    let area = |m: &TetMesh| (0..m.boundary_faces().len()).map(|f| m.boundary_area(f)).sum::<f64>();
    assert!((area(&w) / area(mesh) - 1.0).abs() < 1e-9, "{} vs {}", area(&w), area(mesh));
    assert_eq!(w.boundary_faces().len(), mesh.boundary_faces().len());
    assert!(w.boundary_topology().is_closed_manifold());
    assert!(matches!(weld(&a, &a_ids, &back, &b_ids, 0.0), Err(EditError::InvalidOptions(_))));
}

#[test]
fn check_rigid_accepts_motions_and_names_what_is_wrong() {
    let rot = DMat4::from_rotation_translation(
        glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, -0.5).normalize(), 0.7),
        DVec3::new(1.0, 2.0, 3.0),
    );
    check_rigid(&rot).unwrap();
    check_rigid(&DMat4::IDENTITY).unwrap();
    let err = |m: DMat4| match check_rigid(&m) {
        Err(EditError::NotRigid(msg)) => msg,
        other => panic!("{other:?}"),
    };
    assert!(err(rot * DMat4::from_scale(DVec3::splat(1.001))).contains("scaling"));
    let mut shear = rot;
    shear.y_axis += 1e-3 * shear.x_axis;
    shear.y_axis = shear.y_axis.truncate().normalize().extend(0.0);
    assert!(err(shear).contains("shear"));
    assert!(err(rot * DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0))).contains("reflection"));
    let mut nan = rot;
    nan.w_axis.x = f64::NAN;
    assert!(err(nan).contains("NaN"));
    let mut projective = rot;
    projective.x_axis.w = 0.1;
    assert!(err(projective).contains("last row"));
}
