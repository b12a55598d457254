//! Tests of the CPU renderer against closed forms: a unit-radiance sphere seen head-on (centre
//! value, Fresnel darkening towards the silhouette, coverage), z-buffering, output files,
//! determinism across thread counts, and input validation.

use std::f64::consts::{FRAC_1_SQRT_2, PI};
use std::path::PathBuf;

use transcut::render::{
    render, view_factor, AlphaMode, Camera, Filter, GroundPlane, Image, RenderError, RenderObject, RenderOptions, RenderScene,
    SamplePattern, Shading, SpecularLight, ToneMap,
};
use transcut::DVec3;

const ETA: f64 = 1.3;

/// A UV sphere of radius `r` at the origin: `rings` latitude bands and `segments` longitude
/// segments, poles on ±z, triangles counter-clockwise seen from outside. Returns positions,
/// triangles and the exact normals.
fn uv_sphere(r: f64, rings: u32, segments: u32) -> (Vec<DVec3>, Vec<[u32; 3]>, Vec<DVec3>) {
    let mut normals = vec![DVec3::Z];
    for i in 1..rings {
        let theta = PI * f64::from(i) / f64::from(rings);
        for j in 0..segments {
            let phi = 2.0 * PI * f64::from(j) / f64::from(segments);
            normals.push(DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()));
        }
    }
    normals.push(DVec3::NEG_Z);
    let south = normals.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * segments + j % segments;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([south, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    let positions = normals.iter().map(|n| *n * r).collect();
    (positions, triangles, normals)
}

struct Sphere {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    normals: Vec<DVec3>,
    radiance: Vec<[f64; 3]>,
}

impl Sphere {
    fn new(r: f64, rings: u32, segments: u32) -> Self {
        let (positions, triangles, normals) = uv_sphere(r, rings, segments);
        let radiance = vec![[1.0; 3]; positions.len()];
        Sphere { positions, triangles, normals, radiance }
    }

    fn object(&self) -> RenderObject<'_> {
        RenderObject {
            positions: &self.positions,
            triangles: &self.triangles,
            radiance: &self.radiance,
            normals: Some(&self.normals),
            eta: ETA,
        }
    }
}

/// A camera on the +z axis at distance `d` looking at the origin.
fn head_on(d: f64, fov: f64, w: u32, h: u32) -> Camera {
    Camera { position: DVec3::new(0.0, 0.0, d), target: DVec3::ZERO, up: DVec3::Y, vertical_fov_deg: fov, width: w, height: h }
}

fn scene<'a>(camera: Camera, objects: Vec<RenderObject<'a>>) -> RenderScene<'a> {
    RenderScene { camera, objects, lights: vec![], environment: None, ground: None }
}

