//! The polygrid method against TransCut on the Stanford bunny (60 mm across, marble at η = 1.3,
//! a sun from (0, −1, −1) of irradiance 3, self-shadowed), homogeneous and with veins: the two
//! discretise the same diffusion model on different nodes (a voxel polycube's grid against
//! isosurface-stuffed tets), so their radiance at the user's vertices must agree to within the
//! discretisation error of both (design note §3.4).
//!
//! The default run compares 100k polygrid nodes with 600k tets (about as many unknowns) at
//! two cells per cube (the bunny's ears fold the map at four and more: the method halves the
//! cube itself, the test starts where it would end); `TRANSCUT_POLYGRID_AGREEMENT=N` compares
//! at N nodes. The difference halves from 100k to 500k nodes (marble 1.7–2.0% → 0.94–0.97%,
//! veins 2.2–2.9% → 1.2–1.4%): both discretisations converge to one answer.

use transcut::light::Light;
use transcut::optics::Medium;
use transcut::DVec3;
use transcut::{bake, BakeOptions, MediumSource, Method, Object, PolygridOptions, Scene, Stencil, TransCutOptions};

use crate::common;
use common::bunny;

/// √(Σ (a − b)² / Σ b²) over the vertices, per channel.
fn relative_l2(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    std::array::from_fn(|c| {
        let (d, n) = a.iter().zip(b).fold((0.0, 0.0), |(d, n), (x, y)| (d + (x[c] - y[c]).powi(2), n + y[c] * y[c]));
        (d / n).sqrt()
    })
}

#[test]
fn polygrid_agrees_with_transcut_on_the_bunny() {
    let size: usize = std::env::var("TRANSCUT_POLYGRID_AGREEMENT").ok().and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let (surface, mm_per_unit) = bunny();
    let marble = Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3, 0.0).unwrap();
    let veined = MediumSource::Veins(common::veined(marble, mm_per_unit));
    let sun = Light::Directional { direction: DVec3::new(0.0, -1.0, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
    let solve = TransCutOptions { tets: size, tolerance: 1e-8, ..TransCutOptions::default() };
    // Equal unknowns: stuffed tets come about six to a vertex (at 100k tets TransCut has a
    // sixth of the polygrid's unknowns, and the two differ by 5–6% for that reason alone).
    let transcut = Method::TransCut(TransCutOptions { tets: 6 * size, ..solve.clone() });
    let polygrid =
        Method::Polygrid(PolygridOptions { nodes: size, resolution: 2, solve: solve.clone(), ..PolygridOptions::default() });
    let paper = Method::Polygrid(PolygridOptions {
        nodes: size,
        resolution: 2,
        stencil: Stencil::PaperLsq,
        solve,
        ..PolygridOptions::default()
    });
    // (medium, bound on the relative L2 difference per channel: the issue's).
    // The paper's stencil: within 10% (design note A5); measured 3.5–3.9% (marble) and 5.8–9.3%
    // (veins: Stam's form is not conservative at their interfaces) at 100k.
    let paper_bound = 0.10;
    for (name, medium, bound) in [("marble", MediumSource::Homogeneous(marble), 0.03), ("veined marble", veined, 0.05)] {
        let mut object = Object::new("bunny", surface.clone(), marble, mm_per_unit);
        object.material = medium.into();
        let scene = Scene { objects: vec![object], lights: vec![sun.clone()] };
        let bake_with =
            |method: &Method| bake(&scene, &BakeOptions { method: method.clone(), ..BakeOptions::default() }).unwrap();
        let (t, p) = (bake_with(&transcut), bake_with(&polygrid));
        let l2 = relative_l2(&p.objects[0].radiance, &t.objects[0].radiance);
        eprintln!(
            "{name} at {size}: relative L2 polygrid vs TransCut {l2:.4?}; TransCut {} tets, {} vertices; polygrid {:?}",
            t.objects[0].stats.tets, t.objects[0].stats.vertices, p.objects[0].stats.polygrid
        );
        assert!(l2.iter().all(|&d| d < bound), "{name}: {l2:?}");
        let q = bake_with(&paper);
        let l2 = relative_l2(&q.objects[0].radiance, &t.objects[0].radiance);
        eprintln!("{name} at {size}: the paper's stencil vs TransCut {l2:.4?}; {:?}", q.objects[0].stats.polygrid);
        assert!(l2.iter().all(|&d| d < paper_bound), "{name}, the paper's stencil: {l2:?}");
    }
}
