//! `transcut bench edit` on a small bunny: every field is there and the numbers agree with each
//! other (no timings are asserted).

use std::path::PathBuf;

fn bunny() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/stanford-bunny.obj")
}

fn sum(v: &serde_json::Value) -> u64 {
    let a = v.as_array().unwrap_or_else(|| panic!("not an array: {v}"));
    assert_eq!(a.len(), 3, "{v}");
    a.iter().map(|x| x.as_u64().unwrap()).sum()
}

fn positive(v: &serde_json::Value, what: &str) -> f64 {
    let x = v.as_f64().unwrap_or_else(|| panic!("{what}: not a number: {v}"));
    assert!(x.is_finite() && x > 0.0, "{what} = {x}");
    x
}

#[test]
fn bench_edit_reports_every_edit_consistently() {
    let json = crate::bench_report(&["edit", "--tets", "5000", "--runs", "1", "--input", bunny().to_str().unwrap()]);
    assert_eq!(json["suite"], "edit");
    let entries = json["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 1);
    let e = &entries[0];
    assert_eq!(e["grading"], "Uniform", "the default grading of the edit suite");
    let tets = e["tets"].as_u64().unwrap();
    assert!((4_000..=6_000).contains(&tets), "{tets}");

    // Cold bake and the relight after the sun moved 5°.
    assert!(sum(&e["cold_bake"]["iterations"]) > 0);
    positive(&e["cold_bake"]["median_solve_ms"], "cold solve ms");
    let relight = &e["relight_5deg"];
    assert_eq!(relight["solver"], "aggregation_pcg", "the editor's default solver");
    let cold_bake = sum(&relight["cold"]["iterations"]);
    let cold = sum(&relight["cold_same_solver_iterations"]);
    let warm = sum(&relight["warm"]["last"]["iterations"]);
    assert!(cold > 0 && warm > 0, "cold {cold}, warm {warm}");
    assert!(warm <= cold, "a warm start took more iterations ({warm}) than a cold solve ({cold})");
    assert!(
        cold < cold_bake,
        "the editor's aggregation MG-PCG ({cold}) needs fewer iterations than the bake's SSOR-PCG ({cold_bake})"
    );
    let ratio = relight["iteration_ratio"].as_f64().unwrap();
    assert!((ratio - warm as f64 / cold as f64).abs() < 1e-12, "{ratio}");
    let ratio_bake = relight["iteration_ratio_vs_cold_bake"].as_f64().unwrap();
    assert!((ratio_bake - warm as f64 / cold_bake as f64).abs() < 1e-12, "{ratio_bake}");
    assert_eq!(relight["warm"]["last"]["rows_rebuilt"], 0, "a relight rebuilds no rows");
    // Both solves reach the same solution (tolerance 1e-6 on the residual).
    let diff = relight["relative_difference_vs_cold"].as_f64().unwrap();
    assert!(diff < 1e-3, "warm vs cold relative difference {diff}");

    // Paint: some rows rebuilt, fewer than all, and the solve ran.
    let vertices = e["vertices"].as_u64().unwrap();
    let paint = &e["paint"];
    let rows = paint["last"]["rows_rebuilt"].as_u64().unwrap();
    assert!(rows > 0 && rows < vertices, "rows rebuilt {rows} of {vertices}");
    assert!(paint["last"]["tets_changed"].as_u64().unwrap() > 0);
    assert!(sum(&paint["last"]["iterations"]) > 0);
    positive(&paint["median_total_ms"], "paint ms");

    // Cut: tets removed, the solve ran, and the statistics are there.
    let cut = &e["cut_plane"];
    let stats = &cut["last"]["cut"];
    let removed = stats["removed_tets"].as_u64().unwrap();
    assert!(removed > 0 && removed < tets, "removed {removed} of {tets}");
    assert!(stats["min_dihedral_degrees"].as_f64().unwrap() >= stats["bound_degrees"].as_f64().unwrap());
    assert!(sum(&cut["last"]["iterations"]) > 0);
    positive(&cut["median_total_ms"], "cut ms");
    // The cut's steps are timed and fit inside its total.
    let step = |name: &str| stats[name].as_f64().unwrap();
    assert!(step("classify_ms") >= 0.0 && step("separate_ms") >= 0.0 && step("snap_ms") >= 0.0);
    assert!(step("classify_ms") + step("separate_ms") + step("snap_ms") <= step("total_ms"));

    // The ball bites into what the plane kept: it removes tets, fewer than the plane left.
    let bite = &e["cut_ball"]["last"]["cut"];
    let bitten = bite["removed_tets"].as_u64().unwrap();
    assert!(bitten > 0 && bitten < tets - removed, "the ball removed {bitten} of {}", tets - removed);
    assert!(bite["min_dihedral_degrees"].as_f64().unwrap() >= bite["bound_degrees"].as_f64().unwrap());

    // Fig. 7: five methods, curves whose error falls as the tolerance tightens, and a time to
    // 1% for each (the 1e-6 solve is far below 1%).
    let fig7 = &e["fig7"];
    assert_eq!(fig7["reference_tolerance"].as_f64().unwrap(), 1e-10);
    let methods = fig7["methods"].as_array().unwrap();
    let names: Vec<&str> = methods.iter().map(|m| m["method"].as_str().unwrap()).collect();
    assert_eq!(names, ["pcg", "ssor_pcg", "cascade", "mg_pcg", "sa_pcg"]);
    for m in methods {
        let curve = m["curve"].as_array().unwrap();
        assert_eq!(curve.len(), 11);
        let first = curve[0]["relative_error"].as_f64().unwrap();
        let last = curve[10]["relative_error"].as_f64().unwrap();
        assert!(last < first && last < 1e-3, "{}: error {first} -> {last}", m["method"]);
        assert!(m["error_1e6"].as_f64().unwrap() < 0.01);
        positive(&m["time_to_1pct_ms"], "time to 1%");
    }
    let best = fig7["time_to_1pct_ratio_best_multires_vs_best_single_level"].as_f64().unwrap();
    let cascade = fig7["time_to_1pct_ratio_cascade_vs_pcg"].as_f64().unwrap();
    let mg = fig7["time_to_1pct_ratio_mg_vs_pcg"].as_f64().unwrap();
    let ssor = fig7["time_to_1pct_ratio_ssor_vs_pcg"].as_f64().unwrap();
    let sa = fig7["time_to_1pct_ratio_sa_vs_pcg"].as_f64().unwrap();
    // All four ratios are over Jacobi PCG's time; the best single-level solver is the faster
    // of Jacobi and SSOR, the best multiresolution one the fastest of the other three.
    let multires = cascade.min(mg).min(sa);
    assert!((best - multires / ssor.min(1.0)).abs() < 1e-9, "{best} vs {cascade}, {mg}, {sa}, {ssor}");
}
