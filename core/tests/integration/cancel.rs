//! Cancellation at every instant of a bake, of a relight and of the session's edits (medium
//! edit, paint, cut, fracture): a progress callback that asks to stop at its k-th call, for
//! calls spread over every stage (meshing, assembly, light, solve, cut…), gets `Cancelled` back
//! and nothing else; a cancelled edit leaves the session bit for bit as it was, and the same
//! edit run afterwards gives what it gives in a session that was never cancelled. Prints the worst time from the cancel to the return
//! per stage (a measurement for the record, not an assertion: speed is never a unit test).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;
use transcut::edit::{Cutter, MediumEdit, MediumOp, PaintStroke, Region};
use transcut::gpu::Backend;
use transcut::light::{Light, SourceOptions};
use transcut::optics::Medium;
use transcut::{bake_with, BakeOptions, Object, Progress, Scene, SceneError, Session, SessionError, TransCutOptions};

use crate::common;
use common::uv_sphere;

/// A marble ball under a disc light and a soft sun, with shadows: every stage has work, the
/// light stage thousands of samples per point.
fn scene() -> (Scene, BakeOptions) {
    let ball = Object::new("ball", uv_sphere(10.0, 32, 16), Medium::preset("marble").unwrap(), 1.0);
    let disc = Light::DiscArea {
        center: DVec3::new(0.0, 0.0, 30.0),
        normal: -DVec3::Z,
        radius: 5.0,
        radiance: [2.0; 3],
        two_sided: false,
    };
    let sun = Light::Directional { direction: DVec3::new(0.3, 0.0, -1.0), irradiance: [1.0; 3], angular_diameter_deg: 2.0 };
    let options = BakeOptions {
        source: SourceOptions { area_samples: 2048, ..SourceOptions::default() },
        ..BakeOptions::with_method(TransCutOptions { tets: 6_000, backend: Some(Backend::Cpu), ..TransCutOptions::default() })
    };
    (Scene { objects: vec![ball], lights: vec![disc, sun] }, options)
}

/// The stage of a report, without the object's name.
fn stage_of(s: &str) -> String {
    s.rsplit(": ").next().unwrap_or(s).to_owned()
}

#[test]
fn a_bake_cancelled_at_any_report_returns_cancelled() {
    let (scene, options) = scene();
    let reports = Mutex::new(Vec::new());
    let record = |s: &str, f: f64| {
        reports.lock().unwrap().push((stage_of(s), f));
        true
    };
    let full = bake_with(&scene, &options, Progress::new(&record)).unwrap();
    assert_eq!(full.objects.len(), 1);
    let reports = reports.into_inner().unwrap();
    let n = reports.len();
    let stages: Vec<&str> = reports.iter().map(|(s, _)| s.as_str()).collect();
    for stage in ["winding numbers", "assembly", "light", "solve"] {
        assert!(stages.contains(&stage), "no {stage} report in {stages:?}");
    }
    assert!(stages.iter().filter(|s| **s == "light").count() >= 2, "the light stage reports while it works: {stages:?}");
    // Instants named by stage and the report's rank within it (the light stage reports by time,
    // so a global report index would land in another stage on another run): every stage's
    // first and last report, and 24 more spread over the whole bake.
    let rank = |k: usize| (stages[k].to_owned(), stages[..k].iter().filter(|s| **s == stages[k]).count());
    let mut picks: Vec<usize> = (0..24).map(|i| i * n / 24).collect();
    for (i, w) in stages.windows(2).enumerate() {
        if w[0] != w[1] {
            picks.extend([i, i + 1]);
        }
    }
    picks.sort_unstable();
    picks.dedup();
    let picks: Vec<(String, usize)> = picks.into_iter().map(rank).collect();
    let mut worst: BTreeMap<String, f64> = BTreeMap::new();
    for (target, nth) in &picks {
        let seen = AtomicUsize::new(0);
        let cancelled_at = Mutex::new(None);
        let cancel = |s: &str, _: f64| {
            let mut at = cancelled_at.lock().unwrap();
            if at.is_some() {
                return false;
            }
            let stage = stage_of(s);
            if stage == *target && seen.fetch_add(1, Ordering::SeqCst) == *nth {
                *at = Some((stage, Instant::now()));
                return false;
            }
            true
        };
        let result = bake_with(&scene, &options, Progress::new(&cancel));
        let returned = Instant::now();
        // The light stage reports by time, so a run may make fewer reports than the first did:
        // then the callback never asked to stop and the bake finished.
        let Some((stage, at)) = cancelled_at.into_inner().unwrap() else {
            assert!(result.is_ok(), "no cancel asked, yet: {:?}", result.map(|_| ()));
            continue;
        };
        assert!(
            matches!(result, Err(SceneError::Cancelled(_))),
            "cancel at report {nth} of {target} ({n} reports in all, cancelled in {stage}): {:?}",
            result.map(|_| ())
        );
        let ms = returned.duration_since(at).as_secs_f64() * 1e3;
        let w = worst.entry(stage).or_insert(0.0);
        *w = w.max(ms);
    }
    for stage in ["winding numbers", "assembly", "light", "solve"] {
        assert!(worst.contains_key(stage), "never cancelled in {stage}: {worst:?}");
    }
    for (stage, ms) in &worst {
        eprintln!("cancel → return, worst over {} instants: {stage}: {ms:.2} ms", picks.len());
    }
}