/// Radius in pixels of the silhouette of a sphere of radius r at distance d on the axis: the
/// tangent cone has half-angle asin(r/d), so the image radius is f tan(asin(r/d)) =
/// f r / √(d² − r²), f = (H/2) / tan(fov/2).
fn silhouette_radius_px(r: f64, d: f64, fov: f64, h: u32) -> f64 {
    let f = 0.5 * f64::from(h) / (0.5 * fov.to_radians()).tan();
    f * r / (d * d - r * r).sqrt()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("transcut-render-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn head_on_sphere_centre_equals_the_vertex_radiance() {
    let sphere = Sphere::new(1.0, 128, 256);
    let cam = head_on(5.0, 30.0, 256, 256);
    let img = render(&scene(cam, vec![sphere.object()]), &RenderOptions::default()).unwrap();
    // Pixels (127, 127) … (128, 128) touch the optical axis; all see n·ωo ≈ 1, Ft ratio 1.
    for (x, y) in [(127, 127), (128, 128), (127, 128), (128, 127)] {
        let p = img.pixel(x, y).unwrap();
        for c in &p[..3] {
            assert!((f64::from(*c) - 1.0).abs() < 1e-3, "pixel ({x}, {y}) = {p:?}");
        }
        assert_eq!(p[3], 1.0);
    }
}

#[test]
fn silhouette_darkens_by_the_fresnel_ratio() {
    let sphere = Sphere::new(1.0, 128, 256);
    let (d, fov, size) = (5.0, 30.0, 256);
    let cam = head_on(d, fov, size, size);
    // One sample at each pixel centre, so a pixel is the closed form at that point.
    let options = RenderOptions { samples: SamplePattern::Centre, filter: Filter::Box, ..Default::default() };
    let img = render(&scene(cam, vec![sphere.object()]), &options).unwrap();
    let r_px = silhouette_radius_px(1.0, d, fov, size);
    let centre = img.pixel(128, 128).unwrap()[0];
    let mut checked = 0;
    // Pixels on the horizontal and diagonal rays from the centre, from 50% to 95% of the radius.
    for frac in [0.5, 0.7, 0.8, 0.9, 0.95] {
        for dir in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (FRAC_1_SQRT_2, FRAC_1_SQRT_2)] {
            let u = 128.0 + dir.0 * frac * r_px;
            let v = 128.0 + dir.1 * frac * r_px;
            let (px, py) = (u.floor() as u32, v.floor() as u32);
            let got = f64::from(img.pixel(px, py).unwrap()[0]);
            // Closed form at the pixel centre: the ray meets the exact sphere at x, the normal
            // is x / r, and the view factor is Ft(η, n·ωo) / Ft(η, 1).
            let dir = cam.ray_direction(f64::from(px) + 0.5, f64::from(py) + 0.5).unwrap();
            let o = cam.position;
            let b = o.dot(dir);
            let t = -b - (b * b - (o.length_squared() - 1.0)).sqrt();
            let hit = o + t * dir;
            let cos = hit.normalize().dot(-dir);
            let expect = view_factor(ETA, cos);
            assert!(
                (got - expect).abs() < 5e-4,
                "at {frac} of the radius, pixel ({px}, {py}): cos θo = {cos:.4}, got {got:.5}, Ft ratio {expect:.5}"
            );
            assert!(got < f64::from(centre));
            checked += 1;
        }
    }
    assert_eq!(checked, 20);
    // Darkening is clearly visible near the rim: Ft ratio ≈ 0.85 at 95% of the radius.
    let rim = f64::from(img.pixel((128.0 + 0.95 * r_px) as u32, 128).unwrap()[0]);
    assert!(rim < 0.9, "{rim}");
}

#[test]
fn alpha_coverage_is_the_projected_disc_area() {
    let sphere = Sphere::new(1.0, 96, 192);
    let (d, fov, w, h) = (4.0, 40.0, 320, 240);
    let cam = head_on(d, fov, w, h);
    let r_px = silhouette_radius_px(1.0, d, fov, h);
    let disc = PI * r_px * r_px;
    for (samples, filter) in
        [(SamplePattern::Grid(3), Filter::Tent), (SamplePattern::RotatedGrid4, Filter::Box), (SamplePattern::Centre, Filter::Box)]
    {
        let options = RenderOptions { samples, filter, ..Default::default() };
        let img = render(&scene(cam, vec![sphere.object()]), &options).unwrap();
        let covered: f64 = img.rgba.iter().map(|p| f64::from(p[3])).sum();
        assert!((covered / disc - 1.0).abs() < 0.02, "{samples:?} {filter:?}: coverage {covered:.1} px² vs π r² = {disc:.1} px²");
        // Fractional alpha only along the rim.
        let partial = img.rgba.iter().filter(|p| p[3] > 0.0 && p[3] < 1.0).count();
        assert!((partial as f64) < 4.0 * 2.0 * PI * r_px, "{partial}");
        assert!(img.rgba.iter().all(|p| (0.0..=1.0).contains(&p[3])));
    }
}

