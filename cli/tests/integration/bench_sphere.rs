//! `transcut bench sphere` at 100k tets: every entry is there, σtr·h is the preset's σtr
//! (computed here from Jensen's coefficients) times the reported spacing, the graded mesh has the
//! finer surface, marble is resolved, the fitted assembly beats the paper's in skin's blue and the
//! layer's absorption beats the fitting alone.

/// σtr = √(3 σa (σa + σ′s)) per channel, mm⁻¹.
fn sigma_tr(sigma_a: [f64; 3], sigma_s_prime: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|c| (3.0 * sigma_a[c] * (sigma_a[c] + sigma_s_prime[c])).sqrt())
}

#[test]
fn the_sphere_suite_reports_every_medium_assembly_and_grading() {
    let report = crate::bench_report(&[
        "sphere",
        "--tets",
        "100000",
        "--grading",
        "0,1",
        "--presets",
        "marble,skin1",
        "--discretizations",
        "transcut,fitted,fitted-layer",
    ]);
    assert_eq!(report["suite"], "sphere");
    assert_eq!(report["radius_mm"], 10.0);
    let meshes = report["meshes"].as_array().unwrap();
    assert_eq!(meshes.iter().map(|m| m["grading"].as_u64().unwrap()).collect::<Vec<_>>(), [0, 1]);
    let spacing: Vec<f64> = meshes.iter().map(|m| m["surface_spacing_mm"].as_f64().unwrap()).collect();
    assert!(spacing[1] < spacing[0], "graded surface spacing {spacing:?}");
    let marble = sigma_tr([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00]);
    let skin1 = sigma_tr([0.032, 0.17, 0.48], [0.74, 0.88, 1.01]);
    let f3 = |v: &serde_json::Value| -> [f64; 3] { std::array::from_fn(|c| v[c].as_f64().unwrap()) };
    for (m, h) in meshes.iter().zip(&spacing) {
        let tets = m["tets"].as_u64().unwrap();
        assert!((70_000..=130_000).contains(&tets), "{tets} tets for 100000");
        let media = m["media"].as_array().unwrap();
        let names: Vec<(&str, &str)> =
            media.iter().map(|e| (e["preset"].as_str().unwrap(), e["discretization"].as_str().unwrap())).collect();
        assert_eq!(
            names,
            [
                ("marble", "transcut"),
                ("marble", "fitted"),
                ("marble", "fitted-layer"),
                ("skin1", "transcut"),
                ("skin1", "fitted"),
                ("skin1", "fitted-layer")
            ]
        );
        for e in media {
            let tr = if e["preset"] == "marble" { marble } else { skin1 };
            let (rms, mean, trh) = (f3(&e["lo_rms"]), f3(&e["lo_mean"]), f3(&e["sigma_tr_h"]));
            for c in 0..3 {
                assert!((trh[c] / (tr[c] * h) - 1.0).abs() < 1e-3, "{e}");
                assert!(mean[c].abs() <= rms[c] + 1e-15, "{e}");
                if e["preset"] == "marble" {
                    assert!(rms[c] < 0.01, "marble channel {c}: {e}");
                }
            }
        }
        let skin_blue = |i: usize| f3(&media[i]["lo_rms"])[2];
        assert!(skin_blue(4) < skin_blue(3), "skin1 blue: fitted {} against transcut {}", skin_blue(4), skin_blue(3));
        assert!(skin_blue(5) < skin_blue(4), "skin1 blue: fitted-layer {} against fitted {}", skin_blue(5), skin_blue(4));
    }
}
