//! The editor (`transcut::edit`, TransCut §5) against from-scratch bakes: relighting,
//! material edits and painting give the solution of a fresh assembly and solve; failed edits
//! change nothing; warm starts save iterations.

use glam::{DMat3, DMat4, DVec3};
use transcut::diffusion::SolverKind;
use transcut::edit::{Cutter, EditError, EditOptions, Editor, MediumEdit, MediumOp, PaintStroke, Region};
use transcut::gpu::Backend;
use transcut::light::Light;
use transcut::mesh::TetMesh;
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::Medium;
use transcut::volume::{Coefficients, PerTetMedia};
use transcut::{bake, BakeOptions, MediumSource, Object, Progress, Scene, TransCutOptions};

use crate::common;
use common::uv_sphere;

/// Tight enough that two solutions of the same system agree far below the asserted 1e-6.
const TOLERANCE: f64 = 1e-11;

fn marble() -> Medium {
    Medium::preset("marble").unwrap()
}

/// A ball of radius 10 (1 unit = 1 mm), about 4k tets.
fn ball() -> TetMesh {
    tetrahedralize(&uv_sphere(10.0, 24, 12), &MesherOptions::with_tets(4_000)).unwrap()
}

fn options() -> EditOptions {
    EditOptions { tolerance: TOLERANCE, shadows: false, backend: Some(Backend::Cpu), ..EditOptions::default() }
}

fn bake_options() -> BakeOptions {
    let transcut = TransCutOptions { tolerance: TOLERANCE, backend: Some(Backend::Cpu), ..TransCutOptions::default() };
    BakeOptions { shadows: false, ..BakeOptions::with_method(transcut) }
}

/// The sun straight down, turned by `degrees` about the x axis.
fn sun(degrees: f64) -> Light {
    let d = DMat3::from_rotation_x(degrees.to_radians()) * DVec3::new(0.0, 0.0, -1.0);
    Light::Directional { direction: d, irradiance: [2.0, 1.5, 1.0], angular_diameter_deg: 0.0 }
}

/// A fresh bake of `mesh` filled with `medium` under `lights`: radiance per tet-mesh vertex.
fn fresh(mesh: &TetMesh, medium: MediumSource, lights: &[Light]) -> (Vec<[f64; 3]>, usize) {
    let scene = Scene { objects: vec![Object::from_tets("ref", mesh.clone(), medium, 1.0)], lights: lights.to_vec() };
    let b = bake(&scene, &bake_options()).unwrap();
    let o = &b.objects[0];
    (o.radiance.clone(), o.stats.iterations.iter().sum())
}

/// max |a − b| / max |b| over every vertex and channel.
fn relative_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(scale > 0.0);
    a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / scale
}

fn editor(mesh: &TetMesh, medium: MediumSource, lights: &[Light]) -> Editor {
    Editor::new(&Object::from_tets("ball", mesh.clone(), medium, 1.0), lights, &options()).unwrap()
}

#[test]
fn relight_equals_a_fresh_bake_and_a_warm_start_saves_iterations() {
    let mesh = ball();
    let mut ed = editor(&mesh, marble().into(), &[sun(0.0)]);
    let stats = ed.relight(&[sun(5.0)]).unwrap();
    let (reference, cold_iterations) = fresh(&mesh, marble().into(), &[sun(5.0)]);
    let got = ed.user_radiance().unwrap();
    let diff = relative_difference(&got, &reference);
    let warm: usize = stats.iterations.iter().sum();
    eprintln!("relight: relative difference {diff:.2e}; iterations warm {warm} vs cold {cold_iterations}; {stats:?}");
    assert!(diff < 1e-6, "{diff}");
    assert_eq!((stats.pieces_solved, stats.rows_rebuilt), (1, 0));
    assert!(warm < cold_iterations, "warm {warm} vs cold {cold_iterations}");
    assert_eq!(ed.lights(), &[sun(5.0)]);
}

