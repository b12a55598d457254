//! Cancellation at every instant of a bake and of a relight: a progress callback that asks to
//! stop at its k-th call, for calls spread over every stage (meshing, assembly, light, solve),
//! gets `Cancelled` back and nothing else. Prints the worst time from the cancel to the return
//! per stage (a measurement for the record, not an assertion: speed is never a unit test).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use transcut::gpu::Backend;
use transcut::light::{Light, SourceOptions};
use transcut::optics::Medium;
use transcut::{bake_with, BakeOptions, Object, Progress, Scene, SceneError, Session, SessionError, TransCutOptions};

mod common;
use common::uv_sphere;

/// A marble ball under a disc light and a soft sun, with shadows: every stage has work, the
/// light stage thousands of samples per point.
fn scene() -> (Scene, BakeOptions) {
    let ball = Object::new("ball", uv_sphere(10.0, 32, 16), Medium::preset("marble").unwrap(), 1.0);
    let disc = Light::DiscArea {
        center: glam::DVec3::new(0.0, 0.0, 30.0),
        normal: -glam::DVec3::Z,
        radius: 5.0,
        radiance: [2.0; 3],
        two_sided: false,
    };
    let sun = Light::Directional { direction: glam::DVec3::new(0.3, 0.0, -1.0), irradiance: [1.0; 3], angular_diameter_deg: 2.0 };
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
    let lights = vec![Light::Directional { direction: -glam::DVec3::Z, irradiance: [3.0; 3], angular_diameter_deg: 0.0 }];
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
