//! `transcut acquire synth` then `transcut acquire` on a tiny block, end to end: the data set's
//! files, the fit's report, the voxel grid it writes, and bad input refused by name with no
//! output written.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use transcut::volume::VoxelGrid;

fn transcut(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_transcut")).args(args).output().unwrap()
}

/// A fresh folder under the target's temporary folder.
fn scratch(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("acquire-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Writes a 6 × 6 × 4-node synthetic data set (16 images of 6 × 6 pixels) into `dir`.
fn synth(dir: &Path) {
    let out = transcut(&["acquire", "synth", "-o", path(dir), "--nodes", "6,6,4", "--max-iterations", "4", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["images"], 16);
}

/// The mean of channel `c` of every voxel.
fn mean(grid: &VoxelGrid, c: usize) -> f64 {
    let [x, y, z] = grid.dims();
    let mut sum = 0.0;
    for k in 0..z {
        for j in 0..y {
            for i in 0..x {
                sum += grid.voxel([i, j, k]).unwrap().to_array()[c];
            }
        }
    }
    sum / grid.voxel_count() as f64
}

#[test]
fn a_synthetic_block_is_acquired_end_to_end() {
    let dir = scratch("end-to-end");
    synth(&dir);
    for m in 0..16 {
        assert!(dir.join(format!("m{m:02}.exr")).is_file(), "m{m:02}.exr");
    }
    let output = dir.join("material.tcvox");
    let out = transcut(&["acquire", path(&dir.join("acquisition.toml")), "-o", path(&output), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["cells"], 5 * 5 * 3);
    assert_eq!(r["images"], 16);
    // Every evaluation is 16 forward solves; every gradient 16 adjoint solves.
    assert_eq!(r["forward_solves"].as_u64().unwrap() % 16, 0, "{r}");
    assert_eq!(r["adjoint_solves"].as_u64().unwrap() % 16, 0, "{r}");
    // The per-cell fit never ends above its start, channel by channel.
    let history = r["history"].as_array().unwrap();
    for c in 0..3 {
        let fit: Vec<f64> = history
            .iter()
            .filter(|h| h["stage"] == "heterogeneous" && h["channel"] == c)
            .map(|h| h["objective"].as_f64().unwrap())
            .collect();
        assert!(fit.len() >= 2 && fit.last().unwrap() <= fit.first().unwrap(), "channel {c}: {fit:?}");
    }
    // One unknown pair per cell after the homogeneous fit's one block (no coarse levels).
    for h in history {
        let blocks = if h["stage"] == "homogeneous" { [0, 0] } else { [1, 1] };
        assert_eq!(h["block_cells"], serde_json::json!(blocks), "{h}");
    }
    // The file is the fit: one voxel per cell, 0.5 mm, and close to the truth on average.
    let got = VoxelGrid::read(&output).unwrap();
    let truth = VoxelGrid::read(dir.join("truth.tcvox")).unwrap();
    assert_eq!(got.dims(), [5, 5, 3]);
    assert_eq!(got.voxel_size().x, 0.5);
    for c in 3..6 {
        let (g, t) = (mean(&got, c), mean(&truth, c));
        assert!((g / t - 1.0).abs() < 0.25, "σ′s channel {}: recovered mean {g}, truth {t}", c - 3);
    }
    // The same acquisition without --json prints one line naming the file.
    let out = transcut(&["acquire", path(&dir.join("acquisition.toml")), "-o", path(&output)]);
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("material.tcvox (5 × 5 × 3 voxels)"));
}

#[test]
fn bad_input_is_named_and_nothing_is_written() {
    let dir = scratch("bad-input");
    synth(&dir);
    let text = std::fs::read_to_string(dir.join("acquisition.toml")).unwrap();
    let output = dir.join("out.tcvox");
    // An existing output stays as it was when an acquisition fails.
    std::fs::write(&output, b"previous").unwrap();
    let cases: [(&str, String, &str); 4] = [
        ("negative-lambda", text.replace("lambda = 0.0001", "lambda = -0.5"), "λ must be finite and ≥ 0, got -0.5"),
        ("missing-image", text.replace("m07.exr", "nope.exr"), "nope.exr: no such file"),
        ("count", text.replace("\"m15.exr\"", "\"m15.exr\", \"m14.exr\""), "17 images for 16 light patterns"),
        ("unknown-key", text.replace("eta = 1.3", "eta = 1.3\ncolour = 2"), "unknown field `colour`"),
    ];
    for (name, body, message) in cases {
        assert_ne!(body, text, "{name}: the replacement did not apply");
        let file = dir.join(format!("{name}.toml"));
        std::fs::write(&file, body).unwrap();
        let out = transcut(&["acquire", path(&file), "-o", path(&output)]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name}");
        assert!(stderr.contains(message), "{name}: {stderr}");
        assert_eq!(std::fs::read(&output).unwrap(), b"previous", "{name}");
    }
    // A wrong-sized image names both sizes.
    let small = transcut(&["acquire", "synth", "-o", path(&dir.join("small")), "--nodes", "5,6,4", "--max-iterations", "1"]);
    assert!(small.status.success());
    std::fs::copy(dir.join("small/m03.exr"), dir.join("m03.exr")).unwrap();
    let out = transcut(&["acquire", path(&dir.join("acquisition.toml")), "-o", path(&output)]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("m03.exr is 5 × 6 pixels, the face has 6 × 6 nodes"), "{stderr}");
    assert_eq!(std::fs::read(&output).unwrap(), b"previous");
}

#[test]
fn help_explains_the_description() {
    let out = transcut(&["acquire", "--help"]);
    let text = String::from_utf8_lossy(&out.stdout);
    for needle in ["observe", "[patterns]", "TCVOX1", "acquire synth"] {
        assert!(text.contains(needle), "{needle}: {text}");
    }
}