#[test]
fn a_whole_object_medium_edit_equals_baking_with_that_medium() {
    let mesh = ball();
    let lights = [sun(30.0)];
    let mut ed = editor(&mesh, marble().into(), &lights);
    let jade = Medium { sigma_a: [0.02, 0.005, 0.03], sigma_s_prime: [1.0, 1.3, 0.8], ..marble() };
    let stats = ed.edit_medium(&MediumEdit { region: Region::All, op: MediumOp::Assign(jade) }).unwrap();
    assert_eq!(stats.rows_rebuilt, mesh.vertex_count());
    assert_eq!(stats.tets_changed, mesh.tet_count());
    let (reference, _) = fresh(&mesh, jade.into(), &lights);
    let diff = relative_difference(&ed.user_radiance().unwrap(), &reference);
    eprintln!("assign: relative difference {diff:.2e}");
    assert!(diff < 1e-6, "{diff}");

    // Scaling σa by 2 inside a sphere equals a per-tet bake with those tets doubled.
    let region = Region::Sphere { center: DVec3::new(0.0, 0.0, 8.0), radius: 4.0 };
    let op = MediumOp::Scale { sigma_a: [2.0; 3], sigma_s: [1.0; 3] };
    let stats = ed.edit_medium(&MediumEdit { region, op }).unwrap();
    let mut expect = PerTetMedia::uniform(&mesh, &jade).unwrap();
    let mut touched = 0;
    for t in 0..mesh.tet_count() {
        let c = mesh.tet_positions(t).iter().sum::<DVec3>() / 4.0;
        if c.distance(DVec3::new(0.0, 0.0, 8.0)) <= 4.0 {
            let j = Coefficients::from(&jade);
            expect.set(t, Coefficients::new(j.sigma_a.map(|x| 2.0 * x), j.sigma_s_prime)).unwrap();
            touched += 1;
        }
    }
    assert_eq!(stats.tets_changed, touched);
    assert!(touched > 10 && touched < mesh.tet_count() / 4, "{touched}");
    assert_eq!(ed.media(), &expect);
    let (reference, _) = fresh(&mesh, MediumSource::PerTet(expect), &lights);
    let diff = relative_difference(&ed.user_radiance().unwrap(), &reference);
    assert!(diff < 1e-6, "{diff}");
}

#[test]
fn paint_rebuilds_only_the_rows_of_touched_tets_and_equals_a_fresh_per_tet_solve() {
    let mesh = ball();
    let lights = [sun(10.0)];
    let mut ed = editor(&mesh, marble().into(), &lights);
    // Red, and resolved by the mesh at the surface: the paint fails by the iteration limit.
    let red = Medium { sigma_a: [0.001, 0.05, 0.1], sigma_s_prime: [3.0, 1.0, 1.0], ..marble() };
    let points: Vec<DVec3> = (0..8).map(|k| 10.0 * DVec3::new(1.0, 0.1 * k as f64, 0.05 * k as f64).normalize()).collect();
    let stroke = PaintStroke { points: points.clone(), radius: 1.5, medium: red, strength: 0.9 };
    let stats = ed.paint(&stroke).unwrap();

    // The touched tets, their vertices and the painted media, computed here independently.
    let mut painted = PerTetMedia::uniform(&mesh, &marble()).unwrap();
    let mut rows = vec![false; mesh.vertex_count()];
    let mut touched = 0;
    for t in 0..mesh.tet_count() {
        let c = mesh.tet_positions(t).iter().sum::<DVec3>() / 4.0;
        let d = points.iter().map(|p| p.distance(c)).fold(f64::INFINITY, f64::min);
        let w = 0.9 * (-d * d / (2.0 * 1.5 * 1.5)).exp();
        if w >= 1e-3 {
            touched += 1;
            painted.set(t, Coefficients::from(&marble()).lerp(&Coefficients::from(&red), w)).unwrap();
            for v in mesh.tets()[t] {
                rows[v as usize] = true;
            }
        }
    }
    let rows = rows.iter().filter(|&&r| r).count();
    eprintln!("paint: {touched} tets, {rows} of {} rows; {stats:?}", mesh.vertex_count());
    assert_eq!(stats.tets_changed, touched);
    assert_eq!(stats.rows_rebuilt, rows);
    assert!(rows > 20 && rows < mesh.vertex_count() / 3, "{rows}");
    assert_eq!(ed.media(), &painted);
    let (reference, _) = fresh(&mesh, MediumSource::PerTet(painted), &lights);
    let diff = relative_difference(&ed.user_radiance().unwrap(), &reference);
    eprintln!("paint: relative difference {diff:.2e}");
    assert!(diff < 1e-5, "{diff}");
}