#[test]
fn a_relight_cancelled_at_any_report_changes_nothing() {
    let (scene, options) = scene();
    let mut session = Session::bake(&scene, &options, Progress::none()).unwrap();
    let before = session.radiance(0).unwrap();
    let lights = vec![Light::Directional { direction: -DVec3::Z, irradiance: [3.0; 3], angular_diameter_deg: 0.0 }];
    for k in 0..2 {
        let calls = AtomicUsize::new(0);
        let cancel = |_: &str, _: f64| calls.fetch_add(1, Ordering::SeqCst) < k;
        let result = session.relight(&lights, Progress::new(&cancel));
        assert!(matches!(result, Err(SessionError::Cancelled(_))), "cancel at report {k}: {:?}", result.map(|_| ()));
        assert_eq!(session.radiance(0).unwrap(), before, "a cancelled relight keeps the results");
        assert_eq!(session.lights(), scene.lights.as_slice());
    }
    session.relight(&lights, Progress::none()).unwrap();
    assert_ne!(session.radiance(0).unwrap(), before);
}

/// A smaller marble ball under the same lights, for the edits (each is run many times).
fn edit_scene() -> (Scene, BakeOptions) {
    let (mut scene, mut options) = scene();
    scene.objects[0] = Object::new("ball", uv_sphere(10.0, 24, 12), Medium::preset("marble").unwrap(), 1.0);
    options.source.area_samples = 512;
    if let transcut::Method::TransCut(t) = &mut options.method {
        t.tets = 3_000;
    }
    (scene, options)
}

/// A piece's radiance, fluence and transform.
type PieceState = (Vec<[f64; 3]>, Vec<[f64; 3]>, glam::DMat4);

/// What a session holds for its one object, bit for bit: its radiance, and per piece its
/// radiance, fluence and transform; and the session's lights.
#[derive(Debug, PartialEq)]
struct Snapshot {
    radiance: Option<Vec<[f64; 3]>>,
    pieces: Option<Vec<PieceState>>,
    lights: Vec<Light>,
}

fn snapshot(session: &Session) -> Snapshot {
    Snapshot {
        radiance: session.radiance(0).unwrap(),
        pieces: session
            .editor(0)
            .unwrap()
            .map(|e| e.pieces().iter().map(|p| (p.radiance().to_vec(), p.fluence().to_vec(), p.transform())).collect()),
        lights: session.lights().to_vec(),
    }
}

/// An edit of object 0 of a session.
type Edit<'a> = dyn Fn(&mut Session, Progress) -> Result<(), SessionError> + 'a;

/// The report indices to cancel at: the first and last report of every run of one stage, and
/// `spread` more over the whole call.
fn picks(stages: &[String], spread: usize) -> Vec<usize> {
    let n = stages.len();
    let mut picks: Vec<usize> = (0..spread).map(|i| i * n / spread).collect();
    picks.extend([0, n - 1]);
    for (i, w) in stages.windows(2).enumerate() {
        if w[0] != w[1] {
            picks.extend([i, i + 1]);
        }
    }
    picks.sort_unstable();
    picks.dedup();
    picks
}

