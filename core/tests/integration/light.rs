//! Lights and the transmitted source q(x) = ∫ Li (n·ω)⁺ T(η, ω) dω through the public API.

use std::f64::consts::PI;

use transcut::light::{
    irradiance, transmitted_source, validate_lights, Environment, EnvironmentMethod, EquirectMap, Light, LightError,
    SourceOptions,
};
use transcut::mesh::TriangleBvh;
use transcut::optics::{f_ext, fresnel_transmittance};
use transcut::DVec3;

const ETA: f64 = 1.3;

/// A UV sphere of radius `r` about `c`: `rings` bands of latitude, `segments` of longitude.
fn uv_sphere(c: DVec3, r: f64, rings: usize, segments: usize) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut pos = vec![c + DVec3::Z * r];
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            pos.push(c + r * DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()));
        }
    }
    pos.push(c - DVec3::Z * r);
    let south = (pos.len() - 1) as u32;
    let ring = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut tris = Vec::new();
    for j in 0..segments {
        tris.push([0, ring(1, j), ring(1, j + 1)]);
        for i in 1..rings - 1 {
            let (a, b, c2, d) = (ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1));
            tris.push([a, b, c2]);
            tris.push([a, c2, d]);
        }
        tris.push([ring(rings - 1, j), south, ring(rings - 1, j + 1)]);
    }
    (pos, tris)
}

/// Vertices of a UV sphere about the origin with outward normals, and its BVH.
fn sphere_scene() -> (Vec<DVec3>, Vec<DVec3>, TriangleBvh) {
    let (pos, tris) = uv_sphere(DVec3::ZERO, 1.0, 16, 32);
    let normals = pos.iter().map(|p| p.normalize()).collect();
    let bvh = TriangleBvh::from_indexed(&pos, &tris);
    (pos, normals, bvh)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

#[test]
fn far_point_light_matches_a_directional_light() {
    let dir = DVec3::new(0.3, -0.5, -0.8).normalize();
    let e = [1.5, 1.0, 0.25];
    let d = 1e4;
    let sun = [Light::Directional { direction: dir, irradiance: e, angular_diameter_deg: 0.0 }];
    let point = [Light::Point { position: -dir * d, intensity: e.map(|c| c * d * d) }];
    let mut points = Vec::new();
    let mut normals = Vec::new();
    for k in 0..50 {
        let t = k as f64;
        points.push(0.1 * DVec3::new((0.7 * t).sin(), (1.3 * t).cos(), (0.4 * t).sin()));
        normals.push(DVec3::new((2.1 * t).cos(), (0.9 * t).sin(), 1.0 + (0.5 * t).cos()).normalize());
    }
    let opts = SourceOptions::default();
    let a = transmitted_source(&sun, &points, &normals, ETA, None, &opts).unwrap();
    let b = transmitted_source(&point, &points, &normals, ETA, None, &opts).unwrap();
    // Within 1e-4 of the irradiance scale (the direction differs by up to |x|/d = 1e-5 rad,
    // the distance by 1e-5 relative).
    let mut lit = 0;
    for (qa, qb) in a.iter().zip(&b) {
        for c in 0..3 {
            assert!((qa[c] - qb[c]).abs() <= 1e-4 * e[c], "{qa:?} vs {qb:?}");
        }
        lit += usize::from(qa[0] > 0.0);
    }
    assert!(lit > 10 && lit < 50, "{lit} of 50 points face the light");
}

#[test]
fn occluded_vertex_gets_nothing_from_that_light() {
    // A ground square (two triangles, part of the occluder) and a small roof triangle at z = 1
    // over the point (0, 0); the neighbour at (2, 0) is in the open.
    let g = 5.0;
    let ground = [
        [DVec3::new(-g, -g, 0.0), DVec3::new(g, -g, 0.0), DVec3::new(g, g, 0.0)],
        [DVec3::new(-g, -g, 0.0), DVec3::new(g, g, 0.0), DVec3::new(-g, g, 0.0)],
    ];
    let roof = [DVec3::new(-0.5, -0.5, 1.0), DVec3::new(0.5, -0.5, 1.0), DVec3::new(0.0, 0.6, 1.0)];
    let bvh = TriangleBvh::new(vec![ground[0], ground[1], roof]);
    let points = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0)];
    let normals = [DVec3::Z; 2];
    let opts = SourceOptions::default();
    let lights = [
        Light::Directional { direction: -DVec3::Z, irradiance: [1.0; 3], angular_diameter_deg: 0.0 },
        Light::Point { position: DVec3::new(0.0, 0.0, 3.0), intensity: [9.0; 3] },
        Light::Spot {
            position: DVec3::new(0.5, 0.0, 3.0),
            direction: DVec3::new(0.0, 0.0, -1.0),
            intensity: [9.0; 3],
            cone_half_angle_deg: 60.0,
            blend: 0.0,
        },
    ];
    let t0 = fresnel_transmittance(1.0, ETA);
    for (k, light) in lights.iter().enumerate() {
        let q = transmitted_source(std::slice::from_ref(light), &points, &normals, ETA, Some(&bvh), &opts).unwrap();
        assert_eq!(q[0], [0.0; 3], "light {k}: the covered vertex is shadowed");
        assert!(q[1][0] > 0.0, "light {k}: the neighbour is lit");
        let free = transmitted_source(std::slice::from_ref(light), &points, &normals, ETA, None, &opts).unwrap();
        assert!(free[0][0] > 0.0);
        assert_eq!(q[1], free[1], "light {k}: an unshadowed point is unchanged by the occluder");
    }
    let q = transmitted_source(&lights[..1], &points, &normals, ETA, Some(&bvh), &opts).unwrap();
    assert!((q[1][0] - t0).abs() < 1e-15);
    // The shadow of a directional light falls along its direction: a light from the side
    // misses the roof.
    let slanted = [Light::Directional { direction: DVec3::new(1.0, 0.0, -1.0), irradiance: [1.0; 3], angular_diameter_deg: 0.0 }];
    let q = transmitted_source(&slanted, &points[..1], &normals[..1], ETA, Some(&bvh), &opts).unwrap();
    assert!(q[0][0] > 0.0);
}