#[test]
fn failed_edits_return_the_named_error_and_change_nothing() {
    let mesh = ball();
    let mut ed = editor(&mesh, marble().into(), &[sun(0.0)]);
    let before = ed.user_radiance().unwrap();
    let media = ed.media().clone();
    let stroke = PaintStroke { points: vec![DVec3::new(10.0, 0.0, 0.0)], radius: 1.0, medium: marble(), strength: 1.0 };
    let nan = PaintStroke { points: vec![DVec3::new(f64::NAN, 0.0, 0.0)], ..stroke.clone() };
    assert!(matches!(ed.paint(&nan), Err(EditError::InvalidStroke(_))));
    let negative = PaintStroke { radius: -1.0, ..stroke.clone() };
    assert!(matches!(ed.paint(&negative), Err(EditError::InvalidStroke(_))));
    let other_eta = PaintStroke { medium: Medium { eta: 1.2, ..marble() }, ..stroke };
    assert!(matches!(ed.paint(&other_eta), Err(EditError::InvalidStroke(_))));
    let mask = MediumEdit { region: Region::Mask(vec![true; mesh.tet_count() - 1]), op: MediumOp::Assign(marble()) };
    assert!(matches!(ed.edit_medium(&mask), Err(EditError::InvalidRegion(_))));
    let negative_result = MediumEdit { region: Region::All, op: MediumOp::Add { sigma_a: [-1.0; 3], sigma_s: [0.0; 3] } };
    assert!(matches!(ed.edit_medium(&negative_result), Err(EditError::Volume(_))));
    let bad_light = Light::Point { position: DVec3::new(f64::NAN, 0.0, 0.0), intensity: [1.0; 3] };
    assert!(matches!(ed.relight(&[bad_light]), Err(EditError::Light(_))));
    // A solve that cannot converge in one iteration fails after the matrix was refilled: the
    // refilled copy is dropped.
    let object = Object::from_tets("ball", mesh.clone(), marble().into(), 1.0);
    let baked = bake(&Scene { objects: vec![object], lights: vec![sun(0.0)] }, &bake_options()).unwrap();
    // The bake's φ already solves the editor's system: no iteration needed to start.
    let one = EditOptions { max_iterations: 1, solver: SolverKind::Pcg, ..options() };
    let mut strict = Editor::from_bake(&baked.objects[0], &[sun(0.0)], &one).unwrap();
    let radiance = strict.user_radiance().unwrap();
    assert!(relative_difference(&radiance, &baked.objects[0].radiance) < 1e-12);
    let triple = MediumEdit { region: Region::All, op: MediumOp::Scale { sigma_a: [3.0; 3], sigma_s: [1.0; 3] } };
    let e = strict.edit_medium(&triple);
    assert!(matches!(e, Err(EditError::Diffusion(_))), "{e:?}");
    assert_eq!(strict.user_radiance().unwrap(), radiance);
    assert_eq!(strict.pieces()[0].system().media()[0], marble());
    assert_eq!(ed.user_radiance().unwrap(), before);
    assert_eq!(ed.media(), &media);
    assert_eq!(ed.lights(), &[sun(0.0)]);
    assert_eq!(ed.pieces()[0].transform(), DMat4::IDENTITY);
}

#[test]
fn updates_on_the_gpu_path_match_the_cpu() {
    // Backend::Auto with PCG solves on a hardware GPU when there is one (else on the CPU, and
    // this compares the CPU with itself).
    let mesh = ball();
    let object = Object::from_tets("ball", mesh.clone(), marble().into(), 1.0);
    let run = |backend| {
        let o = EditOptions { tolerance: 1e-8, backend: Some(backend), ..options() };
        let mut ed = Editor::new(&object, &[sun(0.0)], &o).unwrap();
        ed.relight(&[sun(5.0)]).unwrap();
        // Red, and still resolved by the mesh at the surface (σtr·h under the bound).
        let red = Medium { sigma_a: [0.001, 0.05, 0.08], ..marble() };
        ed.paint(&PaintStroke { points: vec![DVec3::new(10.0, 0.0, 0.0)], radius: 2.0, medium: red, strength: 1.0 }).unwrap();
        ed.user_radiance().unwrap()
    };
    let diff = relative_difference(&run(Backend::Auto), &run(Backend::Cpu));
    eprintln!("auto vs cpu: relative difference {diff:.2e}");
    assert!(diff < 1e-5, "{diff}");
}

/// Radiance per vertex keyed by the vertex's exact position.
fn by_position(mesh: &TetMesh, values: &[[f64; 3]]) -> std::collections::HashMap<[u64; 3], [f64; 3]> {
    mesh.positions().iter().zip(values).map(|(p, v)| (p.to_array().map(f64::to_bits), *v)).collect()
}

