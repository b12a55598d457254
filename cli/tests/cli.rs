//! The `transcut` binary as a user runs it.

use std::path::PathBuf;
use std::process::Command;

fn transcut() -> Command {
    Command::new(env!("CARGO_BIN_EXE_transcut"))
}

fn shared_mesh(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/meshes").join(name)
}

#[test]
fn mesh_writes_vtk_and_json_statistics() {
    let dir = std::env::temp_dir().join(format!("transcut-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vtk = dir.join("spot.vtk");
    let out = transcut()
        .args(["mesh", shared_mesh("spot.obj").to_str().unwrap(), "--tets", "20000", "--json", "-o"])
        .arg(&vtk)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let stats = &json["stats"];
    let tets = stats["tets"].as_u64().unwrap();
    assert!((14_000..=26_000).contains(&tets), "{tets}");
    assert!(stats["quality"]["min_dihedral_deg"].as_f64().unwrap() >= 10.0);
    assert_eq!(stats["quality"]["min_angle_histogram"].as_array().unwrap().len(), 9);
    assert!(stats["hausdorff"]["max"].as_f64().unwrap().is_finite());
    let bytes = std::fs::read(&vtk).unwrap();
    assert!(bytes.starts_with(b"# vtk DataFile Version 3.0\n"));
    let header = String::from_utf8_lossy(&bytes[..200]);
    assert!(header.contains("BINARY") && header.contains("DATASET UNSTRUCTURED_GRID"));
    let cells = format!("CELLS {tets} {}", 5 * tets);
    assert!(bytes.windows(cells.len()).any(|w| w == cells.as_bytes()), "{cells}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn human_output_names_the_statistics() {
    let out = transcut().args(["mesh", shared_mesh("suzanne.obj").to_str().unwrap(), "--tets", "5000"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    for word in ["tets", "dihedral", "hausdorff", "time"] {
        assert!(text.contains(word), "missing {word} in:\n{text}");
    }
}

#[test]
fn bad_input_fails_with_a_clear_message() {
    let out = transcut().args(["mesh", "/nonexistent/mesh.obj"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("transcut: error: loading /nonexistent/mesh.obj"), "{err}");
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
    let out = transcut().args(["mesh", "x.obj", "--tets", "0"]).output().unwrap();
    assert!(!out.status.success());
}

#[test]
fn help_explains_the_commands() {
    let out = transcut().arg("--help").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("mesh") && text.contains("bench"));
    let out = transcut().args(["mesh", "--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("--tets") && text.contains("winding number"));
}