#[test]
fn empty_scene_is_all_background() {
    let bg = [0.1, 0.2, 0.3];
    let options = RenderOptions { background: bg, ..Default::default() };
    let cam = head_on(5.0, 45.0, 70, 50);
    let img = render(&scene(cam, vec![]), &options).unwrap();
    assert_eq!((img.width, img.height, img.rgba.len()), (70, 50, 3500));
    let expect = [bg[0] as f32, bg[1] as f32, bg[2] as f32, 0.0];
    assert!(img.rgba.iter().all(|p| *p == expect));

    // An object entirely behind the camera draws nothing either.
    let sphere = Sphere::new(1.0, 16, 32);
    let mut positions = sphere.positions.clone();
    for p in &mut positions {
        p.z += 20.0;
    }
    let behind = RenderObject { positions: &positions, ..sphere.object() };
    let img = render(&scene(cam, vec![behind]), &options).unwrap();
    assert!(img.rgba.iter().all(|p| *p == expect));
}

fn flat_object<'a>(p: &'a [DVec3], t: &'a [[u32; 3]], r: &'a [[f64; 3]]) -> RenderObject<'a> {
    // η = 1: no interface, so the view factor is 1 at every angle.
    RenderObject { positions: p, triangles: t, radiance: r, normals: None, eta: 1.0 }
}

#[test]
fn triangle_behind_another_is_hidden() {
    // Two overlapping triangles facing the camera; the near one is smaller and darker.
    let far = [DVec3::new(-2.0, -2.0, -1.0), DVec3::new(2.0, -2.0, -1.0), DVec3::new(0.0, 2.0, -1.0)];
    let near = [DVec3::new(-1.0, -1.0, 0.5), DVec3::new(1.0, -1.0, 0.5), DVec3::new(0.0, 1.0, 0.5)];
    let (front, back) = ([[0u32, 1, 2]], [[0u32, 2, 1]]);
    let (bright, dark) = ([[0.9, 0.8, 0.7]; 3], [[0.2, 0.3, 0.4]; 3]);
    let far_obj = flat_object(&far, &front, &bright);
    let near_obj = flat_object(&near, &front, &dark);
    let cam = head_on(6.0, 50.0, 64, 64);
    for objects in [vec![far_obj, near_obj], vec![near_obj, far_obj]] {
        let img = render(&scene(cam, objects), &RenderOptions::default()).unwrap();
        let c = img.pixel(32, 34).unwrap();
        assert!((c[0] - 0.2).abs() < 1e-6 && (c[1] - 0.3).abs() < 1e-6 && (c[2] - 0.4).abs() < 1e-6, "{c:?}");
        // Outside the near triangle but inside the far one: the far one shows.
        let p = cam.project(DVec3::new(0.0, -1.5, -1.0)).unwrap().unwrap();
        let f = img.pixel(p.x as u32, p.y as u32).unwrap();
        assert!((f[0] - 0.9).abs() < 1e-6, "{f:?}");
    }
    // With the near triangle turned away and back faces culled, the far one shows through.
    let flipped = flat_object(&near, &back, &dark);
    let options = RenderOptions { cull_back_faces: true, ..Default::default() };
    let img = render(&scene(cam, vec![far_obj, flipped]), &options).unwrap();
    assert!((img.pixel(32, 34).unwrap()[0] - 0.9).abs() < 1e-6);
    // Not culled, the back face is drawn and shaded like its front.
    let img = render(&scene(cam, vec![far_obj, flipped]), &RenderOptions::default()).unwrap();
    assert!((img.pixel(32, 34).unwrap()[0] - 0.2).abs() < 1e-6);
}