#[test]
fn a_plane_cut_equals_a_fresh_solve_on_the_cut_mesh() {
    let mesh = ball();
    let lights = [sun(20.0)];
    let mut ed = editor(&mesh, marble().into(), &lights);
    let plane = Cutter::Plane { point: DVec3::new(0.0, 0.0, 3.0), normal: DVec3::new(0.2, 0.0, 1.0) };
    let stats = ed.cut(&plane).unwrap();
    let cut = stats.cut.clone().unwrap();
    eprintln!("cut: {stats:?}");
    assert_eq!(ed.pieces().len(), 1);
    let piece = &ed.pieces()[0];
    assert_eq!(cut.removed_tets, mesh.tet_count() - piece.mesh().tet_count());
    assert!(cut.removed_tets > mesh.tet_count() / 10, "{cut:?}");
    assert!(ed.user_radiance().is_none());
    // Every kept tet keeps its original id, and nothing above the plane is left.
    assert_eq!(piece.original_tets().len(), piece.mesh().tet_count());
    let normal = DVec3::new(0.2, 0.0, 1.0).normalize();
    let above = piece.mesh().positions().iter().map(|p| (*p - DVec3::new(0.0, 0.0, 3.0)).dot(normal)).fold(f64::MIN, f64::max);
    assert!(above <= cut.max_cut_distance + 1e-12, "{above} vs {}", cut.max_cut_distance);
    let (reference, _) = fresh(piece.mesh(), marble().into(), &lights);
    let diff = relative_difference(piece.radiance(), &reference);
    eprintln!("cut: relative difference {diff:.2e}");
    assert!(diff < 1e-6, "{diff}");
    // Paint still reaches the original tets, including removed ones.
    let removed = (0..mesh.tet_count() as u32).find(|t| !piece.original_tets().contains(t)).unwrap();
    let c = mesh.tet_positions(removed as usize).iter().sum::<DVec3>() / 4.0;
    let stroke = PaintStroke { points: vec![c], radius: 0.01, medium: Medium { sigma_a: [0.5; 3], ..marble() }, strength: 1.0 };
    let s = ed.paint(&stroke).unwrap();
    assert_eq!((s.tets_changed, s.rows_rebuilt, s.pieces_solved), (1, 0, 0));
    assert_eq!(ed.media().coefficients()[removed as usize].sigma_a, [0.5; 3]);
}

#[test]
fn split_move_apart_move_back_and_recombine_give_the_uncut_solution() {
    let mesh = ball();
    let lights = [sun(40.0)];
    let mut ed = editor(&mesh, marble().into(), &lights);
    let uncut = by_position(&mesh, ed.pieces()[0].radiance());
    let plane = Cutter::Plane { point: DVec3::ZERO, normal: DVec3::new(1.0, 0.3, 0.0) };
    ed.split(&plane).unwrap();
    assert_eq!(ed.pieces().len(), 2);
    let tets: usize = ed.pieces().iter().map(|p| p.mesh().tet_count()).sum();
    assert_eq!(tets, mesh.tet_count());
    // Two halves, each solved with its own boundary: the cut faces now take light in.
    let away = DMat4::from_rotation_translation(glam::DQuat::from_rotation_z(0.3), DVec3::new(30.0, 0.0, 0.0));
    let moved = ed.set_piece_transform(1, away).unwrap();
    assert_eq!(moved.pieces_solved, 2);
    assert_eq!(ed.pieces()[1].transform(), away);
    // Nothing touches while apart.
    assert_eq!(ed.recombine().unwrap().pieces_solved, 0);
    assert_eq!(ed.pieces().len(), 2);
    ed.set_piece_transform(1, DMat4::IDENTITY).unwrap();
    ed.recombine().unwrap();
    assert_eq!(ed.pieces().len(), 1);
    let p = &ed.pieces()[0];
    assert_eq!((p.mesh().tet_count(), p.mesh().vertex_count()), (mesh.tet_count(), mesh.vertex_count()));
    let back = by_position(p.mesh(), p.radiance());
    let scale = uncut.values().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let worst = uncut.iter().map(|(k, a)| (0..3).map(|c| (a[c] - back[k][c]).abs()).fold(0.0, f64::max)).fold(0.0, f64::max);
    eprintln!("recombined: max difference {:.2e} of {scale:.3}", worst / scale);
    assert!(worst < 1e-6 * scale, "{worst}");
}