#[test]
fn soft_sun_gives_a_penumbra() {
    // The roof edge at x = 0.5, height 1; a sun of 10° from straight above: points well inside
    // are dark, well outside fully lit, at the edge partly lit.
    let roof = [DVec3::new(-5.0, -5.0, 1.0), DVec3::new(0.5, -5.0, 1.0), DVec3::new(0.5, 5.0, 1.0)];
    let roof2 = [DVec3::new(-5.0, -5.0, 1.0), DVec3::new(0.5, 5.0, 1.0), DVec3::new(-5.0, 5.0, 1.0)];
    let bvh = TriangleBvh::new(vec![roof, roof2]);
    let sun = [Light::Directional { direction: -DVec3::Z, irradiance: [1.0; 3], angular_diameter_deg: 10.0 }];
    let points = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0)];
    let normals = [DVec3::Z; 3];
    let opts = SourceOptions { area_samples: 256, ..Default::default() };
    let e = irradiance(&sun, &points, &normals, Some(&bvh), &opts).unwrap();
    assert_eq!(e[0][0], 0.0);
    assert!((e[1][0] - 0.5).abs() < 0.02, "{}", e[1][0]);
    assert!((e[2][0] - 1.0).abs() < 1e-12, "{}", e[2][0]);
}

#[test]
fn constant_environment_on_a_sphere() {
    let (points, normals, bvh) = sphere_scene();
    let l = [1.0, 0.5, 2.0];
    let lights = [Light::Environment(Environment::Constant(l))];
    let expect = PI * (1.0 - f_ext(ETA));
    let opts = SourceOptions::default();
    let exact = transmitted_source(&lights, &points, &normals, ETA, None, &opts).unwrap();
    let shadowed = transmitted_source(&lights, &points, &normals, ETA, Some(&bvh), &opts).unwrap();
    for (a, b) in exact.iter().zip(&shadowed) {
        for c in 0..3 {
            assert!((a[c] - expect * l[c]).abs() < 1e-13, "{a:?}");
            assert!(rel(b[c], expect * l[c]) < 0.01, "{b:?} vs {}", expect * l[c]);
        }
    }
    // Irradiance: π L.
    let e = irradiance(&lights, &points[..3], &normals[..3], Some(&bvh), &opts).unwrap();
    assert!(e.iter().all(|e| rel(e[0], PI) < 1e-12), "{e:?}");
}