#[test]
fn picks_cover_both_ends_of_every_stage() {
    let stages: Vec<String> = ["a", "a", "a", "b", "c", "c"].iter().map(|s| (*s).to_owned()).collect();
    assert_eq!(picks(&stages, 2), vec![0, 2, 3, 4, 5]);
}

/// Runs `edit` on a session made by `prepare` (from a fresh bake) once with every report
/// recorded, then cancels a second such session at reports spread over every stage (the n-th
/// report of a stage): each
/// cancel returns `Cancelled` and leaves the session as it was; the edit then run to the end
/// gives bit for bit the first run's result. Returns the worst cancel → return time per stage.
fn cancel_everywhere(what: &str, prepare: &dyn Fn(&mut Session), edit: &Edit<'_>, stages: &[&str]) -> BTreeMap<String, f64> {
    let (scene, options) = edit_scene();
    let fresh = || {
        let mut s = Session::bake(&scene, &options, Progress::none()).unwrap();
        prepare(&mut s);
        s
    };
    let mut reference = fresh();
    let reports = Mutex::new(Vec::new());
    let record = |s: &str, f: f64| {
        assert!(s.starts_with("ball: ") || s.starts_with("relight"), "{what}: stage {s:?} does not name the object");
        reports.lock().unwrap().push((stage_of(s), f));
        true
    };
    edit(&mut reference, Progress::new(&record)).unwrap();
    let expected = snapshot(&reference);
    let reports = reports.into_inner().unwrap();
    let names: Vec<String> = reports.iter().map(|(s, _)| s.clone()).collect();
    for stage in stages {
        assert!(names.iter().any(|s| s == stage), "{what}: no {stage} report in {names:?}");
    }
    assert!(reports.windows(2).all(|w| w[1].1 >= w[0].1), "{what}: the fraction went back: {reports:?}");

    let mut session = fresh();
    let before = snapshot(&session);
    let mut worst: BTreeMap<String, f64> = BTreeMap::new();
    // By stage and occurrence within it, not by index: the light stage reports by time, so the
    // number of its reports differs from run to run.
    let targets: Vec<(String, usize)> = picks(&names, 10)
        .into_iter()
        .map(|k| (names[k].clone(), names[..k].iter().filter(|s| **s == names[k]).count()))
        .collect();
    for (target, occurrence) in &targets {
        let seen = Mutex::new(BTreeMap::<String, usize>::new());
        let cancelled_at = Mutex::new(None);
        let cancel = |s: &str, _: f64| {
            let stage = stage_of(s);
            let mut at = cancelled_at.lock().unwrap();
            if at.is_some() {
                return false;
            }
            let mut seen = seen.lock().unwrap();
            let n = seen.entry(stage.clone()).or_insert(0);
            *n += 1;
            if stage == *target && *n > *occurrence {
                *at = Some((stage, Instant::now()));
                false
            } else {
                true
            }
        };
        let result = edit(&mut session, Progress::new(&cancel));
        let returned = Instant::now();
        let Some((stage, at)) = cancelled_at.into_inner().unwrap() else {
            // The light stage reports by time: this run made fewer reports than the first.
            assert!(result.is_ok(), "{what}: no cancel asked, yet: {result:?}");
            session = fresh();
            continue;
        };
        assert!(matches!(result, Err(SessionError::Cancelled(_))), "{what}: cancel at {stage} #{occurrence}: {result:?}");
        assert!(snapshot(&session) == before, "{what}: the cancel at {stage} #{occurrence} changed the session");
        let ms = returned.duration_since(at).as_secs_f64() * 1e3;
        let w = worst.entry(stage).or_insert(0.0);
        *w = w.max(ms);
    }
    for stage in stages {
        assert!(worst.contains_key(*stage), "{what}: never cancelled in {stage}: {worst:?}");
    }
    edit(&mut session, Progress::none()).unwrap();
    assert!(snapshot(&session) == expected, "{what}: the edit after the cancels differs from one never cancelled");
    for (stage, ms) in &worst {
        eprintln!("{what}: cancel → return, worst over {} instants: {stage}: {ms:.2} ms", targets.len());
    }
    worst
}

