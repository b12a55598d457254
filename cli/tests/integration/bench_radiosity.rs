//! `transcut bench radiosity` on a coarse Cornell box, opaque and with the example's marble
//! block: every field is there and the numbers agree with each other (no timings are asserted).

#[test]
fn the_radiosity_suite_reports_every_patch_size() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/cornell_marble.toml");
    let report = crate::bench_report(&[
        "radiosity",
        "--runs",
        "1",
        "--patch-sizes",
        "50,35",
        "--radiosity-tets",
        "8000",
        "--scene",
        scene,
    ]);
    assert_eq!(report["suite"], "radiosity");
    let entries = report["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 2);
    for e in entries {
        let patches = e["patches"].as_u64().unwrap();
        let nonzeros = e["nonzeros"].as_u64().unwrap();
        assert!(patches > 50 && nonzeros > patches, "{e}");
        assert!((e["nonzeros_per_patch"].as_f64().unwrap() - nonzeros as f64 / patches as f64).abs() < 1e-9);
        // 8 bytes a stored factor (a u32 column, an f32 exchange).
        assert!((e["form_factor_mib"].as_f64().unwrap() * 1024.0 * 1024.0 - 8.0 * nonzeros as f64).abs() < 1.0);
        let (jacobi, gs) = (e["jacobi_sweeps"].as_u64().unwrap(), e["gauss_seidel_sweeps"].as_u64().unwrap());
        assert!(gs >= 1 && gs <= jacobi, "Gauss–Seidel took {gs} sweeps, Jacobi {jacobi}");
        assert!(e["energy_defect"].as_f64().unwrap() < 1e-2, "{e}");
        for key in ["median_form_factor_ms", "median_jacobi_ms", "median_gauss_seidel_ms", "jacobi_to_gauss_seidel"] {
            assert!(e[key].as_f64().unwrap() > 0.0, "{key}: {e}");
        }
    }
    // A finer patch size makes more patches.
    assert!(entries[1]["patches"].as_u64() > entries[0]["patches"].as_u64());

    let coupled = report["coupled"].as_array().unwrap();
    assert_eq!(coupled.len(), 2);
    for e in coupled {
        let (patches, translucent) = (e["patches"].as_u64().unwrap(), e["translucent_patches"].as_u64().unwrap());
        assert!(translucent > 0 && patches > translucent, "{e}");
        assert!(e["tets"].as_u64().unwrap() >= 4000, "{e}");
        let (jacobi, gs) = (e["jacobi_sweeps"].as_u64().unwrap(), e["gauss_seidel_sweeps"].as_u64().unwrap());
        assert!(gs >= 1 && gs <= jacobi, "Gauss–Seidel took {gs} sweeps, Jacobi {jacobi}");
        // The warm start after turning the light 5° needs no more sweeps than the bake's cold solve.
        assert!(e["relight_sweeps"].as_u64().unwrap() <= e["solve_sweeps"].as_u64().unwrap(), "{e}");
        assert!(e["energy_defect"].as_f64().unwrap() < 1e-2, "{e}");
        for (fps, ms) in [("relight_fps", "median_relight_ms"), ("medium_fps", "median_medium_ms")] {
            assert!((e[fps].as_f64().unwrap() * e[ms].as_f64().unwrap() - 1e3).abs() < 1e-6, "{fps}: {e}");
        }
        for key in ["median_form_factor_ms", "median_prepare_ms", "median_recolour_ms", "median_albedo_ms"] {
            assert!(e[key].as_f64().unwrap() > 0.0, "{key}: {e}");
        }
        // The profile S beside it: the same patches but the block's (its surface refined, no
        // tets), a matrix of at most one entry per pair, 44 bytes an entry plus 8 a sample.
        let p = &e["profile"];
        let (translucent, nonzeros) = (p["translucent_patches"].as_u64().unwrap(), p["nonzeros"].as_u64().unwrap());
        assert!(translucent > 0 && nonzeros >= translucent && nonzeros <= translucent * translucent, "{p}");
        assert!(p["matrix_mib"].as_f64().unwrap() * 1024.0 * 1024.0 >= 44.0 * nonzeros as f64, "{p}");
        assert_eq!(p["patches"].as_u64().unwrap() - translucent, patches - e["translucent_patches"].as_u64().unwrap(), "{p}");
        assert!(p["relight_sweeps"].as_u64().unwrap() <= p["solve_sweeps"].as_u64().unwrap(), "{p}");
        assert!(p["energy_defect"].as_f64().unwrap() < 1e-2, "{p}");
        for key in ["median_build_ms", "median_solve_ms", "median_relight_ms", "median_medium_ms"] {
            assert!(p[key].as_f64().unwrap() > 0.0, "{key}: {p}");
        }
    }
    assert!(coupled[1]["patches"].as_u64() > coupled[0]["patches"].as_u64());
}