#[test]
fn a_point_inside_a_closed_mesh_sees_no_sky() {
    let (pos, tris) = uv_sphere(DVec3::ZERO, 3.0, 8, 16);
    let shell = TriangleBvh::from_indexed(&pos, &tris);
    let map = EquirectMap::from_fn(32, 16, 1.0, |d| [1.0 + d.z; 3]).unwrap();
    let lights = [
        Light::Environment(Environment::Constant([1.0; 3])),
        Light::Environment(Environment::Equirect(map)),
        Light::Directional { direction: DVec3::new(0.2, 0.1, -1.0), irradiance: [5.0; 3], angular_diameter_deg: 2.0 },
    ];
    let q = transmitted_source(&lights, &[DVec3::ZERO], &[DVec3::X], ETA, Some(&shell), &SourceOptions::default()).unwrap();
    assert_eq!(q[0], [0.0; 3]);
}

#[test]
fn rectangle_light_far_away_approaches_a_point_light() {
    let l = [2.0, 1.0, 0.5];
    let (hu, hv) = (DVec3::new(0.5, 0.0, 0.0), DVec3::new(0.0, 0.3, 0.2));
    let normal = hu.cross(hv).normalize();
    let area = 4.0 * hu.cross(hv).length();
    let receiver = [DVec3::ZERO];
    let n = [DVec3::new(0.1, 0.2, 1.0).normalize()];
    let opts = SourceOptions { area_samples: 64, ..Default::default() };
    let mut errors = Vec::new();
    for dist in [10.0, 100.0, 1000.0] {
        // Light above and to the side, facing back towards the receiver at an angle.
        let center = DVec3::new(0.2, -0.3, 1.0).normalize() * dist;
        let to_receiver = (DVec3::ZERO - center).normalize();
        let cos_l = to_receiver.dot(normal).abs();
        let rect = [Light::RectArea { center, half_u: hu, half_v: hv, radiance: l, two_sided: true }];
        let point = [Light::Point { position: center, intensity: l.map(|c| c * area * cos_l) }];
        let a = transmitted_source(&rect, &receiver, &n, ETA, None, &opts).unwrap()[0];
        let b = transmitted_source(&point, &receiver, &n, ETA, None, &opts).unwrap()[0];
        assert!(b[0] > 0.0);
        errors.push(rel(a[0], b[0]));
        assert!((a[1] / a[0] - 0.5).abs() < 1e-12);
    }
    assert!(errors[2] < 1e-5, "{errors:?}");
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
}

#[test]
fn one_sided_area_lights_emit_along_u_cross_v() {
    let rect =
        |center: DVec3| Light::RectArea { center, half_u: DVec3::X, half_v: DVec3::Y, radiance: [1.0; 3], two_sided: false };
    // u × v = +z: a receiver above it, facing down, is lit; one below, facing up, is not.
    let points = [DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, -1.0)];
    let normals = [-DVec3::Z, DVec3::Z];
    let e = irradiance(&[rect(DVec3::ZERO)], &points, &normals, None, &SourceOptions::default()).unwrap();
    assert!(e[0][0] > 0.1 && e[1][0] == 0.0, "{e:?}");
}

