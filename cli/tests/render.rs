//! `transcut render` on every example scene at a reduced size, and scene-file errors.

use std::path::{Path, PathBuf};
use std::process::Command;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples")
}

fn out_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("render-tests");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `transcut render` and returns (success, stderr).
fn transcut_render(scene: &Path, output: &Path, extra: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_transcut"))
        .arg("render")
        .arg(scene)
        .arg("-o")
        .arg(output)
        .args(["--width", "96", "--height", "72", "--tets", "8000", "--json"])
        .args(extra)
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn render_example(name: &str, ext: &str) -> PathBuf {
    let output = out_dir().join(format!("{name}.{ext}"));
    let (ok, stderr) = transcut_render(&examples().join(format!("{name}.toml")), &output, &[]);
    assert!(ok, "{name}: {stderr}");
    output
}

/// Checks size, finiteness and coverage; returns the RGBA image.
fn check_png(path: &Path) -> image::RgbaImage {
    let img = image::open(path).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (96, 72), "{}", path.display());
    assert_eq!(img.get_pixel(0, 0)[3], 0, "{}: corner covered", path.display());
    let covered = img.pixels().filter(|p| p[3] > 0).count();
    assert!(covered > 50, "{}: only {covered} object pixels", path.display());
    assert!(img.pixels().any(|p| p[3] > 0 && (p[0] > 5 || p[1] > 5 || p[2] > 5)), "{}: object is black", path.display());
    img
}

#[test]
fn bunny_is_brighter_on_the_lit_side() {
    let img = check_png(&render_example("bunny_marble", "png"));
    // The sun comes from the left (it travels along +x): split the object's pixels at their
    // mean column and compare mean luminance.
    let pixels: Vec<(u32, f64)> = img
        .enumerate_pixels()
        .filter(|(_, _, p)| p[3] == 255)
        .map(|(x, _, p)| (x, 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])))
        .collect();
    let mid = pixels.iter().map(|p| f64::from(p.0)).sum::<f64>() / pixels.len() as f64;
    let mean = |left: bool| {
        let v: Vec<f64> = pixels.iter().filter(|p| (f64::from(p.0) < mid) == left).map(|p| p.1).collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (lit, far) = (mean(true), mean(false));
    assert!(lit > far * 1.05, "lit side {lit:.1} vs far side {far:.1}");
}

#[test]
fn other_examples_render() {
    for name in ["spot_skin_backlit", "suzanne_jade_hdr", "layered_block", "bunny_cut", "jade_block_paint"] {
        check_png(&render_example(name, "png"));
    }
}

#[test]
fn exr_output_is_linear() {
    let path = render_example("layered_block", "exr");
    let img = image::open(&path).unwrap().to_rgba32f();
    assert_eq!(img.dimensions(), (96, 72));
    assert!(img.pixels().all(|p| p.0.iter().all(|v| v.is_finite())));
    assert_eq!(img.get_pixel(0, 0)[3], 0.0);
    let object: Vec<f32> = img.pixels().filter(|p| p[3] == 1.0).map(|p| p[0].max(p[1]).max(p[2])).collect();
    assert!(!object.is_empty());
    // Linear, not tone-mapped to [0, 1] sRGB codes: positive values, and the PNG of the same
    // scene differs (its sRGB curve lifts dark values well above the linear ones).
    assert!(object.iter().all(|&v| v >= 0.0));
    let max = object.iter().copied().fold(0.0f32, f32::max);
    assert!(max > 0.0);
    let png = image::open(render_example("layered_block", "png")).unwrap().to_rgba8();
    let dark = img
        .enumerate_pixels()
        .filter(|(_, _, p)| p[3] == 1.0 && p[1] > 0.01 && p[1] < 0.1)
        .map(|(x, y, p)| (f64::from(p[1]), f64::from(png.get_pixel(x, y)[1]) / 255.0))
        .collect::<Vec<_>>();
    for (linear, srgb) in dark.iter().take(20) {
        assert!(srgb > linear, "linear {linear} vs sRGB {srgb}");
    }
}