fn lit_scene(sphere: &Sphere) -> RenderScene<'_> {
    let cam =
        Camera::frame(DVec3::splat(-1.0), DVec3::splat(1.0), DVec3::new(-0.3, -0.15, -1.0), DVec3::Y, 35.0, 96, 72).unwrap();
    RenderScene {
        camera: cam,
        objects: vec![sphere.object()],
        lights: vec![SpecularLight { direction_to_light: DVec3::new(1.0, 2.0, 2.0), irradiance: [3.0, 2.5, 2.0] }],
        environment: Some([0.2, 0.25, 0.3]),
        ground: Some(GroundPlane::below(DVec3::splat(-1.0), DVec3::splat(1.0), DVec3::Y)),
    }
}

#[test]
fn png_and_exr_round_trip() {
    let sphere = Sphere::new(1.0, 32, 64);
    let img = render(&lit_scene(&sphere), &RenderOptions::default()).unwrap();
    let dir = temp_dir("io");
    let (png, exr) = (dir.join("sphere.png"), dir.join("sphere.exr"));
    img.save_png(&png).unwrap();
    img.save_exr(&exr).unwrap();

    let back = image::open(&png).unwrap();
    assert_eq!((back.width(), back.height()), (96, 72));
    let back = back.into_rgba8();
    let bytes = img.to_srgb8(ToneMap::AcesFitted);
    for (x, y) in [(48u32, 36u32), (0, 0), (10, 60), (95, 71)] {
        let i = ((y * 96 + x) * 4) as usize;
        assert_eq!(back.get_pixel(x, y).0, [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]], "({x}, {y})");
    }
    assert_eq!(back.get_pixel(48, 36).0[3], 255);
    assert_eq!(back.get_pixel(0, 0).0[3], 0);

    let back = image::open(&exr).unwrap();
    assert_eq!((back.width(), back.height()), (96, 72));
    let back = back.into_rgba32f();
    for (x, y) in [(48u32, 36u32), (0, 0), (10, 60), (95, 71)] {
        assert_eq!(back.get_pixel(x, y).0, img.pixel(x, y).unwrap(), "({x}, {y})");
    }
    std::fs::remove_dir_all(&dir).unwrap();

    // A directory that does not exist is reported with its path.
    let e = img.save_png(dir.join("missing").join("x.png")).unwrap_err();
    assert!(matches!(e, RenderError::Write { .. }) && e.to_string().contains("missing"), "{e}");
}

#[test]
fn deterministic_across_thread_counts() {
    let sphere = Sphere::new(1.0, 48, 96);
    let scene = lit_scene(&sphere);
    let run = |threads: usize, options: &RenderOptions| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render(&scene, options).unwrap())
    };
    let differing =
        |a: &Image, b: &Image| a.rgba.iter().zip(&b.rgba).filter(|(p, q)| p.map(f32::to_bits) != q.map(f32::to_bits)).count();
    for shading in [Shading::PerPixel, Shading::PerSample] {
        for (samples, filter) in [(SamplePattern::RotatedGrid4, Filter::Box), (SamplePattern::Grid(3), Filter::Tent)] {
            let options = RenderOptions { samples, filter, shading, ..Default::default() };
            let one = run(1, &options);
            let two = run(2, &options);
            assert_eq!(differing(&one, &two), 0, "{shading:?} {samples:?} {filter:?}: 1 vs 2 threads");
            assert_eq!(differing(&two, &run(2, &options)), 0, "{shading:?} {samples:?} {filter:?}: rerun");
        }
    }
}