#[test]
fn spot_light_is_dark_outside_its_cone() {
    let spot = [Light::Spot {
        position: DVec3::new(0.0, 0.0, 5.0),
        direction: DVec3::new(0.0, 0.0, -2.0),
        intensity: [25.0, 50.0, 0.0],
        cone_half_angle_deg: 30.0,
        blend: 0.2,
    }];
    let edge = 5.0 * 30f64.to_radians().tan();
    let radii = [0.0, 0.5 * edge, 0.99 * edge, 1.01 * edge, 2.0 * edge, 10.0];
    let points: Vec<DVec3> = radii.iter().map(|&r| DVec3::new(r, 0.0, 0.0)).collect();
    let normals = vec![DVec3::Z; points.len()];
    let q = transmitted_source(&spot, &points, &normals, ETA, None, &SourceOptions::default()).unwrap();
    // On the axis: I cos θ T / d² with no falloff.
    assert!((q[0][0] - fresnel_transmittance(1.0, ETA)).abs() < 1e-14, "{:?}", q[0]);
    assert!((q[0][1] - 2.0 * q[0][0]).abs() < 1e-14 && q[0][2] == 0.0);
    assert!(q[1][0] > 0.0 && q[2][0] > 0.0 && q[2][0] < q[1][0]);
    for k in 3..radii.len() {
        assert_eq!(q[k], [0.0; 3], "r = {}", radii[k]);
    }
    // A point light of the same intensity agrees inside the un-blended core.
    let point = [Light::Point { position: DVec3::new(0.0, 0.0, 5.0), intensity: [25.0, 50.0, 0.0] }];
    let p = transmitted_source(&point, &points[..2], &normals[..2], ETA, None, &SourceOptions::default()).unwrap();
    assert_eq!(p[0], q[0]);
    assert_eq!(p[1], q[1]);
}

#[test]
fn constant_equirect_map_matches_the_constant_environment() {
    let (points, normals, bvh) = sphere_scene();
    let texel = [0.5f32, 1.0, 2.0];
    let rgb: Vec<f32> = (0..64 * 32).flat_map(|_| texel).collect();
    let map = EquirectMap::from_rgb(64, 32, &rgb, 2.0).unwrap();
    let l = [1.0, 2.0, 4.0];
    let constant = [Light::Environment(Environment::Constant(l))];
    let equirect = [Light::Environment(Environment::Equirect(map))];
    let opts = SourceOptions::default();
    let reference = transmitted_source(&constant, &points, &normals, ETA, None, &opts).unwrap();
    let sh9 = transmitted_source(&equirect, &points, &normals, ETA, None, &opts).unwrap();
    let sampled_opts = SourceOptions { unshadowed_environment: EnvironmentMethod::Sampled, ..opts };
    let sampled = transmitted_source(&equirect, &points, &normals, ETA, None, &sampled_opts).unwrap();
    let shadowed = transmitted_source(&equirect, &points, &normals, ETA, Some(&bvh), &opts).unwrap();
    let (mut worst_sampled, mut worst_shadowed) = (0.0f64, 0.0f64);
    for i in 0..points.len() {
        for c in 0..3 {
            assert!(rel(sh9[i][c], reference[i][c]) < 0.01, "SH9 {:?} vs {:?}", sh9[i], reference[i]);
            worst_sampled = worst_sampled.max(rel(sampled[i][c], reference[i][c]));
            worst_shadowed = worst_shadowed.max(rel(shadowed[i][c], reference[i][c]));
        }
    }
    assert!(worst_sampled < 0.02, "{worst_sampled}");
    assert!(worst_shadowed < 0.02, "{worst_shadowed}");
}

