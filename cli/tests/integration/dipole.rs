//! The hierarchical dipole from the command line: `bake --method hierarchical-dipole`,
//! `animate` over frames of a deforming sphere against a bake of each frame, and the refusals
//! (another topology, another method's options, a method that cannot deform).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use transcut::mesh::icosphere;
use transcut::DVec3;

fn transcut(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_transcut")).args(args).output().unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A fresh temporary folder for one test.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("transcut-dipole-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes the triangles `triangles` over `positions` as OBJ.
fn write_obj(path: &Path, positions: &[DVec3], triangles: &[[u32; 3]]) {
    let mut text = String::new();
    for p in positions {
        text.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
    }
    for t in triangles {
        text.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    std::fs::write(path, text).unwrap();
}

/// Frame `k` of a sphere of radius 10 (mm) with 1,280 triangles, squashed and bulged more at
/// every frame (every vertex moves).
fn frame(k: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let sphere = icosphere(10.0, 3);
    let s = 0.15 * k as f64;
    let positions =
        sphere.positions().iter().map(|p| DVec3::new(p.x * (1.0 + s), p.y, p.z * (1.0 - 0.5 * s + 0.02 * p.x))).collect();
    (positions, sphere.triangles().to_vec())
}

/// The float32 array of a .npy file and its shape.
fn read_npy(path: &Path) -> (Vec<usize>, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap();
    assert!(bytes.starts_with(b"\x93NUMPY\x01\x00"));
    let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    assert_eq!((10 + header_len) % 64, 0);
    let header = String::from_utf8_lossy(&bytes[10..10 + header_len]).into_owned();
    assert!(header.contains("'descr': '<f4'"), "{header}");
    let shape = header.split("'shape': (").nth(1).unwrap().split(')').next().unwrap();
    let shape: Vec<usize> = shape.split(',').filter(|s| !s.trim().is_empty()).map(|s| s.trim().parse().unwrap()).collect();
    let data: Vec<f32> = bytes[10 + header_len..].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
    assert_eq!(data.len(), shape.iter().product::<usize>());
    (shape, data)
}

const SUN: &str = "sun:dir=0,-1,-1,irradiance=3";

#[test]
fn bake_with_the_dipole_writes_radiance_and_its_statistics() {
    let dir = temp_dir("bake");
    let (positions, triangles) = frame(0);
    let obj = dir.join("sphere.obj");
    write_obj(&obj, &positions, &triangles);
    let npy = dir.join("sphere.npy");
    let out = transcut(&[
        "bake",
        obj.to_str().unwrap(),
        "--method",
        "hierarchical-dipole",
        "--theta",
        "0.3",
        "--light",
        SUN,
        "--json",
        "-o",
        npy.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["stats"]["method"], "hierarchical-dipole");
    assert_eq!(json["dipole"]["triangles"].as_u64(), Some(1280));
    assert!(json["dipole"]["links"].as_u64().unwrap() > json["dipole"]["near_links"].as_u64().unwrap());
    let (shape, data) = read_npy(&npy);
    assert_eq!(shape, [positions.len(), 3]);
    assert!(data.iter().all(|x| x.is_finite() && *x >= 0.0));
    // Lit from +y+z: brighter there than on the far side.
    let lo = |v: usize| data[3 * v];
    let (lit, dark) = (0..positions.len()).partition::<Vec<usize>, _>(|&v| positions[v].y + positions[v].z > 0.0);
    let mean = |v: &[usize]| v.iter().map(|&i| lo(i)).sum::<f32>() / v.len() as f32;
    assert!(mean(&lit) > 2.0 * mean(&dark), "lit {} dark {}", mean(&lit), mean(&dark));
    // The human summary names links, not tets.
    let out = transcut(&["bake", obj.to_str().unwrap(), "--method", "hierarchical-dipole", "--mode", "render"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("hierarchical-dipole") && text.contains("links") && !text.contains("tets"), "{text}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn animate_equals_a_bake_of_every_frame() {
    let dir = temp_dir("animate");
    let mut paths = Vec::new();
    for k in 0..3 {
        let (positions, triangles) = frame(k);
        let path = dir.join(format!("frame{k}.obj"));
        write_obj(&path, &positions, &triangles);
        paths.push(path.to_str().unwrap().to_owned());
    }
    let npy = dir.join("frames.npy");
    let mut args = vec!["animate"];
    args.extend(paths.iter().map(String::as_str));
    args.extend(["--light", SUN, "--json", "-o", npy.to_str().unwrap()]);
    let out = transcut(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let frames = json["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 3);
    for (k, f) in frames.iter().enumerate() {
        assert_eq!(f["frame"].as_u64(), Some(k as u64 + 1));
        for key in ["total_ms", "light_ms", "refit_ms", "link_ms", "gather_ms", "push_ms", "links", "form_factors"] {
            assert!(f[key].as_f64().is_some_and(|x| x >= 0.0), "frame {k}: {key} in {f}");
        }
        assert!(f["links"].as_u64().unwrap() > 0);
    }
    assert!(json["options"].as_str().unwrap().contains("Incremental"), "{}", json["options"]);
    let (shape, animated) = read_npy(&npy);
    let vertices = frame(0).0.len();
    assert_eq!(shape, [3, vertices, 3]);

    for (k, path) in paths.iter().enumerate() {
        let single = dir.join(format!("bake{k}.npy"));
        let out = transcut(&["bake", path, "--method", "hierarchical-dipole", "--light", SUN, "-o", single.to_str().unwrap()]);
        assert!(out.status.success(), "{}", stderr(&out));
        let (_, baked) = read_npy(&single);
        let frame = &animated[k * vertices * 3..(k + 1) * vertices * 3];
        for c in 0..3 {
            let peak = baked.iter().skip(c).step_by(3).fold(0.0f32, |m, &x| m.max(x));
            let worst = (c..baked.len()).step_by(3).map(|i| (frame[i] - baked[i]).abs()).fold(0.0f32, f32::max) / peak;
            let moved = (c..baked.len()).step_by(3).map(|i| (animated[i] - baked[i]).abs()).fold(0.0f32, f32::max) / peak;
            eprintln!("frame {}, channel {c}: {worst:.1e} of the peak from its bake (frame 1 is {moved:.1e} off)", k + 1);
            // Frame 1 is the same bake (its form factors kept in f32 for the frames after); later
            // frames refit the trees that a bake builds afresh.
            let tolerance = if k == 0 { 1e-6 } else { 1e-2 };
            assert!(worst <= tolerance, "frame {}: channel {c} differs from its bake by {worst} of the peak", k + 1);
            assert!(k == 0 || moved > 5.0 * tolerance, "frame {}: the deformation should change the radiance", k + 1);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn animate_refuses_another_topology_and_methods_that_cannot_deform() {
    let dir = temp_dir("refuse");
    let (positions, triangles) = frame(0);
    let first = dir.join("first.obj");
    write_obj(&first, &positions, &triangles);
    let finer = icosphere(10.0, 2);
    let second = dir.join("second.obj");
    write_obj(&second, finer.positions(), finer.triangles());
    let npy = dir.join("out.npy");
    let out = transcut(&["animate", first.to_str().unwrap(), second.to_str().unwrap(), "-o", npy.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("frame 2") && err.contains("second.obj") && err.contains("162 vertices, the first frame 642"), "{err}");
    assert!(!npy.exists(), "nothing is written on failure");
    let out = transcut(&["animate", first.to_str().unwrap(), "--method", "transcut", "-o", npy.to_str().unwrap()]);
    let err = stderr(&out);
    assert!(!out.status.success() && err.contains("transcut method cannot deform"), "{err}");
    let out = transcut(&["animate", first.to_str().unwrap(), "-o", dir.join("out.ply").to_str().unwrap()]);
    assert!(!out.status.success() && stderr(&out).contains(".npy"), "{}", stderr(&out));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn options_of_another_method_are_refused_by_name() {
    for (args, words) in [
        (&["bake", "unused.obj", "--theta", "0.4"][..], &["--theta", "hierarchical-dipole", "not of transcut"][..]),
        (&["bake", "unused.obj", "--method", "transcut", "--mode", "render"], &["--mode", "hierarchical-dipole"]),
        (&["bake", "unused.obj", "--method", "hierarchical-dipole", "--tets", "1000"], &["--tets", "transcut"]),
        (&["animate", "unused.obj", "--solver", "pcg"], &["--solver", "transcut", "not of hierarchical-dipole"]),
        (&["bake", "unused.obj", "--method", "hierarchical-dipole", "--export-system", "dir"], &["--export-system"]),
        (&["bake", "unused.obj", "--method", "hierarchical-dipole", "--theta", "2"], &["theta", "(0, 1]"]),
        (&["bake", "unused.obj", "--method", "hierarchical-dipole", "--budget", "10"], &["--budget", "--mode incremental"]),
    ] {
        let out = transcut(args);
        let err = stderr(&out);
        assert!(!out.status.success() && words.iter().all(|w| err.contains(w)), "{args:?}: {err}");
    }
}

#[test]
fn render_bakes_a_scene_by_the_dipole() {
    let dir = temp_dir("render");
    let (positions, triangles) = frame(0);
    let obj = dir.join("sphere.obj");
    write_obj(&obj, &positions, &triangles);
    let scene = |bake: &str| {
        let path = dir.join("scene.toml");
        let text = format!(
            "[camera]\nposition = [0, 0, 60]\ntarget = [0, 0, 0]\nfov_deg = 35\nwidth = 64\nheight = 48\n\n[bake]\n{bake}\n\n\
             [[object]]\nmesh = \"{}\"\nmedium = \"marble\"\n\n[[light]]\nkind = \"sun\"\ndir = [0, -1, -1]\nirradiance = 3\n",
            obj.display()
        );
        std::fs::write(&path, text).unwrap();
        path
    };
    let png = dir.join("sphere.png");
    let render = |scene: &Path, extra: &[&str]| {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", png.to_str().unwrap(), "--json"];
        args.extend(extra);
        transcut(&args)
    };
    // The command line's method over a file written for TransCut.
    let out = render(&scene("tets = 60000"), &["--method", "hierarchical-dipole"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["objects"][0]["stats"]["method"], "hierarchical-dipole");
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // A file that chooses the dipole itself, with TransCut's tets: refused by name.
    let out = render(&scene("method = \"hierarchical-dipole\"\ntets = 60000"), &[]);
    let err = stderr(&out);
    assert!(!out.status.success() && err.contains("[bake] tets") && err.contains("not of hierarchical-dipole"), "{err}");
    let out = render(&scene("method = \"hierarchical-dipole\""), &["--theta", "0.6"]);
    assert!(out.status.success(), "{}", stderr(&out));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_scene_files_bake_table_sets_every_dipole_option_and_the_flags_override_it() {
    let dir = temp_dir("scene-keys");
    let (positions, triangles) = frame(0);
    let obj = dir.join("sphere.obj");
    write_obj(&obj, &positions, &triangles);
    let scene = |name: &str, bake: &str| {
        let path = dir.join(format!("{name}.toml"));
        let text = format!(
            "[camera]\nposition = [0, 0, 60]\ntarget = [0, 0, 0]\nfov_deg = 35\nwidth = 48\nheight = 36\n\n\
             [render]\nsamples = 1\n\n[bake]\n{bake}\n\n[[object]]\nmesh = \"{}\"\nmedium = \"marble\"\n\n\
             [[light]]\nkind = \"sun\"\ndir = [0, -1, -1]\nirradiance = 3\n",
            obj.display()
        );
        std::fs::write(&path, text).unwrap();
        path
    };
    // The image (linear EXR) of a render of `scene` with `extra` flags.
    let render = |scene: &Path, extra: &[&str]| -> Vec<u8> {
        let exr = dir.join("out.exr");
        std::fs::remove_file(&exr).ok();
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
        args.extend(extra);
        let out = transcut(&args);
        assert!(out.status.success(), "{args:?}: {}", stderr(&out));
        std::fs::read(&exr).unwrap()
    };
    let plain = scene("plain", "method = \"hierarchical-dipole\"");
    let keys = scene(
        "keys",
        "method = \"hierarchical-dipole\"\noracle = \"paper\"\neps1 = 0.3\neps2 = 0.3\nrule = \"paper\"\n\
         receivers = \"faces\"\nmode = \"incremental\"\nbudget = 1000",
    );
    let default = render(&plain, &[]);
    let flags = [
        "--oracle",
        "paper",
        "--eps1",
        "0.3",
        "--eps2",
        "0.3",
        "--rule",
        "paper",
        "--receivers",
        "faces",
        "--mode",
        "incremental",
        "--budget",
        "1000",
    ];
    let by_flags = render(&plain, &flags);
    let by_keys = render(&keys, &[]);
    // The keys reach the bake exactly as the flags do, and they change the radiance.
    assert!(by_keys == by_flags, "the file's keys render another image than the same flags");
    assert!(by_keys != default, "the paper oracle, rule and face receivers should change the image");
    // The flags override the keys: back to the defaults.
    let over = ["--oracle", "opening-angle", "--rule", "gl3", "--receivers", "vertices", "--mode", "on-the-fly"];
    assert!(render(&keys, &over) == default, "the flags did not override the file's keys");
    // One key at a time reaches the bake (each alone changes the image).
    for (key, value) in [("receivers", "\"faces\""), ("rule", "\"paper\""), ("theta", "0.8")] {
        let one = scene("one", &format!("method = \"hierarchical-dipole\"\n{key} = {value}"));
        assert!(render(&one, &[]) != default, "[bake] {key} = {value} did not change the image");
    }

    // Refusals name the key (and list the valid values).
    let refused = |bake: &str, words: &[&str]| {
        let path = scene("bad", bake);
        let out = transcut(&["render", path.to_str().unwrap(), "-o", dir.join("bad.png").to_str().unwrap()]);
        let err = stderr(&out);
        assert!(!out.status.success() && words.iter().all(|w| err.contains(w)), "{bake}: {err}");
        assert!(err.contains("bad.toml"), "the error names the scene file: {err}");
    };
    refused("receivers = \"faces\"", &["[bake] receivers is an option of the hierarchical-dipole method, not of transcut"]);
    refused("method = \"transcut\"\nbudget = 10", &["[bake] budget is an option of the hierarchical-dipole method"]);
    refused("method = \"hierarchical-dipole\"\nrule = \"simpson\"", &["[bake] rule", "'simpson'", "gl3, paper"]);
    refused("method = \"hierarchical-dipole\"\noracle = \"solid\"", &["[bake] oracle", "opening-angle, paper"]);
    refused("method = \"hierarchical-dipole\"\nreceivers = \"edges\"", &["[bake] receivers", "vertices, faces"]);
    refused("method = \"hierarchical-dipole\"\nbudget = 10", &["[bake] budget", "mode = \"incremental\""]);
    refused("method = \"hierarchical-dipole\"\neps1 = 0.1", &["[bake] eps1", "oracle = \"paper\""]);
    refused("method = \"hierarchical-dipole\"\noracle = \"paper\"\ntheta = 0.3", &["[bake] theta", "eps1 and eps2"]);
    refused("method = \"hierarchical-dipole\"\noracle = \"paper\"\neps2 = -1", &["eps2"]);
    refused("method = \"hierarchical-dipole\"\nbudget = 0", &["[bake] budget = 0"]);
    std::fs::remove_dir_all(&dir).ok();
}