#[test]
fn lighting_ground_exposure_and_alpha_modes() {
    let sphere = Sphere::new(1.0, 48, 96);
    let scene = lit_scene(&sphere);
    let img = render(&scene, &RenderOptions::default()).unwrap();
    let ground = scene.ground.unwrap().radiance(&scene.lights, scene.environment);
    // The bottom-left corner shows the ground (not in alpha), the top-left the background.
    let g = img.pixel(0, 71).unwrap();
    for c in 0..3 {
        assert!((f64::from(g[c]) - ground[c]).abs() < 1e-6, "{g:?} vs {ground:?}");
    }
    assert_eq!(g[3], 0.0);
    let top = img.pixel(0, 0).unwrap();
    assert_eq!(top, [0.0, 0.0, 0.0, 0.0]);
    // With the ground in alpha it is opaque.
    let options = RenderOptions { alpha: AlphaMode::ObjectsAndGround, ..Default::default() };
    assert_eq!(render(&scene, &options).unwrap().pixel(0, 71).unwrap()[3], 1.0);

    // The highlight: the brightest object pixel is far above the unlit object's, which never
    // exceeds the baked radiance (the view factor is at most 1).
    let brightest = |img: &Image| img.rgba.iter().filter(|p| p[3] == 1.0).map(|p| p[0]).fold(0.0f32, f32::max);
    let unlit = RenderScene { lights: vec![], environment: None, ..scene.clone() };
    let plain = render(&unlit, &RenderOptions::default()).unwrap();
    assert!(brightest(&plain) <= 1.0 + 1e-6, "{}", brightest(&plain));
    assert!(brightest(&img) > brightest(&plain) + 0.3, "{} {}", brightest(&img), brightest(&plain));
    // The environment alone adds R(η, θo) L_env: a little head-on, more towards the rim.
    let env_only = RenderScene { lights: vec![], ..scene.clone() };
    let env_img = render(&env_only, &RenderOptions::default()).unwrap();
    let added: Vec<f32> = env_img.rgba.iter().zip(&plain.rgba).filter(|(p, _)| p[3] == 1.0).map(|(a, b)| a[2] - b[2]).collect();
    let r0 = ((ETA - 1.0) / (ETA + 1.0)).powi(2);
    assert!(added.iter().all(|&d| f64::from(d) >= 0.3 * r0 - 1e-6), "{:?}", added.iter().fold(f32::MAX, |a, &b| a.min(b)));

    // +1 EV doubles every value.
    let brighter = render(&scene, &RenderOptions { exposure_ev: 1.0, ..Default::default() }).unwrap();
    for (a, b) in img.rgba.iter().zip(&brighter.rgba) {
        for c in 0..3 {
            assert!((2.0 * a[c] - b[c]).abs() <= 1e-6 * b[c].abs().max(1.0));
        }
        assert_eq!(a[3], b[3]);
    }
}

#[test]
fn invalid_inputs_are_named() {
    let sphere = Sphere::new(1.0, 8, 16);
    let good = scene(head_on(5.0, 40.0, 32, 32), vec![sphere.object()]);
    let opts = RenderOptions::default();
    let err = |s: &RenderScene<'_>, o: &RenderOptions| render(s, o).unwrap_err().to_string();
    assert!(render(&good, &opts).is_ok());

    for (w, h) in [(0, 32), (32, 0)] {
        let s = scene(Camera { width: w, height: h, ..good.camera }, vec![sphere.object()]);
        let e = render(&s, &opts).unwrap_err();
        assert!(matches!(e, RenderError::InvalidSize { .. }), "{e}");
        assert!(e.to_string().contains("0"), "{e}");
    }
    for fov in [0.0, -5.0, 180.0, 250.0, f64::NAN] {
        let s = scene(Camera { vertical_fov_deg: fov, ..good.camera }, vec![]);
        let e = err(&s, &opts);
        assert!(e.contains("vertical_fov_deg"), "{e}");
    }

    let mut radiance = sphere.radiance.clone();
    radiance[5][1] = f64::NAN;
    let s = scene(good.camera, vec![RenderObject { radiance: &radiance, ..sphere.object() }]);
    let e = err(&s, &opts);
    assert!(e.contains("radiance[5]") && e.contains("NaN"), "{e}");

    let mut triangles = sphere.triangles.clone();
    triangles[7][2] = sphere.positions.len() as u32;
    let s = scene(good.camera, vec![sphere.object(), RenderObject { triangles: &triangles, ..sphere.object() }]);
    let e = render(&s, &opts).unwrap_err();
    assert!(matches!(e, RenderError::IndexOutOfRange { object: 1, triangle: 7, corner: 2, .. }), "{e}");
    assert!(e.to_string().contains("triangle 7"), "{e}");

    let s = scene(good.camera, vec![RenderObject { eta: f64::NAN, ..sphere.object() }]);
    assert!(err(&s, &opts).contains("eta"));
    let s = scene(good.camera, vec![RenderObject { radiance: &sphere.radiance[1..], ..sphere.object() }]);
    assert!(err(&s, &opts).contains("radiance has"));

    let s = RenderScene { lights: vec![SpecularLight { direction_to_light: DVec3::ZERO, irradiance: [1.0; 3] }], ..good.clone() };
    assert!(err(&s, &opts).contains("direction_to_light"));
    let s = RenderScene { environment: Some([f64::INFINITY, 0.0, 0.0]), ..good.clone() };
    assert!(err(&s, &opts).contains("environment"));
    let mut ground = GroundPlane::below(DVec3::splat(-1.0), DVec3::ONE, DVec3::Y);
    ground.albedo = [1.5, 0.5, 0.5];
    let s = RenderScene { ground: Some(ground), ..good.clone() };
    assert!(err(&s, &opts).contains("ground.albedo"));
    let o = RenderOptions { exposure_ev: f64::INFINITY, ..opts };
    assert!(err(&good, &o).contains("exposure_ev"));
}