#[test]
fn fracture_of_two_disjoint_balls_gives_two_pieces_each_equal_to_the_ball_alone() {
    let a = ball();
    let offset = DVec3::new(30.0, 0.0, 0.0);
    let b = a.clone().map_positions(move |p| p + offset).unwrap();
    let n = a.vertex_count() as u32;
    let positions: Vec<DVec3> = a.positions().iter().chain(b.positions()).copied().collect();
    let tets: Vec<[u32; 4]> = a.tets().iter().copied().chain(b.tets().iter().map(|t| t.map(|v| v + n))).collect();
    let both = TetMesh::new(positions, tets, vec![]).unwrap();
    let lights = [sun(15.0)];
    let mut ed = editor(&both, marble().into(), &lights);
    let stats = ed.fracture().unwrap();
    assert_eq!(ed.pieces().len(), 2);
    assert_eq!(stats.pieces_solved, 2);
    for (piece, alone) in ed.pieces().iter().zip([&a, &b]) {
        assert_eq!(piece.mesh().positions(), alone.positions());
        let (reference, _) = fresh(alone, marble().into(), &lights);
        let diff = relative_difference(piece.radiance(), &reference);
        assert!(diff < 1e-6, "{diff}");
    }
    // A second fracture finds nothing to split.
    assert_eq!(ed.fracture().unwrap().tets_changed, 0);
    // A cut that removes the second ball entirely leaves the first as it was.
    let first = ed.pieces()[0].radiance().to_vec();
    let s = ed.cut(&Cutter::Plane { point: DVec3::new(15.0, 0.0, 0.0), normal: DVec3::X }).unwrap();
    assert_eq!(ed.pieces().len(), 1);
    assert_eq!(s.cut.unwrap().removed_tets, b.tet_count());
    assert_eq!(ed.pieces()[0].mesh().positions(), a.positions());
    assert!(relative_difference(ed.pieces()[0].radiance(), &first) < 1e-9);
}

#[test]
fn failed_topology_edits_return_the_named_error_and_change_nothing() {
    let mesh = ball();
    let mut ed = editor(&mesh, marble().into(), &[sun(0.0)]);
    let before = ed.pieces()[0].radiance().to_vec();
    let e = ed.set_piece_transform(3, DMat4::IDENTITY).unwrap_err();
    assert!(matches!(e, EditError::NoSuchPiece { index: 3, count: 1 }), "{e}");
    let e = ed.set_piece_transform(0, DMat4::from_scale(DVec3::splat(2.0))).unwrap_err();
    assert!(matches!(e, EditError::NotRigid(_)), "{e}");
    let e = ed.cut(&Cutter::Plane { point: DVec3::ZERO, normal: DVec3::ZERO }).unwrap_err();
    assert!(matches!(e, EditError::InvalidCutter(_)), "{e}");
    // Everything removed: an error, not an empty editor.
    let e = ed.cut(&Cutter::Plane { point: DVec3::new(0.0, 0.0, -20.0), normal: DVec3::Z }).unwrap_err();
    assert!(matches!(e, EditError::NothingLeft { .. }), "{e}");
    assert_eq!(ed.pieces().len(), 1);
    assert_eq!(ed.pieces()[0].mesh().tet_count(), mesh.tet_count());
    assert_eq!(ed.pieces()[0].radiance(), &before[..]);
    assert!(ed.user_radiance().is_some());
}

/// Everything a failed update must leave as it was, bit for bit: per piece φ, radiance, q, b,
/// the matrix values and its media table; and the editor's per-tet media and lights.
fn snapshot(ed: &Editor) -> (Vec<Vec<[f64; 3]>>, PerTetMedia, Vec<Light>) {
    let mut arrays = Vec::new();
    for p in ed.pieces() {
        let s = p.system();
        arrays.extend([p.fluence(), p.radiance(), s.source(), s.rhs(), s.matrix().values()].map(<[[f64; 3]]>::to_vec));
        arrays.push(s.media().iter().flat_map(|m| [m.sigma_a, m.sigma_s_prime, [m.eta, m.g, 0.0]]).collect());
    }
    (arrays, ed.media().clone(), ed.lights().to_vec())
}

