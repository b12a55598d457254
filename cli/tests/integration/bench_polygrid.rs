//! `transcut bench polygrid` on small grids: every field is there and the numbers agree with
//! each other (no timings are asserted).

#[test]
fn the_polygrid_suite_reports_fig15_and_the_diffusion_pass() {
    let spot = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/spot.obj");
    let report = crate::bench_report(&[
        "polygrid",
        "--runs",
        "1",
        "--polygrid-resolution",
        "16",
        "--polygrid-nodes",
        "3000",
        "--polygrid-object",
        spot.to_str().unwrap(),
    ]);
    assert_eq!(report["suite"], "polygrid");
    // The ball and the block, each with the three stencils (the paper's included).
    let figure = report["fig15"].as_array().unwrap();
    assert_eq!(figure.len(), 6);
    let stencils: Vec<&str> = figure.iter().map(|f| f["stencil"].as_str().unwrap()).collect();
    assert_eq!(stencils, ["fem", "fem", "finite-volume", "finite-volume", "paper-lsq", "paper-lsq"]);
    for f in figure {
        let nodes: Vec<u64> = f["nodes"].as_array().unwrap().iter().map(|n| n.as_u64().unwrap()).collect();
        assert_eq!(nodes.len(), 3);
        assert!(nodes[0] > nodes[1] && nodes[1] > nodes[2], "{f}");
        let schemes = f["schemes"].as_array().unwrap();
        assert_eq!(schemes.len(), 4);
        assert_eq!(schemes[0]["scheme"], "gauss-seidel");
        assert_eq!(schemes[1]["scheme"], "hierarchical");
        let updates = |i: usize| schemes[i]["updates_to_1pct"].as_u64();
        // Gauss–Seidel and the cascade always get to 1%; the ratio is theirs.
        let (gs, hierarchical) = (updates(0).unwrap(), updates(1).unwrap());
        let ratio = f["hierarchical_over_gauss_seidel"].as_f64().unwrap();
        assert!((ratio - hierarchical as f64 / gs as f64).abs() < 1e-12, "{f}");
        for s in schemes {
            let curve = s["curve"].as_array().unwrap();
            assert!(!curve.is_empty() && curve.len() <= 201, "{s}");
            // The curve's updates increase; its last error is the one reported.
            let u: Vec<u64> = curve.iter().map(|p| p["updates"].as_u64().unwrap()).collect();
            assert!(u.windows(2).all(|w| w[0] < w[1]), "{s}");
            let last = curve.last().unwrap()["error"].as_f64().unwrap();
            assert_eq!(last, s["final_error"].as_f64().unwrap());
            if let Some(to1) = s["updates_to_1pct"].as_u64() {
                assert!(s["median_ms_to_1pct"].as_f64().unwrap() > 0.0, "{s}");
                // 1% is reached on the way down the curve.
                assert!(u.last().copied().unwrap() >= to1, "{s}");
            }
        }
    }
    // The ball, then Spot mapped at 4 cells per cube (it maps at this size), each with P1 and FV.
    let passes = report["diffusion_pass"].as_array().unwrap();
    assert_eq!(passes.len(), 4);
    for (p, stencil) in passes.iter().zip(["fem", "finite-volume", "fem", "finite-volume"]) {
        assert_eq!(p["stencil"], stencil, "{p}");
    }
    assert!(passes[0]["model"].as_str().unwrap().starts_with("cubed-sphere ball"));
    assert!(passes[2]["model"].as_str().unwrap().contains("spot.obj, 4 cells per cube"));
    for p in passes {
        assert_eq!(p["resolution"], if p["model"].as_str().unwrap().contains("spot") { 4 } else { 12 }, "{p}");
        let solvers = p["solvers"].as_array().unwrap();
        assert_eq!(solvers.len(), 9);
        for s in solvers.iter().filter(|s| s.get("skipped").is_none()) {
            // Every timed solver got within 1%, cold and warm.
            assert!(s["cold_error"].as_f64().unwrap() <= 0.01 && s["warm_error"].as_f64().unwrap() <= 0.01, "{s}");
            assert!(s["median_cold_ms"].as_f64().unwrap() > 0.0 && s["median_warm_ms"].as_f64().unwrap() > 0.0, "{s}");
            assert!(s["tolerance"].is_f64() != s["cold_sweeps_per_level"].is_u64(), "{s}");
        }
        // The CGs and the cascade always get there.
        for s in &solvers[..5] {
            assert!(s.get("skipped").is_none(), "{s}");
        }
    }
}