#[test]
fn sh9_and_sampling_agree_on_a_smooth_sky() {
    // A sky brighter towards +z and +x: SH9 holds it almost exactly (only l ≤ 1 content plus a
    // little l = 2), so the noise-free SH9 path and the unbiased sampled one agree.
    let map = EquirectMap::from_fn(128, 64, 1.0, |d| {
        let v = 1.0 + 0.6 * d.z + 0.3 * d.x;
        [v, 0.5 * v, 0.25]
    })
    .unwrap();
    let (points, normals, bvh) = sphere_scene();
    let lights = [Light::Environment(Environment::Equirect(map))];
    let sh9 = transmitted_source(&lights, &points, &normals, ETA, None, &SourceOptions::default()).unwrap();
    let opts = SourceOptions { environment_samples: 1024, ..Default::default() };
    let shadowed = transmitted_source(&lights, &points, &normals, ETA, Some(&bvh), &opts).unwrap();
    for i in 0..points.len() {
        assert!(rel(shadowed[i][0], sh9[i][0]) < 0.02, "{i}: {:?} vs {:?}", shadowed[i], sh9[i]);
    }
    // Brighter where the normal faces the bright part of the sky.
    let top = points.iter().position(|p| p.z > 0.999).unwrap();
    let bottom = points.iter().position(|p| p.z < -0.999).unwrap();
    assert!(sh9[top][0] > 1.5 * sh9[bottom][0]);
}

