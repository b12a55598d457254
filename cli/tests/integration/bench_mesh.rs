//! `transcut bench mesh` at 5000 tets on Suzanne (open shells, pinched where the eyes meet the
//! head) and on Spot (closed), uniform and graded: each entry reports the guaranteed dihedral
//! bounds, a closed manifold boundary, the repair's counts and stage timings that fit in the
//! total.

use std::path::PathBuf;

#[test]
fn the_mesh_suite_reports_quality_repairs_and_stages_per_entry() {
    for name in ["suzanne.obj", "spot.obj"] {
        let input = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes").join(name);
        let report = crate::bench_report(&[
            "mesh",
            "--input",
            input.to_str().unwrap(),
            "--tets",
            "5000",
            "--grading",
            "0,1",
            "--runs",
            "1",
        ]);
        assert_eq!(report["suite"], "mesh");
        let entries = report["entries"].as_array().unwrap();
        assert_eq!(entries.len(), 2, "{name}: one entry per grading");
        for e in entries {
            let f = |key: &str| e[key].as_f64().unwrap_or_else(|| panic!("{name}: {key} in {e}"));
            let tets = f("tets");
            assert!((tets / 5000.0 - 1.0).abs() <= 0.3, "{name}: {tets} tets");
            assert!(f("min_dihedral_deg") >= 10.0 && f("max_dihedral_deg") <= 165.0, "{name}: {e}");
            assert_eq!(e["tets_below_10_deg"], 0, "{name}");
            assert_eq!(e["closed_manifold_boundary"], true, "{name}");
            assert!(f("off_surface_vertices") <= f("removed_tets") * 4.0, "{name}: {e}");
            assert!(f("passes") >= 1.0 && f("hausdorff") > 0.0 && f("spacing") > 0.0, "{name}: {e}");
            let stage = |key: &str| e["median_stage_ms"][key].as_f64().unwrap();
            let total = stage("total_ms");
            let parts = stage("winding_tree_ms") + stage("stuffing_ms") + stage("topology_ms") + stage("mapping_ms");
            assert!(parts <= total * 1.0001 && total <= f("median_ms") * 1.0001, "{name}: stages {parts} of {total}");
        }
        if name == "spot.obj" {
            assert!(entries.iter().all(|e| e["bisected_cuts"] == 0), "a closed input has no hole to bisect");
        }
        let cubes = |i: usize| entries[i]["cubes_per_level"].as_array().unwrap().len();
        assert!(cubes(1) >= cubes(0), "{name}: the graded entry has coarser cubes");
    }
}
