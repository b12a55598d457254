//! `transcut bench radiosity` on a coarse Cornell box: every field is there and the numbers agree
//! with each other (no timings are asserted).

use std::process::Command;

#[test]
fn the_radiosity_suite_reports_every_patch_size() {
    let out = Command::new(env!("CARGO_BIN_EXE_transcut"))
        .args(["bench", "radiosity", "--runs", "1", "--patch-sizes", "50,35"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["suite"], "radiosity");
    let entries = report["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 2);
    for e in entries {
        let patches = e["patches"].as_u64().unwrap();
        let nonzeros = e["nonzeros"].as_u64().unwrap();
        assert!(patches > 50 && nonzeros > patches, "{e}");
        assert!((e["nonzeros_per_patch"].as_f64().unwrap() - nonzeros as f64 / patches as f64).abs() < 1e-9);
        // 12 bytes a stored factor.
        assert!((e["form_factor_mib"].as_f64().unwrap() * 1024.0 * 1024.0 - 12.0 * nonzeros as f64).abs() < 1.0);
        let (jacobi, gs) = (e["jacobi_sweeps"].as_u64().unwrap(), e["gauss_seidel_sweeps"].as_u64().unwrap());
        assert!(gs >= 1 && gs <= jacobi, "Gauss–Seidel took {gs} sweeps, Jacobi {jacobi}");
        assert!(e["energy_defect"].as_f64().unwrap() < 1e-2, "{e}");
        for key in ["median_form_factor_ms", "median_jacobi_ms", "median_gauss_seidel_ms", "jacobi_to_gauss_seidel"] {
            assert!(e[key].as_f64().unwrap() > 0.0, "{key}: {e}");
        }
    }
    // A finer patch size makes more patches.
    assert!(entries[1]["patches"].as_u64() > entries[0]["patches"].as_u64());
}