#[test]
fn hdr_and_exr_files_round_trip() {
    let dir = std::env::temp_dir().join(format!("transcut-light-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (8u32, 4u32);
    // Powers of two survive the RGBE encoding exactly.
    let px = |x: u32, y: u32| [2f32.powi(x as i32 - 4), 0.5, 2f32.powi(y as i32)];
    let pixels: Vec<image::Rgb<f32>> = (0..h).flat_map(|y| (0..w).map(move |x| image::Rgb(px(x, y)))).collect();

    let hdr = dir.join("sky.hdr");
    image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(std::fs::File::create(&hdr).unwrap()))
        .encode(&pixels, w as usize, h as usize)
        .unwrap();
    let exr = dir.join("sky.exr");
    let buf: Vec<f32> = pixels.iter().flat_map(|p| p.0).collect();
    image::Rgb32FImage::from_raw(w, h, buf).unwrap().save(&exr).unwrap();

    for path in [&hdr, &exr] {
        let map = EquirectMap::load(path, 3.0).unwrap();
        assert_eq!((map.width(), map.height()), (w as usize, h as usize));
        assert_eq!(map.intensity(), 3.0);
        for y in 0..h {
            for x in 0..w {
                assert_eq!(map.texel(x as usize, y as usize), px(x, y), "{} ({x}, {y})", path.display());
            }
        }
    }
    // A missing file and a file that is no image are load errors naming the path.
    let missing = dir.join("missing.hdr");
    match EquirectMap::load(&missing, 1.0) {
        Err(LightError::ImageLoad { path, .. }) => assert!(path.ends_with("missing.hdr")),
        other => panic!("{other:?}"),
    }
    let junk = dir.join("junk.hdr");
    std::fs::write(&junk, b"not an image").unwrap();
    assert!(matches!(EquirectMap::load(&junk, 1.0), Err(LightError::ImageLoad { .. })));
    std::fs::remove_dir_all(&dir).unwrap();
}

fn invalid_field(light: Light) -> (&'static str, String) {
    match validate_lights(&[Light::Point { position: DVec3::ZERO, intensity: [1.0; 3] }, light]) {
        Err(e @ LightError::InvalidLight { index: 1, field, .. }) => (field, e.to_string()),
        other => panic!("expected an InvalidLight error for light 1, got {other:?}"),
    }
}

#[test]
fn validation_names_the_light_and_the_field() {
    let sun = |direction: DVec3, irradiance: [f64; 3], angular_diameter_deg: f64| Light::Directional {
        direction,
        irradiance,
        angular_diameter_deg,
    };
    let spot = |direction: DVec3, cone_half_angle_deg: f64, blend: f64| Light::Spot {
        position: DVec3::ZERO,
        direction,
        intensity: [1.0; 3],
        cone_half_angle_deg,
        blend,
    };
    let rect = |half_u: DVec3, half_v: DVec3, radiance: [f64; 3]| Light::RectArea {
        center: DVec3::ZERO,
        half_u,
        half_v,
        radiance,
        two_sided: false,
    };
    let disc = |normal: DVec3, radius: f64| Light::DiscArea {
        center: DVec3::ZERO,
        normal,
        radius,
        radiance: [1.0; 3],
        two_sided: false,
    };
    let cases = [
        (sun(DVec3::ZERO, [1.0; 3], 0.0), "direction"),
        (sun(DVec3::new(0.0, f64::NAN, 1.0), [1.0; 3], 0.0), "direction"),
        (sun(DVec3::Z, [1.0, f64::NAN, 1.0], 0.0), "irradiance"),
        (sun(DVec3::Z, [1.0, 1.0, -0.1], 0.0), "irradiance"),
        (sun(DVec3::Z, [1.0; 3], -1.0), "angular_diameter_deg"),
        (Light::Point { position: DVec3::new(f64::NAN, 0.0, 0.0), intensity: [1.0; 3] }, "position"),
        (Light::Point { position: DVec3::ZERO, intensity: [-1.0, 0.0, 0.0] }, "intensity"),
        (spot(DVec3::ZERO, 30.0, 0.1), "direction"),
        (spot(DVec3::Z, 0.0, 0.1), "cone_half_angle_deg"),
        (spot(DVec3::Z, 91.0, 0.1), "cone_half_angle_deg"),
        (spot(DVec3::Z, f64::NAN, 0.1), "cone_half_angle_deg"),
        (spot(DVec3::Z, 30.0, -0.1), "blend"),
        (rect(DVec3::ZERO, DVec3::Y, [1.0; 3]), "half_u"),
        (rect(DVec3::X, DVec3::ZERO, [1.0; 3]), "half_v"),
        (rect(DVec3::X, DVec3::X * -3.0, [1.0; 3]), "half_v"),
        (rect(DVec3::X, DVec3::Y, [f64::INFINITY, 1.0, 1.0]), "radiance"),
        (disc(DVec3::ZERO, 1.0), "normal"),
        (disc(DVec3::Z, 0.0), "radius"),
        (disc(DVec3::Z, -1.0), "radius"),
        (disc(DVec3::Z, f64::NAN), "radius"),
        (Light::Environment(Environment::Constant([-1.0, 0.0, 0.0])), "radiance"),
    ];
    for (light, field) in cases {
        let kind = light.kind();
        let (got, message) = invalid_field(light);
        assert_eq!(got, field, "{message}");
        assert!(message.starts_with(&format!("light 1 ({kind}): {field} = ")), "{message}");
    }
    // transmitted_source validates too, before doing any work.
    let bad = [Light::Point { position: DVec3::ZERO, intensity: [f64::NAN; 3] }];
    assert!(matches!(
        transmitted_source(&bad, &[DVec3::X], &[DVec3::Z], ETA, None, &SourceOptions::default()),
        Err(LightError::InvalidLight { index: 0, field: "intensity", .. })
    ));
}

#[test]
fn environment_map_buffers_are_checked() {
    assert!(matches!(
        EquirectMap::from_rgb(4, 2, &[1.0; 23], 1.0),
        Err(LightError::ImageBufferLength { width: 4, height: 2, expected: 24, actual: 23 })
    ));
    assert!(matches!(EquirectMap::from_rgb(4, 2, &[1.0; 25], 1.0), Err(LightError::ImageBufferLength { .. })));
    assert!(matches!(EquirectMap::from_rgb(0, 0, &[], 1.0), Err(LightError::ImageSize { .. })));
    let mut rgb = vec![1.0f32; 24];
    rgb[3 * 5 + 2] = f32::INFINITY;
    assert!(matches!(EquirectMap::from_rgb(4, 2, &rgb, 1.0), Err(LightError::ImageTexel { x: 1, y: 1, .. })));
    assert!(matches!(EquirectMap::from_rgb(4, 2, &[1.0; 24], f64::NAN), Err(LightError::ImageIntensity { .. })));
}

#[test]
fn bad_points_normals_eta_and_options_are_reported() {
    let lights = [Light::Point { position: DVec3::Z, intensity: [1.0; 3] }];
    let opts = SourceOptions::default();
    let run = |p: &[DVec3], n: &[DVec3], eta: f64, o: &SourceOptions| transmitted_source(&lights, p, n, eta, None, o);
    assert_eq!(run(&[DVec3::ZERO; 2], &[DVec3::Z], ETA, &opts), Err(LightError::LengthMismatch { points: 2, normals: 1 }));
    assert!(matches!(
        run(&[DVec3::ZERO, DVec3::new(0.0, 0.0, f64::NAN)], &[DVec3::Z; 2], ETA, &opts),
        Err(LightError::InvalidPoint { index: 1, field: "position", .. })
    ));
    assert!(matches!(
        run(&[DVec3::ZERO; 2], &[DVec3::Z, DVec3::ZERO], ETA, &opts),
        Err(LightError::InvalidPoint { index: 1, field: "normal", .. })
    ));
    for eta in [0.9, f64::NAN, 10.0] {
        assert!(matches!(run(&[DVec3::ZERO], &[DVec3::Z], eta, &opts), Err(LightError::InvalidEta { .. })));
    }
    let nan_bias = SourceOptions { shadow_bias: f64::NAN, ..opts };
    assert!(matches!(
        run(&[DVec3::ZERO], &[DVec3::Z], ETA, &nan_bias),
        Err(LightError::InvalidOption { field: "shadow_bias", .. })
    ));
    // Normals need not be unit length.
    let a = run(&[DVec3::ZERO], &[DVec3::Z * 7.0], ETA, &opts).unwrap();
    let b = run(&[DVec3::ZERO], &[DVec3::Z], ETA, &opts).unwrap();
    assert_eq!(a, b);
    // No points, no work.
    assert_eq!(run(&[], &[], ETA, &opts).unwrap(), Vec::<[f64; 3]>::new());
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let (points, normals, bvh) = sphere_scene();
    let map = EquirectMap::from_fn(64, 32, 1.5, |d| [1.0 + d.z.max(0.0) * 4.0, 1.0, 0.5 + d.x.abs()]).unwrap();
    let lights = [
        Light::Directional { direction: DVec3::new(-1.0, 0.2, -0.5), irradiance: [3.0; 3], angular_diameter_deg: 5.0 },
        Light::RectArea {
            center: DVec3::new(0.0, 3.0, 1.0),
            half_u: DVec3::X,
            half_v: DVec3::new(0.0, 0.2, 0.5),
            radiance: [1.0, 2.0, 3.0],
            two_sided: true,
        },
        Light::DiscArea {
            center: DVec3::new(0.0, -3.0, 0.0),
            normal: DVec3::Y,
            radius: 0.5,
            radiance: [4.0; 3],
            two_sided: false,
        },
        Light::Environment(Environment::Equirect(map)),
        Light::Environment(Environment::Constant([0.1; 3])),
    ];
    let opts = SourceOptions { area_samples: 16, environment_samples: 64, seed: 42, ..Default::default() };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| transmitted_source(&lights, &points, &normals, ETA, Some(&bvh), &opts).unwrap())
    };
    let one = run(1);
    let two = run(2);
    assert_eq!(one, two);
    assert_eq!(one, run(2), "repeatable");
    // A different seed gives a different (but close) answer.
    let other = transmitted_source(&lights, &points, &normals, ETA, Some(&bvh), &SourceOptions { seed: 43, ..opts }).unwrap();
    assert_ne!(one, other);
    let (s1, s2): (f64, f64) = (one.iter().map(|q| q[0]).sum(), other.iter().map(|q| q[0]).sum());
    assert!(rel(s1, s2) < 0.01, "{s1} vs {s2}");
}
