//! `transcut bench inverse` on a tiny block, with and without the sweep: every field is there
//! and the numbers agree with each other (no timings are asserted).

#[test]
fn the_inverse_suite_reports_both_optimisers_and_the_marble_estimate() {
    let r = crate::bench_report(&["inverse", "--inverse-nodes", "6,6,4", "--inverse-iterations", "3"]);
    assert_eq!(r["suite"], "inverse");
    assert_eq!(r["observation"], "back-lit");
    assert_eq!(r["images"], 16);
    assert_eq!(r["cells"], 5 * 5 * 3);
    let methods = r["methods"].as_array().unwrap();
    assert_eq!(methods.len(), 2);
    assert_eq!(methods[0]["method"], "lbfgs");
    assert_eq!(methods[1]["method"], "paper");
    let count = |m: usize, k: &str| methods[m][k].as_u64().unwrap();
    for method in methods {
        let count = |k: &str| method[k].as_u64().unwrap();
        // One solve per image per evaluation or gradient.
        assert_eq!(count("forward_solves") % 16, 0);
        assert_eq!(count("adjoint_solves") % 16, 0);
        // At most the cap per channel in the per-cell fit.
        assert!(count("heterogeneous_iterations") <= 3 * 3, "{method}");
        let misfit = method["misfit_rms"].as_array().unwrap();
        assert!(misfit.iter().all(|v| v.as_f64().unwrap() > 0.0 && v.as_f64().unwrap() < 1.0), "{misfit:?}");
    }
    let ratio = r["forward_solves_default_over_paper"].as_f64().unwrap();
    assert!((ratio - count(0, "forward_solves") as f64 / count(1, "forward_solves") as f64).abs() < 1e-12);
    // The estimate: the default run's solves × seconds per solve × the node and axis ratios.
    let solves = (count(0, "forward_solves") + count(0, "adjoint_solves")) as f64;
    let per_solve = methods[0]["seconds_per_solve"].as_f64().unwrap();
    let expected = solves * per_solve * (256.0 * 256.0 * 20.0) / (6.0 * 6.0 * 4.0) * (256.0 / 6.0);
    let e = &r["marble_estimate"];
    assert!((e["seconds"].as_f64().unwrap() / expected - 1.0).abs() < 1e-9, "{e}");
    assert_eq!(e["paper_hours"], 11.0);
    // TransCut's rendering of the default run's grid and its homogeneous fit, per light.
    let rendered = &r["rendered_lit_face_rms"];
    assert_eq!(rendered["tets"], 60_000);
    for fit in ["recovered", "homogeneous"] {
        for light in ["sun", "spot"] {
            let v = rendered[fit][light].as_f64().unwrap();
            assert!(v > 0.0 && v < 1.0, "{fit} under the {light}: {v}");
        }
    }
    // Each fit's κ and μ by layer of cells (three at 0.5 mm) and its held-out appearance.
    for method in methods {
        let q = &method["quality"];
        assert_eq!(q["depth"].as_array().unwrap().len(), 3);
        assert!(q["held_out_point_rms"].as_f64().unwrap() > 0.0);
    }
    assert_eq!(e["warm_start_bytes"].as_u64().unwrap(), 48 * 16 * 256 * 256 * 20);
}

/// `--inverse-front-lit` observes the lit face: the report names it with its margin, and the
/// fit sees other pixels than the back-lit one (a different misfit).
#[test]
fn the_front_lit_acquisition_is_named_and_differs() {
    let run = |extra: &[&str]| {
        let mut args = vec!["inverse", "--inverse-nodes", "6,6,4", "--inverse-iterations", "3"];
        args.extend_from_slice(extra);
        crate::bench_report(&args)
    };
    let front = run(&["--inverse-front-lit", "0.5"]);
    assert_eq!(front["observation"]["front-lit"]["margin_mm"], 0.5);
    let back = run(&[]);
    let misfit = |r: &serde_json::Value| r["methods"][0]["misfit_rms"].clone();
    assert_ne!(misfit(&front), misfit(&back));
}