#[test]
fn framed_object_is_centred_and_inside() {
    let sphere = Sphere::new(1.0, 32, 64);
    let mut positions = sphere.positions.clone();
    for p in &mut positions {
        *p += DVec3::new(10.0, -3.0, 2.0);
    }
    let (lo, hi) = (DVec3::new(9.0, -4.0, 1.0), DVec3::new(11.0, -2.0, 3.0));
    let cam = Camera::frame(lo, hi, DVec3::new(1.0, -1.0, 0.5), DVec3::Z, 30.0, 120, 80).unwrap();
    let obj = RenderObject { positions: &positions, ..sphere.object() };
    let img = render(&scene(cam, vec![obj]), &RenderOptions::default()).unwrap();
    // Centroid of the alpha matte at the image centre; nothing touches the border.
    let (mut sx, mut sy, mut sa) = (0.0, 0.0, 0.0);
    for y in 0..80 {
        for x in 0..120 {
            let a = f64::from(img.pixel(x, y).unwrap()[3]);
            sx += a * (f64::from(x) + 0.5);
            sy += a * (f64::from(y) + 0.5);
            sa += a;
            if x == 0 || y == 0 || x == 119 || y == 79 {
                assert_eq!(a, 0.0);
            }
        }
    }
    assert!((sx / sa - 60.0).abs() < 0.2 && (sy / sa - 40.0).abs() < 0.2, "{} {}", sx / sa, sy / sa);
}

#[test]
fn per_pixel_shading_matches_per_sample() {
    let sphere = Sphere::new(1.0, 64, 128);
    let scene = lit_scene(&sphere);
    let run = |shading| render(&scene, &RenderOptions { shading, ..Default::default() }).unwrap();
    let (pixel, sample) = (run(Shading::PerPixel), run(Shading::PerSample));
    // Coverage and depth are resolved per sample either way: the alpha mattes are identical.
    assert!(pixel.rgba.iter().zip(&sample.rgba).all(|(a, b)| a[3] == b[3]));
    // Shading at the centroid of each triangle's samples instead of at every sample changes a
    // smooth image only at second order.
    let (mut max, mut sum, mut n) = (0.0f32, 0.0f64, 0);
    for (a, b) in pixel.rgba.iter().zip(&sample.rgba) {
        for c in 0..3 {
            let d = (a[c] - b[c]).abs();
            max = max.max(d);
            sum += f64::from(d);
            n += 1;
        }
    }
    assert!(max < 0.02 && sum / f64::from(n) < 1e-4, "max {max}, mean {}", sum / f64::from(n));
}