fn write_scene(name: &str, text: &str) -> PathBuf {
    let path = out_dir().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

const HEAD: &str = "[camera]\nposition = [0, 0, 150]\ntarget = [0, 0, 0]\nfov_deg = 35\nwidth = 64\nheight = 48\n";

fn expect_error(name: &str, text: &str, words: &[&str]) {
    let scene = write_scene(name, text);
    let (ok, stderr) = transcut_render(&scene, &out_dir().join("never.png"), &[]);
    assert!(!ok, "{name} succeeded");
    for w in words.iter().chain([&name]) {
        assert!(stderr.contains(w), "{name}: '{w}' not in: {stderr}");
    }
}

#[test]
fn scene_file_errors_name_the_file_and_problem() {
    let block = examples().join("box.obj");
    let object = format!("[[object]]\nmesh = \"{}\"\nmedium = \"marble\"\n", block.display());
    expect_error("unknown_key.toml", &format!("{HEAD}[render]\nexposure = 1\n{object}"), &["exposure", "render"]);
    expect_error("unknown_object_key.toml", &format!("{HEAD}{object}colour = 1\n"), &["colour"]);
    expect_error(
        "unknown_light_key.toml",
        &format!("{HEAD}{object}[[light]]\nkind = \"sun\"\ndir = [0,0,-1]\nirradiance = 1\npos = [0,0,0]\n"),
        &["pos", "light 1"],
    );
    expect_error(
        "missing_mesh.toml",
        &format!("{HEAD}[[object]]\nmesh = \"no-such.obj\"\nmedium = \"marble\"\n"),
        &["no-such.obj", "not found"],
    );
    expect_error(
        "bad_preset.toml",
        &format!("{HEAD}[[object]]\nmesh = \"{}\"\nmedium = \"plutonium\"\n", block.display()),
        &["plutonium", "medium"],
    );
    expect_error(
        "bad_medium.toml",
        &format!("{HEAD}[[object]]\nmesh = \"{}\"\nmedium = {{ sigma_a = [0.1, 0.1], sigma_s = 1 }}\n", block.display()),
        &["sigma_a", "medium"],
    );
    expect_error("no_camera.toml", &object, &["camera"]);
}

/// `render` to a full device fails, naming the file once; so does `samples = 0`.
#[cfg(target_os = "linux")]
#[test]
fn write_errors_and_zero_samples_fail() {
    let block = examples().join("box.obj");
    let object = format!("[[object]]\nmesh = \"{}\"\nmedium = \"marble\"\n", block.display());
    let scene = write_scene("full_device.toml", &format!("{HEAD}{object}"));
    for ext in ["png", "exr"] {
        // A symlink named .png / .exr to /dev/full: the extension chooses the format.
        let link = out_dir().join(format!("full.{ext}"));
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink("/dev/full", &link).unwrap();
        let (ok, stderr) = transcut_render(&scene, &link, &[]);
        assert!(!ok, "{ext}: writing to /dev/full succeeded");
        assert!(stderr.contains("No space left on device"), "{ext}: {stderr}");
        assert_eq!(stderr.matches(&format!("full.{ext}")).count(), 1, "{ext}: {stderr}");
    }
    expect_error("zero_samples.toml", &format!("{HEAD}[render]\nsamples = 0\n{object}"), &["samples = 0", "[render]"]);
}

/// An example with its `[[edit]]` tables dropped and its mesh path made absolute, written to the
/// output folder: the same scene, unedited.
fn unedited(name: &str) -> PathBuf {
    let text = std::fs::read_to_string(examples().join(format!("{name}.toml"))).unwrap();
    let text = &text[..text.find("[[edit]]").expect("the example has edits")];
    let text: String = text
        .lines()
        .map(|l| match l.strip_prefix("mesh = \"") {
            Some(rest) => format!("mesh = \"{}/{rest}", examples().display()),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n");
    write_scene(&format!("{name}_unedited.toml"), &text)
}

fn render_scene(scene: &Path, name: &str) -> image::RgbaImage {
    let output = out_dir().join(format!("{name}.png"));
    let (ok, stderr) = transcut_render(scene, &output, &[]);
    assert!(ok, "{name}: {stderr}");
    check_png(&output)
}

fn coverage(img: &image::RgbaImage) -> usize {
    img.pixels().filter(|p| p[3] > 0).count()
}

fn mean_luminance(img: &image::RgbaImage) -> f64 {
    let v: Vec<f64> = img
        .pixels()
        .filter(|p| p[3] == 255)
        .map(|p| 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]))
        .collect();
    v.iter().sum::<f64>() / v.len() as f64
}

#[test]
fn edit_examples_differ_from_their_unedited_scenes() {
    // The cut removes the front of the bunny: fewer object pixels.
    let cut = check_png(&render_example("bunny_cut", "png"));
    let whole = render_scene(&unedited("bunny_cut"), "bunny_cut_unedited");
    let (a, b) = (coverage(&cut), coverage(&whole));
    assert!(a < b * 95 / 100 && a > b / 5, "cut bunny covers {a} pixels, whole bunny {b}");
    // The painted ink absorbs: a darker block, with the same outline.
    let painted = check_png(&render_example("jade_block_paint", "png"));
    let clean = render_scene(&unedited("jade_block_paint"), "jade_block_unedited");
    let (a, b) = (coverage(&painted), coverage(&clean));
    // (An edited object is drawn from its tet mesh's boundary, the unedited one from the input
    // surface: the outlines differ by the mesher's surface approximation only.)
    assert!(a.abs_diff(b) <= b / 20, "painting changed the outline: {a} vs {b} pixels");
    // The stroke is a band across the top face: a part of the block, not all of it, at least
    // 10% darker; nowhere is the painted block much lighter.
    let (dark, light) = (mean_luminance(&painted), mean_luminance(&clean));
    assert!(dark < light, "painted {dark:.1} vs clean {light:.1}");
    let band = changed_pixels(&painted, &clean, |p, c| p < 0.9 * c);
    let lighter = changed_pixels(&painted, &clean, |p, c| p > 1.1 * c + 2.0);
    eprintln!("jade_block_paint: {band} of {b} pixels 10% darker, {lighter} lighter");
    assert!(band >= b / 200 && band <= b / 4, "{band} of {b} pixels 10% darker");
    assert!(lighter <= band / 10, "{lighter} pixels lighter, {band} darker");
}

/// The pixels opaque in both images whose luminance in `a` and `b` satisfies `test`.
fn changed_pixels(a: &image::RgbaImage, b: &image::RgbaImage, test: impl Fn(f64, f64) -> bool) -> usize {
    let y = |p: &image::Rgba<u8>| 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]);
    a.pixels().zip(b.pixels()).filter(|(p, q)| p[3] == 255 && q[3] == 255 && test(y(p), y(q))).count()
}