#[test]
fn a_failed_relight_or_paint_leaves_every_array_bit_identical() {
    let mesh = ball();
    let object = Object::from_tets("ball", mesh.clone(), marble().into(), 1.0);
    let baked = bake(&Scene { objects: vec![object], lights: vec![sun(0.0)] }, &bake_options()).unwrap();
    // One iteration: enough for the bake's own lights (already solved), not for a change.
    let one = EditOptions { max_iterations: 1, ..options() };
    let mut ed = Editor::from_bake(&baked.objects[0], &[sun(0.0)], &one).unwrap();
    let before = snapshot(&ed);
    let e = ed.relight(&[sun(30.0)]);
    assert!(matches!(e, Err(EditError::Diffusion(_))), "{e:?}");
    assert!(snapshot(&ed) == before, "a failed relight changed the editor");
    // Red, and resolved by the mesh at the surface: the paint fails by the iteration limit.
    let red = Medium { sigma_a: [0.001, 0.05, 0.1], sigma_s_prime: [3.0, 1.0, 1.0], ..marble() };
    let stroke = PaintStroke {
        points: vec![DVec3::new(10.0, 0.0, 0.0), DVec3::new(0.0, 10.0, 0.0)],
        radius: 2.0,
        medium: red,
        strength: 1.0,
    };
    let e = ed.paint(&stroke);
    assert!(matches!(e, Err(EditError::Diffusion(_))), "{e:?}");
    assert!(snapshot(&ed) == before, "a failed paint changed the editor");
    // And the editor still works from that state: the original lights need no iteration.
    let stats = ed.relight(&[sun(0.0)]).unwrap();
    assert_eq!(stats.iterations, [0; 3]);
    assert!(snapshot(&ed) == before);
}

/// The names of the arrays [`snapshot`] takes per piece, in its order.
const SNAPSHOT_ARRAYS: [&str; 6] = ["fluence", "radiance", "source q", "rhs b", "matrix values", "media table"];

#[test]
fn undo_relight_restores_every_array_and_the_next_relight_is_as_if_never_relit() {
    let mut ed = editor(&ball(), marble().into(), &[sun(0.0)]);
    ed.split(&Cutter::Plane { point: DVec3::ZERO, normal: DVec3::X }).unwrap();
    assert_eq!(ed.pieces().len(), 2);
    let never_relit = ed.clone();
    let before = snapshot(&ed);
    let (stats, undo) = ed.relight_with_undo(&[sun(30.0)], Progress::none()).unwrap();
    assert_eq!(stats.pieces_solved, 2);
    let relit = snapshot(&ed);
    assert_eq!(relit.2, [sun(30.0)]);
    for (k, (a, b)) in relit.0.iter().zip(&before.0).enumerate() {
        // q, b, φ and radiance change with the light; the matrix and media do not.
        assert_eq!(a == b, k % 6 >= 4, "piece {} {} after the relight", k / 6, SNAPSHOT_ARRAYS[k % 6]);
    }
    ed.undo_relight(undo).unwrap();
    let undone = snapshot(&ed);
    assert_eq!(undone.0.len(), before.0.len());
    for (k, (a, b)) in undone.0.iter().zip(&before.0).enumerate() {
        assert!(a == b, "piece {} {} differs after undo_relight", k / 6, SNAPSHOT_ARRAYS[k % 6]);
    }
    assert!(undone.1 == before.1, "media");
    assert_eq!(undone.2, [sun(0.0)]);
    // Relighting from there is exactly a relight of the editor that never relit (same warm start).
    let mut reference = never_relit;
    let (a, b) = (ed.relight(&[sun(10.0)]).unwrap(), reference.relight(&[sun(10.0)]).unwrap());
    assert_eq!(a.iterations, b.iterations);
    assert!(a.iterations.iter().all(|&i| i > 0));
    assert!(snapshot(&ed) == snapshot(&reference), "a relight after an undone one differs");
    // An undo does not fit an editor whose pieces changed since the relight.
    let (_, undo) = ed.relight_with_undo(&[sun(20.0)], Progress::none()).unwrap();
    ed.recombine().unwrap();
    let recombined = snapshot(&ed);
    assert!(ed.undo_relight(undo).is_err(), "undo_relight accepted an undo of other pieces");
    assert!(snapshot(&ed) == recombined, "a refused undo changed the editor");
}

fn shadowed() -> EditOptions {
    EditOptions { shadows: true, ..options() }
}

