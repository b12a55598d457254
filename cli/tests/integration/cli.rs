//! The `transcut` binary as a user runs it.

use std::path::PathBuf;
use std::process::Command;

fn transcut() -> Command {
    Command::new(env!("CARGO_BIN_EXE_transcut"))
}

fn shared_mesh(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes").join(name)
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
    assert!(text.contains("mesh") && text.contains("bake") && text.contains("bench"));
    let out = transcut().args(["mesh", "--help"]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("--tets") && text.contains("winding number"));
}

#[test]
fn bake_writes_ply_npy_and_the_system() {
    let dir = std::env::temp_dir().join(format!("transcut-bake-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let spot = shared_mesh("spot.obj");
    let ply = dir.join("spot.ply");
    let out = transcut()
        .args(["bake", spot.to_str().unwrap(), "--medium", "skin1", "--scale", "10", "--tets", "15000", "--json"])
        .args(["--light", "sun:dir=0,-1,0,irradiance=3", "-o"])
        .arg(&ply)
        .arg("--export-system")
        .arg(dir.join("system"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(json["stats"]["tets"].as_u64().unwrap() > 10_000);
    assert!(json["stats"]["iterations"].as_array().unwrap().iter().all(|i| i.as_u64().unwrap() > 0));
    // Spot is wound consistently; skin's σtr grows from red to blue, and so does σtr·h.
    assert_eq!(json["stats"]["flipped_faces"].as_u64(), Some(0));
    let resolution: Vec<f64> = json["stats"]["resolution"].as_array().unwrap().iter().map(|r| r.as_f64().unwrap()).collect();
    assert!(resolution.len() == 3 && resolution[0] > 0.0 && resolution[0] < resolution[1] && resolution[1] < resolution[2]);
    // The PLY has the user's 2,930 vertices with float colours, all finite and non-negative.
    let bytes = std::fs::read(&ply).unwrap();
    let end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header = String::from_utf8_lossy(&bytes[..end]);
    assert!(header.contains("element vertex 2930") && header.contains("property float red"), "{header}");
    let colours: Vec<f32> = bytes[end..end + 2930 * 24]
        .chunks(24)
        .flat_map(|v| (3..6).map(move |k| f32::from_le_bytes(v[4 * k..4 * k + 4].try_into().unwrap())))
        .collect();
    assert!(colours.iter().all(|c| c.is_finite() && *c >= 0.0));
    assert!(colours.iter().any(|&c| c > 0.01));
    for name in ["M_red.mtx", "M_green.mtx", "M_blue.mtx", "b.mtx"] {
        let text = std::fs::read_to_string(dir.join("system").join(name)).unwrap();
        assert!(text.starts_with("%%MatrixMarket matrix"), "{name}");
    }
    // The same radiance as .npy: the header names the shape.
    let npy = dir.join("spot.npy");
    let out = transcut()
        .args(["bake", spot.to_str().unwrap(), "--medium", "skin1", "--scale", "10", "--tets", "15000"])
        .args(["--light", "sun:dir=0,-1,0,irradiance=3", "-o"])
        .arg(&npy)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let bytes = std::fs::read(&npy).unwrap();
    assert!(bytes.starts_with(b"\x93NUMPY\x01\x00"));
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    assert_eq!((10 + header_len) % 64, 0);
    assert!(String::from_utf8_lossy(&bytes[10..10 + header_len]).contains("'shape': (2930, 3)"));
    assert_eq!(bytes.len(), 10 + header_len + 2930 * 12);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bake_rejects_bad_specs_clearly() {
    let spot = shared_mesh("spot.obj");
    // Spot in skin at 2 m (mm_per_unit 1000) on 15k tets: refused, naming what would resolve it.
    let out = transcut()
        .args(["bake", spot.to_str().unwrap(), "--medium", "skin1", "--scale", "1000", "--tets", "15000"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("does not resolve") && err.contains("blue") && err.contains("tets"), "{err}");
    for (args, words) in [
        (vec!["--light", "laser:pos=0,0,0"], "unknown light kind"),
        (vec!["--medium", "jello"], "marble"),
        (vec!["--scale", "0"], "--scale"),
    ] {
        let out = transcut().args(["bake", spot.to_str().unwrap(), "--tets", "1000"]).args(&args).output().unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(words), "{args:?}: {err}");
    }
}

#[test]
fn methods_are_chosen_by_name_and_listed_by_help() {
    for command in [&["bake", "unused.obj"][..], &["render", "unused.toml", "-o", "unused.png"]] {
        let out = transcut().args(command).args(["--method", "help"]).output().unwrap();
        assert!(out.status.success(), "{command:?}: {}", String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.lines().any(|l| l.trim_start().starts_with("transcut ") && l.contains("TransCut")), "{command:?}: {text}");
    }
    let spot = shared_mesh("spot.obj");
    let out = transcut().args(["bake", spot.to_str().unwrap(), "--scale", "30", "--method", "nonsense"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("unknown method 'nonsense'") && err.contains("transcut"), "{err}");
    let out = transcut().args(["bake", spot.to_str().unwrap(), "--solver", "gauss"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("gauss") && err.contains("ssor-pcg"), "{err}");
    // The method by name, with another solver: the same radiance to the solver's tolerance.
    let bake = |extra: &[&str]| -> Vec<f64> {
        let out = transcut()
            .args([
                "bake",
                spot.to_str().unwrap(),
                "--scale",
                "30",
                "--tets",
                "8000",
                "--tolerance",
                "1e-10",
                "--backend",
                "cpu",
                "--json",
            ])
            .args(extra)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["stats"]["method"], "transcut");
        json["stats"]["relative_residual"].as_array().unwrap().iter().map(|r| r.as_f64().unwrap()).collect()
    };
    assert!(bake(&["--method", "TransCut"]).iter().all(|&r| r <= 1e-10));
    assert!(bake(&["--method", "transcut", "--solver", "mg-pcg"]).iter().all(|&r| r <= 1e-10));
}

/// Runs `transcut` with `args` and returns (exit code, stderr); a signal (an abort) fails here.
fn run_status(args: &[&std::ffi::OsStr]) -> (i32, String) {
    let out = transcut().args(args).output().unwrap();
    let code = out.status.code().unwrap_or_else(|| panic!("killed by a signal: {:?}", out.status));
    (code, String::from_utf8_lossy(&out.stderr).into_owned())
}

#[cfg(target_os = "linux")]
#[test]
fn unbounded_inputs_are_refused_with_short_messages() {
    let dir = std::env::temp_dir().join(format!("transcut-cli-bounded-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A file of one 1 GiB line (sparse: NUL bytes) and one whose first line is wrong.
    let line = dir.join("one_line.obj");
    let f = std::fs::File::create(&line).unwrap();
    f.set_len(1 << 30).unwrap();
    let bad = dir.join("bad_first_line.obj");
    let mut text = b"1 2 3 ".repeat(1 << 17);
    text.push(b'\n');
    std::fs::write(&bad, &text).unwrap();
    let cases: [(&std::path::Path, &str); 4] = [
        ("/dev/zero".as_ref(), "it is a character device, not a regular file"),
        (dir.as_ref(), "it is a directory, not a regular file"),
        (&line, "line 1 is longer than 1048576 bytes"),
        (&bad, ":1: unexpected '1'"),
    ];
    for (input, expect) in cases {
        let (code, stderr) = run_status(&["mesh".as_ref(), input.as_os_str()]);
        assert_ne!(code, 0, "{}", input.display());
        assert!(stderr.contains(expect), "{}: {stderr}", input.display());
        assert!(stderr.len() <= 1024 + 1, "{}: {} bytes", input.display(), stderr.len());
    }
    // The 768 KiB first line is quoted short.
    let (_, stderr) = run_status(&["mesh".as_ref(), bad.as_os_str()]);
    assert!(stderr.len() < 300, "{stderr}");
    // A scene file that is a device.
    let (code, stderr) = run_status(&["render".as_ref(), "/dev/zero".as_ref(), "-o".as_ref(), dir.join("x.png").as_os_str()]);
    assert_ne!(code, 0);
    assert!(stderr.contains("reading scene file /dev/zero: it is a character device"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

#[cfg(target_os = "linux")]
#[test]
fn mesh_to_a_full_device_fails() {
    let (code, stderr) = run_status(&[
        "mesh".as_ref(),
        shared_mesh("spot.obj").as_os_str(),
        "--tets".as_ref(),
        "2000".as_ref(),
        "-o".as_ref(),
        "/dev/full".as_ref(),
    ]);
    assert_ne!(code, 0);
    assert!(stderr.contains("writing /dev/full") && stderr.contains("No space left on device"), "{stderr}");
}

/// `prt precompute` then `prt eval` give what `bake --method prt` gives, bit for bit, for any
/// medium and lights; `--prt-cache` writes and reuses the same precompute; a mesh at another
/// scale than the file's is refused by its key.
#[test]
fn prt_precompute_then_eval_equals_a_bake() {
    let dir = std::env::temp_dir().join(format!("transcut-prt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let spot = shared_mesh("spot.obj");
    let file = dir.join("spot.tcprt");
    let prt = ["--prt-samples", "12", "--prt-terms", "512"];
    let out = transcut()
        .args(["prt", "precompute", spot.to_str().unwrap(), "--scale", "10", "--json"])
        .args(prt)
        .arg("-o")
        .arg(&file)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((json["samples"].as_u64(), json["vertices"].as_u64()), (Some(4096), Some(2930)));
    let light = ["--medium", "skin1", "--light", "sun:dir=0,-1,-0.5,irradiance=3"];
    let (eval, baked, cached) = (dir.join("eval.npy"), dir.join("bake.npy"), dir.join("cached.npy"));
    let out = transcut()
        .args(["prt", "eval"])
        .arg(&file)
        .args([spot.to_str().unwrap(), "--scale", "10", "--json"])
        .args(light)
        .arg("-o")
        .arg(&eval)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["stats"]["precompute_loaded"].as_bool(), Some(true));
    let bake = |output: &std::path::Path, extra: &[&str]| {
        let out = transcut()
            .args(["bake", spot.to_str().unwrap(), "--scale", "10", "--method", "prt", "--json"])
            .args(prt)
            .args(light)
            .args(extra)
            .arg("-o")
            .arg(output)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()["stats"]["precompute_loaded"].as_bool()
    };
    assert_eq!(bake(&baked, &[]), Some(false));
    assert_eq!(std::fs::read(&eval).unwrap(), std::fs::read(&baked).unwrap());
    let cache = dir.join("cache");
    assert_eq!(bake(&cached, &["--prt-cache", cache.to_str().unwrap()]), Some(false));
    assert_eq!(bake(&cached, &["--prt-cache", cache.to_str().unwrap()]), Some(true));
    assert_eq!(std::fs::read(&cached).unwrap(), std::fs::read(&baked).unwrap());
    let entries: Vec<_> = std::fs::read_dir(&cache).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(entries.len(), 1);
    assert_eq!(std::fs::read(&entries[0]).unwrap(), std::fs::read(&file).unwrap(), "the cache holds what precompute wrote");

    let out = transcut().args(["prt", "eval"]).arg(&file).args([spot.to_str().unwrap(), "--scale", "11"]).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("another surface") && err.contains("spot.tcprt"), "{err}");
    let out = transcut().args(["prt", "eval"]).arg(dir.join("none.tcprt")).arg(&spot).output().unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("none.tcprt"));
    std::fs::remove_dir_all(&dir).ok();
}

/// A UV sphere of radius 10 as OBJ text with an equirectangular UV map (u = k/segments,
/// v = 1 − j/rings; the seam's texture coordinates duplicated at u = 1, the poles' per segment).
fn uv_sphere_obj(segments: usize, rings: usize) -> String {
    let mut text = String::from("v 0 0 10\n");
    for j in 1..rings {
        let theta = std::f64::consts::PI * j as f64 / rings as f64;
        for k in 0..segments {
            let phi = std::f64::consts::TAU * k as f64 / segments as f64;
            text += &format!("v {} {} {}\n", 10.0 * theta.sin() * phi.cos(), 10.0 * theta.sin() * phi.sin(), 10.0 * theta.cos());
        }
    }
    text += "v 0 0 -10\n";
    // vt index (1-based) of ring j (0..=rings), column k (0..=segments; the poles use k + ½).
    let stride = segments + 1;
    for j in 0..=rings {
        for k in 0..=segments {
            let u = if j == 0 || j == rings { (k as f64 + 0.5) / segments as f64 } else { k as f64 / segments as f64 };
            text += &format!("vt {u} {}\n", 1.0 - j as f64 / rings as f64);
        }
    }
    let t = |j: usize, k: usize| 1 + j * stride + k;
    let v = |j: usize, k: usize| 2 + (j - 1) * segments + k % segments;
    let south = 2 + (rings - 1) * segments;
    for k in 0..segments {
        text += &format!("f 1/{} {}/{} {}/{}\n", t(0, k), v(1, k), t(1, k), v(1, k + 1), t(1, k + 1));
        for j in 1..rings - 1 {
            let (a, b, c, d) = (v(j, k), v(j + 1, k), v(j + 1, k + 1), v(j, k + 1));
            text += &format!("f {a}/{} {b}/{} {c}/{} {d}/{}\n", t(j, k), t(j + 1, k), t(j + 1, k + 1), t(j, k + 1));
        }
        text += &format!(
            "f {}/{} {south}/{} {}/{}\n",
            v(rings - 1, k),
            t(rings - 1, k),
            t(rings, k),
            v(rings - 1, k + 1),
            t(rings - 1, k + 1)
        );
    }
    text
}

/// `transcut bake --uv-texture`: a uniformly lit marble sphere's texture is the closed form at
/// every texel, as EXR (linear) and PNG (sRGB); misuse is refused before the bake.
#[test]
fn bake_writes_a_uv_texture_of_the_solution() {
    use transcut::optics::{f_ext, Medium, UniformSphere};
    let dir = std::env::temp_dir().join(format!("transcut-cli-texture-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("ball.obj");
    std::fs::write(&obj, uv_sphere_obj(32, 16)).unwrap();
    let bake = |out: &std::path::Path, extra: &[&str]| {
        transcut()
            .arg("bake")
            .arg(&obj)
            .args(["--medium", "marble", "--scale", "1", "--light", "env:radiance=1", "--tets", "30000", "--json"])
            .args(extra)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap()
    };
    let marble = Medium::preset("marble").unwrap();
    let q = std::f64::consts::PI * (1.0 - f_ext(marble.eta));
    let expect = UniformSphere::new(marble, 10.0, [q; 3]).unwrap().surface_radiance(1.0);

    let exr = dir.join("ball.exr");
    let out = bake(&exr, &["--uv-texture", "64"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["texture"]["width"], 64);
    assert_eq!(json["texture"]["margin"], 1);
    // All but the gaps between the poles' triangles (the equirectangular map's top and bottom
    // rows), which the margin of 1 texel pads.
    let covered = json["texture"]["covered_texels"].as_u64().unwrap();
    assert!((3_800..4_096).contains(&covered), "{covered}");
    let image = image::open(&exr).unwrap().into_rgba32f();
    assert_eq!(image.dimensions(), (64, 64));
    let filled: Vec<_> = image.pixels().filter(|p| p[3] == 1.0).collect();
    assert!(filled.len() as u64 > covered, "the margin pads the islands");
    for p in filled {
        for c in 0..3 {
            assert!((f64::from(p[c]) / expect[c] - 1.0).abs() < 0.02, "{p:?} vs {expect:?}");
        }
    }

    let png = dir.join("ball.png");
    let out = bake(&png, &["--uv-texture", "16", "--texture-margin", "0"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let image = image::open(&png).unwrap().into_rgba8();
    let srgb = |x: f64| if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
    for p in image.pixels().filter(|p| p[3] == 255) {
        for c in 0..3 {
            let level = 255.0 * srgb(expect[c]);
            assert!((f64::from(p[c]) - level).abs() <= 3.0, "{p:?} vs {level}");
        }
    }

    // Refused before the bake, naming what is wrong.
    let out = bake(&dir.join("ball.ply"), &["--uv-texture", "16"]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains(".exr"));
    std::fs::write(dir.join("bare.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n").unwrap();
    let out = transcut().arg("bake").arg(dir.join("bare.obj")).args(["--uv-texture", "16", "-o"]).arg(&exr).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("no texture coordinate"), "{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `transcut bake --method polygrid`: a uniformly lit marble sphere (a fine UV sphere) within a
/// few percent of the closed form at every vertex, the polygrid's statistics in the JSON and
/// the human output, and its options refused with another method.
#[test]
fn bake_by_polygrid_reports_its_grid() {
    use transcut::optics::{f_ext, Medium, UniformSphere};
    let dir = std::env::temp_dir().join(format!("transcut-cli-polygrid-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("ball.obj");
    std::fs::write(&obj, uv_sphere_obj(96, 48)).unwrap();
    let raw = dir.join("ball.raw");
    let bake = |extra: &[&str]| {
        transcut()
            .arg("bake")
            .arg(&obj)
            .args(["--medium", "marble", "--scale", "1", "--light", "env:radiance=1", "--method", "polygrid"])
            .args(["--polygrid-nodes", "20000", "--backend", "cpu", "--tolerance", "1e-9", "-o"])
            .arg(&raw)
            .args(extra)
            .output()
            .unwrap()
    };
    let out = bake(&["--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let stats = &json["stats"];
    assert_eq!(stats["method"], "polygrid");
    let p = &stats["polygrid"];
    assert_eq!(p["resolution"], 8);
    let count = |key: &str| p[key].as_u64().unwrap_or_else(|| panic!("{key}: {p}"));
    assert!(count("cubes") >= 8 && count("cells") >= count("cubes"), "{p}");
    assert!((5_000..60_000).contains(&count("nodes")), "{p}");
    assert!(p["cube_mm"].as_f64().unwrap() > 0.0);
    let (min, mean) =
        (p["quality"]["min_scaled_jacobian"].as_f64().unwrap(), p["quality"]["mean_scaled_jacobian"].as_f64().unwrap());
    assert!(min > 0.0 && min <= mean && mean <= 1.0, "{p}");
    let marble = Medium::preset("marble").unwrap();
    let q = std::f64::consts::PI * (1.0 - f_ext(marble.eta));
    let expect = UniformSphere::new(marble, 10.0, [q; 3]).unwrap().surface_radiance(1.0);
    let bytes = std::fs::read(&raw).unwrap();
    assert_eq!(bytes.len(), 4 * 3 * (2 + 96 * 47));
    for (k, c) in bytes.chunks_exact(4).map(|b| f64::from(f32::from_le_bytes(b.try_into().unwrap()))).enumerate() {
        let want = expect[k % 3];
        assert!((c / want - 1.0).abs() < 0.03, "vertex {} channel {}: {c} vs {want}", k / 3, k % 3);
    }
    assert!(p["lsq"].is_null(), "{p}");
    let out = bake(&[]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.contains("baked by polygrid") && text.contains("cubes of"), "{text}");
    // The paper's stencil: its diagnostics in the JSON and the text; its radiance within 3% of
    // the closed form on average (measured 0.5–1.5% per channel).
    let out = bake(&["--polygrid-stencil", "paper-lsq", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let l = &json["stats"]["polygrid"]["lsq"];
    let stencil_nodes = l["stencil_nodes"].as_u64().unwrap_or_else(|| panic!("{l}"));
    assert!(stencil_nodes > 1000 && l["p1_nodes"].as_u64().unwrap() < stencil_nodes / 10, "{l}");
    let bytes = std::fs::read(&raw).unwrap();
    let values: Vec<f64> = bytes.chunks_exact(4).map(|b| f64::from(f32::from_le_bytes(b.try_into().unwrap()))).collect();
    for (c, want) in expect.iter().enumerate() {
        let mean = values.iter().skip(c).step_by(3).map(|v| (v / want - 1.0).abs()).sum::<f64>() / (values.len() / 3) as f64;
        assert!(mean < 0.03, "channel {c}: mean error {mean}");
    }
    let out = bake(&["--polygrid-stencil", "paper-lsq"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && text.contains("the paper's stencil:") && text.contains("on P1's weights"), "{text}");
    let out = transcut().arg("bake").arg(&obj).args(["--polygrid-resolution", "4"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("--polygrid-resolution is an option of the polygrid method"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