/// A horizontal stroke across the middle of the image, drawn left to right, swept along the
/// camera's rays is the plane y = 0 through the eye: keep = "left" keeps the upper half of the
/// bunny, "right" the lower half.
#[test]
fn cut_stroke_keeps_the_side_it_names() {
    let bunny = examples().join("../assets/meshes/stanford-bunny.obj");
    let scene = |keep: &str| {
        format!(
            "[camera]\nposition = [0, 0, 150]\ntarget = [0, 0, 0]\nfov_deg = 30\nwidth = 96\nheight = 72\n[render]\nground = false\n\
             [[object]]\nmesh = \"{}\"\nmedium = \"marble\"\nfit_size_mm = 60\n[[light]]\nkind = \"sun\"\ndir = [0, 0, -1]\nirradiance = 3\n\
             [[edit]]\nkind = \"cut_stroke\"\nstroke = [[-10, 36], [50, 36], [106, 36]]\nkeep = \"{keep}\"\n",
            bunny.display()
        )
    };
    // Pixel rows 34..38 around the stroke are left out: the cut face is seen edge-on there, and
    // the kept tets reach the cut surface only within the snapping tolerance.
    let halves = |img: &image::RgbaImage| {
        let upper = img.enumerate_pixels().filter(|(_, y, p)| *y < 34 && p[3] > 0).count();
        let lower = img.enumerate_pixels().filter(|(_, y, p)| *y >= 38 && p[3] > 0).count();
        (upper, lower)
    };
    let left = render_scene(&write_scene("stroke_left.toml", &scene("left")), "stroke_left");
    let (upper, lower) = halves(&left);
    assert!(upper > 100 && lower * 10 < upper, "keep = left: {upper} pixels above the stroke, {lower} below");
    let right = render_scene(&write_scene("stroke_right.toml", &scene("right")), "stroke_right");
    let (upper, lower) = halves(&right);
    assert!(lower > 100 && upper * 10 < lower, "keep = right: {upper} pixels above the stroke, {lower} below");
}

#[test]
fn edit_errors_name_the_edit_and_key() {
    let block = examples().join("box.obj");
    let object = format!("[[object]]\nmesh = \"{}\"\nname = \"block\"\nmedium = \"jade\"\nfit_size_mm = 80\n", block.display());
    let fracture = "[[edit]]\nkind = \"fracture\"\n";
    expect_error(
        "edit_missing_key.toml",
        &format!("{HEAD}{object}{fracture}[[edit]]\nkind = \"cut_plane\"\npoint = [0, 0, 0]\n"),
        &["edit 2", "cut_plane", "'normal'"],
    );
    expect_error(
        "edit_bad_object.toml",
        &format!("{HEAD}{object}[[edit]]\nkind = \"fracture\"\nobject = \"bunny\"\n"),
        &["edit 1", "no object named 'bunny'", "block"],
    );
    // Caught by the core when the edit runs: a paint medium whose η differs from the object's.
    expect_error(
        "edit_paint_eta.toml",
        &format!("{HEAD}{object}[[edit]]\nkind = \"paint\"\npoints = [[0, 16.33, 0]]\nradius = 3\nmedium = \"marble\"\n"),
        &["edit 1", "paint"],
    );
    // Everything removed.
    expect_error(
        "edit_cut_all.toml",
        &format!("{HEAD}{object}[[edit]]\nkind = \"cut_plane\"\npoint = [0, 100, 0]\nnormal = [0, 1, 0]\n"),
        &["edit 1", "cut_plane"],
    );
}