/// A ball at the origin and a second one `offset` away, as one tet mesh (ids of the first
/// ball's vertices first).
fn two_balls(offset: DVec3) -> (TetMesh, TetMesh) {
    let a = ball();
    let b = a.clone().map_positions(move |p| p + offset).unwrap();
    let n = a.vertex_count() as u32;
    let positions: Vec<DVec3> = a.positions().iter().chain(b.positions()).copied().collect();
    let tets: Vec<[u32; 4]> = a.tets().iter().copied().chain(b.tets().iter().map(|t| t.map(|v| v + n))).collect();
    (TetMesh::new(positions, tets, vec![]).unwrap(), a)
}

/// q at the vertex of piece `piece` farthest along +x (facing the sun of [`from_plus_x`]).
fn q_at_plus_x(ed: &Editor, piece: usize) -> [f64; 3] {
    let p = &ed.pieces()[piece];
    let ids = &p.system().boundary().ids;
    let k = (0..ids.len()).max_by(|&i, &j| {
        let x = |k: usize| p.mesh().positions()[ids[k] as usize].x;
        x(i).total_cmp(&x(j))
    });
    p.system().source()[k.unwrap()]
}

/// A sun shining along −x (light arriving from +x).
fn from_plus_x() -> Light {
    Light::Directional { direction: -DVec3::X, irradiance: [2.0, 1.5, 1.0], angular_diameter_deg: 0.0 }
}

#[test]
fn relight_with_the_cached_occluder_equals_a_fresh_start_bit_for_bit() {
    // Two balls side by side along x: with the sun low over x, the second shadows the first.
    let (both, _) = two_balls(DVec3::new(25.0, 0.0, 4.0));
    let object = Object::from_tets("two", both, marble().into(), 1.0);
    let low = |deg: f64| Light::Directional {
        direction: DMat3::from_rotation_y(deg.to_radians()) * -DVec3::X,
        irradiance: [2.0, 1.5, 1.0],
        angular_diameter_deg: 0.0,
    };
    let mut ed = Editor::new(&object, &[low(0.0)], &shadowed()).unwrap();
    for deg in [10.0, 25.0] {
        ed.relight(&[low(deg)]).unwrap();
        let fresh = Editor::new(&object, &[low(deg)], &shadowed()).unwrap();
        let (a, b) = (ed.pieces()[0].system(), fresh.pieces()[0].system());
        assert_eq!(a.source(), b.source(), "q after relighting to {deg}°");
        assert_eq!(a.rhs(), b.rhs());
        // Some boundary points are in the other ball's shadow, so the occluder matters.
        let unshadowed = Editor::new(&object, &[low(deg)], &options()).unwrap();
        let lit = unshadowed.pieces()[0].system().source();
        let in_shadow = a.source().iter().zip(lit).filter(|(s, l)| s[0] == 0.0 && l[0] > 0.0).count();
        assert!(in_shadow > 10, "{in_shadow}");
    }
}

#[test]
fn the_occluder_follows_moves_and_cuts() {
    // The second ball starts 60 above the first, then moves to +x of it, into the sun.
    let (both, _) = two_balls(DVec3::new(0.0, 60.0, 0.0));
    let mut ed = Editor::new(&Object::from_tets("two", both, marble().into(), 1.0), &[from_plus_x()], &shadowed()).unwrap();
    ed.fracture().unwrap();
    assert_eq!(ed.pieces().len(), 2);
    assert!(q_at_plus_x(&ed, 0)[0] > 0.0, "lit while the other ball is away");
    ed.set_piece_transform(1, DMat4::from_translation(DVec3::new(25.0, -60.0, 0.0))).unwrap();
    assert_eq!(q_at_plus_x(&ed, 0), [0.0; 3], "in the moved ball's shadow");
    ed.relight(&[from_plus_x()]).unwrap();
    assert_eq!(q_at_plus_x(&ed, 0), [0.0; 3], "relight keeps the moved ball's shadow");
    // Cutting the shadowing ball away lights the vertex again (also after a relight).
    ed.cut(&Cutter::Plane { point: DVec3::new(15.0, 0.0, 0.0), normal: DVec3::X }).unwrap();
    assert_eq!(ed.pieces().len(), 1);
    assert!(q_at_plus_x(&ed, 0)[0] > 0.0, "lit once the shadowing ball is cut away");
    ed.relight(&[from_plus_x()]).unwrap();
    assert!(q_at_plus_x(&ed, 0)[0] > 0.0);
}