#[test]
fn coarse_to_fine_and_coarser_absorption_are_passed_to_the_fits() {
    let r = crate::bench_report(&[
        "inverse",
        "--inverse-nodes",
        "6,6,4",
        "--inverse-iterations",
        "3",
        "--inverse-coarse-levels",
        "1",
        "--inverse-absorption-coarsening",
        "2",
    ]);
    assert_eq!((r["coarse_levels"].as_u64(), r["absorption_coarsening"].as_u64()), (Some(1), Some(2)));
    for method in r["methods"].as_array().unwrap() {
        let count = |k: &str| method[k].as_u64().unwrap();
        // One coarse level and the per-cell fit, each capped at 3 per channel.
        assert!((1..=3 * 3).contains(&count("coarse_iterations")), "{method}");
        assert!(count("heterogeneous_iterations") <= 3 * 3, "{method}");
    }
}

#[test]
fn the_sweep_reports_every_pattern_count_and_the_noisy_repeat() {
    let r = crate::bench_report(&["inverse", "--inverse-nodes", "6,6,4", "--inverse-iterations", "3", "--inverse-sweep"]);
    let sweep = &r["sweep"];
    let entries = sweep["patterns"].as_array().unwrap();
    let counts: Vec<u64> = entries.iter().map(|e| e["images"].as_u64().unwrap()).collect();
    assert_eq!(counts, [1, 4, 9, 16, 25, 64]);
    for e in entries {
        let m = e["images"].as_u64().unwrap();
        // One solve per image per evaluation or gradient.
        assert_eq!(e["forward_solves"].as_u64().unwrap() % m, 0, "{e}");
        assert_eq!(e["adjoint_solves"].as_u64().unwrap() % m, 0, "{e}");
        let q = &e["quality"];
        for k in ["held_out_random_rms", "held_out_point_rms"] {
            let v = q[k].as_f64().unwrap();
            assert!(v > 0.0 && v < 1.0, "{k} {v}");
        }
        // Three layers of cells at 0.5 mm from the lit face; the top 1 mm is the first two.
        let depth = q["depth"].as_array().unwrap();
        let depths: Vec<f64> = depth.iter().map(|d| d["depth_mm"].as_f64().unwrap()).collect();
        assert_eq!(depths, [0.25, 0.75, 1.25]);
        assert_eq!(q["top_1mm"]["depth_mm"], 0.75);
        // The top 1 mm's squared error is a weighted mean of its two layers': between them.
        for k in ["kappa_rms", "mu_rms"] {
            for c in 0..3 {
                let layer = |i: usize| depth[i][k][c].as_f64().unwrap();
                let top = q["top_1mm"][k][c].as_f64().unwrap();
                let (lo, hi) = (layer(0).min(layer(1)), layer(0).max(layer(1)));
                assert!(top >= lo - 1e-12 && top <= hi + 1e-12, "{k}[{c}]: top {top} against layers {lo} … {hi}");
            }
        }
    }
    // The 16-pattern entry is the comparison's default run.
    let default = &r["methods"][0];
    assert_eq!(entries[3]["forward_solves"], default["forward_solves"]);
    assert_eq!(entries[3]["quality"], default["quality"]);
    // The noisy repeat: 16 images at 1% noise, λ from the discrepancy principle's decades.
    let noisy = &sweep["noisy"];
    assert_eq!(noisy["images"], 16);
    assert_eq!(noisy["noise_rms"], 0.01);
    for l in noisy["lambda"].as_array().unwrap() {
        let decades = (1e-2 / l.as_f64().unwrap()).log10();
        assert!((decades - decades.round()).abs() < 1e-9 && (0.0..8.0).contains(&decades.round()), "λ {l}");
    }
}