/// Makes the object's live state, so that an edit is measured on its own.
fn start(session: &mut Session) {
    session.start(0, Progress::none()).unwrap();
}

#[test]
fn a_relight_inside_an_object_cancelled_anywhere_changes_nothing() {
    let lights =
        vec![Light::Directional { direction: DVec3::new(0.2, 0.1, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 1.0 }];
    let relight = |s: &mut Session, p: Progress| s.relight(&lights, p).map(|_| ());
    cancel_everywhere("relight", &start, &relight, &["relight", "light", "solve"]);
}

#[test]
fn the_first_update_cancelled_anywhere_keeps_the_bake() {
    let lights =
        vec![Light::Directional { direction: DVec3::new(0.2, 0.1, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 1.0 }];
    let relight = |s: &mut Session, p: Progress| s.relight(&lights, p).map(|_| ());
    cancel_everywhere("relight of a bake", &|_| {}, &relight, &["relight", "assembly", "hierarchy", "light", "solve"]);
}

#[test]
fn a_medium_edit_cancelled_anywhere_changes_nothing() {
    let edit = MediumEdit {
        region: Region::Sphere { center: DVec3::new(0.0, 0.0, 8.0), radius: 4.0 },
        op: MediumOp::Scale { sigma_a: [3.0, 2.0, 1.5], sigma_s: [0.5; 3] },
    };
    let op = |s: &mut Session, p: Progress| s.edit_medium(0, &edit, p).map(|_| ());
    cancel_everywhere("edit_medium", &start, &op, &["select", "assembly", "solve"]);
}

#[test]
fn a_paint_cancelled_anywhere_changes_nothing() {
    let stroke = PaintStroke {
        points: vec![DVec3::new(-5.0, 0.0, 8.0), DVec3::new(5.0, 0.0, 8.0)],
        radius: 2.0,
        medium: Medium { sigma_a: [0.2, 0.05, 0.01], ..Medium::preset("marble").unwrap() },
        strength: 0.8,
    };
    let op = |s: &mut Session, p: Progress| s.paint(0, &stroke, p).map(|_| ());
    cancel_everywhere("paint", &start, &op, &["select", "assembly", "solve"]);
}

#[test]
fn a_cut_cancelled_anywhere_changes_nothing() {
    let cutter = Cutter::Plane { point: DVec3::new(0.0, 0.0, 3.0), normal: DVec3::new(0.3, 0.0, 1.0).normalize() };
    let op = |s: &mut Session, p: Progress| s.cut(0, &cutter, p).map(|_| ());
    cancel_everywhere("cut", &start, &op, &["cut", "assembly", "hierarchy", "occluder", "light", "solve"]);
}

#[test]
fn a_fracture_cancelled_anywhere_changes_nothing() {
    // Split first, so that the fracture has work: split pieces are connected, but the session
    // relights and re-solves them all.
    let split = |s: &mut Session| {
        s.split(0, &Cutter::Plane { point: DVec3::ZERO, normal: DVec3::X }, Progress::none()).unwrap();
    };
    let op = |s: &mut Session, p: Progress| s.fracture(0, p).map(|_| ());
    cancel_everywhere("fracture", &split, &op, &["components", "occluder", "light", "solve"]);
}

/// Splits the ball at x = 0 into two pieces that still touch.
fn split_in_two(s: &mut Session) {
    s.split(0, &Cutter::Plane { point: DVec3::ZERO, normal: DVec3::X }, Progress::none()).unwrap();
    assert_eq!(s.editor(0).unwrap().unwrap().pieces().len(), 2);
}

#[test]
fn a_split_cancelled_anywhere_changes_nothing() {
    let cutter = Cutter::Plane { point: DVec3::new(0.0, 0.0, 2.0), normal: DVec3::new(0.2, 0.1, 1.0).normalize() };
    let op = |s: &mut Session, p: Progress| s.split(0, &cutter, p).map(|_| ());
    cancel_everywhere("split", &start, &op, &["split", "assembly", "hierarchy", "occluder", "light", "solve"]);
}

#[test]
fn a_piece_move_cancelled_anywhere_changes_nothing() {
    // The cancelled move must leave the piece where it was: its transform is in the snapshot.
    let moved = glam::DMat4::from_rotation_z(0.3) * glam::DMat4::from_translation(DVec3::new(4.0, 0.0, 1.0));
    let op = |s: &mut Session, p: Progress| s.set_piece_transform(0, 1, moved, p).map(|_| ());
    cancel_everywhere("set_piece_transform", &split_in_two, &op, &["occluder", "light", "solve"]);
}

#[test]
fn a_recombine_cancelled_anywhere_changes_nothing() {
    let op = |s: &mut Session, p: Progress| {
        s.recombine(0, p)?;
        assert_eq!(s.editor(0).unwrap().unwrap().pieces().len(), 1, "the two halves weld back into one");
        Ok(())
    };
    cancel_everywhere("recombine", &split_in_two, &op, &["weld", "assembly", "hierarchy", "occluder", "light", "solve"]);
}

/// The longest time between two reports of one call, per pair of stages (the report that
/// starts the gap → the one that ends it, or the return): a cancel asked at any moment is seen
/// within the gap. Measured, not asserted (docs/benchmarks.md, "Cancel latency"): a ball of about
/// `TRANSCUT_GAP_TETS` tets (default 200 000), baked, then a cut, a medium edit and a relight.
#[test]
#[ignore = "measurement: minutes at 200k tets"]
fn slow_report_gaps_of_large_edits() {
    let tets: usize = std::env::var("TRANSCUT_GAP_TETS").ok().and_then(|s| s.parse().ok()).unwrap_or(200_000);
    let (mut scene, mut options) = scene();
    scene.objects[0] = Object::new("ball", uv_sphere(10.0, 128, 64), Medium::preset("marble").unwrap(), 1.0);
    if let transcut::Method::TransCut(t) = &mut options.method {
        t.tets = tets;
    }
    let mut session = Session::bake(&scene, &options, Progress::none()).unwrap();
    let measure = |what: &str, session: &mut Session, edit: &Edit<'_>| {
        let reports = Mutex::new(vec![("start".to_owned(), Instant::now())]);
        let record = |s: &str, _: f64| {
            reports.lock().unwrap().push((stage_of(s), Instant::now()));
            true
        };
        edit(session, Progress::new(&record)).unwrap();
        let mut reports = reports.into_inner().unwrap();
        reports.push(("return".to_owned(), Instant::now()));
        let mut gaps: BTreeMap<String, f64> = BTreeMap::new();
        for w in reports.windows(2) {
            let ms = w[1].1.duration_since(w[0].1).as_secs_f64() * 1e3;
            let g = gaps.entry(format!("{} → {}", w[0].0, w[1].0)).or_insert(0.0);
            *g = g.max(ms);
        }
        let total = reports[reports.len() - 1].1.duration_since(reports[0].1).as_secs_f64() * 1e3;
        eprintln!("{what} ({} reports, {total:.0} ms): longest gap between reports of the stages, ms: {gaps:.1?}", reports.len());
    };
    measure("start", &mut session, &|s, p| s.start(0, p));
    let mesh = session.editor(0).unwrap().unwrap().pieces()[0].mesh();
    eprintln!("the ball: {} tets, {} vertices", mesh.tet_count(), mesh.vertex_count());
    let lights =
        vec![Light::Directional { direction: DVec3::new(0.2, 0.1, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 1.0 }];
    measure("relight", &mut session, &|s, p| s.relight(&lights, p).map(|_| ()));
    let edit = MediumEdit {
        region: Region::Sphere { center: DVec3::new(0.0, 0.0, 8.0), radius: 4.0 },
        op: MediumOp::Scale { sigma_a: [2.0, 1.5, 1.2], sigma_s: [1.0; 3] },
    };
    measure("edit_medium", &mut session, &|s, p| s.edit_medium(0, &edit, p).map(|_| ()));
    let cutter = Cutter::Plane { point: DVec3::new(0.0, 0.0, 3.0), normal: DVec3::new(0.3, 0.0, 1.0).normalize() };
    measure("cut", &mut session, &|s, p| s.cut(0, &cutter, p).map(|_| ()));
}

/// Calls of a `keep_going` that says stop at its `stop_at`-th call (never when 0), counted.
struct StopAt {
    calls: AtomicUsize,
    stop_at: usize,
}

impl StopAt {
    fn new(stop_at: usize) -> Self {
        Self { calls: AtomicUsize::new(0), stop_at }
    }

    fn keep_going(&self) -> bool {
        let n = self.calls.fetch_add(1, Ordering::SeqCst) + 1;
        n != self.stop_at
    }

    fn calls(&self) -> usize {
        self.calls.load(Ordering::SeqCst)
    }
}

/// The long steps of an edit (assembly, hierarchy, cut) stop at every one of their polls with
/// their cancel error, and never asked to stop give exactly the plain call's result.
#[test]
fn the_long_steps_stop_at_every_poll() {
    use transcut::diffusion::{assemble, assemble_with, DiffusionError};
    use transcut::edit::cut::{cut, cut_with, CutOptions};
    use transcut::edit::EditError;
    use transcut::mesher::{tetrahedralize, MesherOptions};
    use transcut::sparse::hierarchy::{Hierarchy, HierarchyOptions};
    use transcut::sparse::SparseError;

    let mesh = tetrahedralize(&uv_sphere(10.0, 24, 12), &MesherOptions::with_tets(3_000)).unwrap();
    let media = [Medium::preset("marble").unwrap()];

    let plain = assemble(&mesh, &media, 1.0).unwrap();
    let all = StopAt::new(0);
    let polled = assemble_with(&mesh, &media, 1.0, &|| all.keep_going()).unwrap();
    assert_eq!(polled.matrix().values(), plain.matrix().values());
    assert!(all.calls() >= 3, "{} polls", all.calls());
    for k in 1..=all.calls() {
        let stop = StopAt::new(k);
        let e = assemble_with(&mesh, &media, 1.0, &|| stop.keep_going()).unwrap_err();
        assert!(matches!(e, DiffusionError::Cancelled), "stop at poll {k}: {e}");
        assert_eq!(stop.calls(), k, "the assembly went on after poll {k}");
    }

    let positions = mesh.positions(); // in mm: 1 mm per unit
    let options = HierarchyOptions::default().with_min_vertices(50);
    let levels = Hierarchy::build(plain.pattern(), positions, &options).unwrap().levels();
    let all = StopAt::new(0);
    let polled = Hierarchy::build_with(plain.pattern(), positions, &options, &|| all.keep_going()).unwrap();
    assert_eq!(polled.levels(), levels);
    assert!(levels > 2 && all.calls() >= 2 * (levels - 1), "{} polls for {levels} levels", all.calls());
    for k in 1..=all.calls() {
        let stop = StopAt::new(k);
        let e = Hierarchy::build_with(plain.pattern(), positions, &options, &|| stop.keep_going()).unwrap_err();
        assert!(matches!(e, SparseError::Cancelled { .. }), "stop at poll {k}: {e}");
        assert_eq!(stop.calls(), k);
    }

    let tets: Vec<u32> = (0..mesh.tet_count() as u32).collect();
    let cutter = Cutter::Plane { point: DVec3::new(0.0, 0.0, 2.0), normal: DVec3::new(0.3, 0.0, 1.0).normalize() };
    let options = CutOptions::default();
    let plain = cut(&mesh, &tets, &cutter, &options).unwrap();
    let all = StopAt::new(0);
    let polled = cut_with(&mesh, &tets, &cutter, &options, &|| {
        assert!(all.keep_going());
        Ok(())
    })
    .unwrap();
    assert_eq!((polled.mesh.positions(), polled.mesh.tets()), (plain.mesh.positions(), plain.mesh.tets()));
    assert!(all.calls() >= 5, "{} polls", all.calls());
    for k in 1..=all.calls() {
        let stop = StopAt::new(k);
        let poll = || if stop.keep_going() { Ok(()) } else { Err(transcut::Cancelled) };
        let e = cut_with(&mesh, &tets, &cutter, &options, &poll).unwrap_err();
        assert!(matches!(e, EditError::Cancelled(_)), "stop at poll {k}: {e}");
        assert_eq!(stop.calls(), k);
    }
}
