//! `transcut bench inverse` on a tiny block: every field is there and the numbers agree with
//! each other (no timings are asserted).

use std::process::Command;

#[test]
fn the_inverse_suite_reports_both_optimisers_and_the_marble_estimate() {
    let out = Command::new(env!("CARGO_BIN_EXE_transcut"))
        .args(["bench", "inverse", "--inverse-nodes", "6,6,4", "--inverse-iterations", "3"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["suite"], "inverse");
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
    assert_eq!(e["warm_start_bytes"].as_u64().unwrap(), 48 * 16 * 256 * 256 * 20);
}
