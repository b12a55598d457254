//! Helpers shared by the hierarchical dipole's tests (`hierarchical_dipole.rs`, `gpu_dipole.rs`):
//! the design note's marble, a hierarchy over a mesh, a sun-lit irradiance, peak-relative
//! errors and the Perlin-displaced sphere.
#![allow(dead_code)] // each test binary uses its own subset

use transcut::hierarchy::{DipoleHierarchy, DipoleOptions};
use transcut::light::{self, Light, SourceOptions};
use transcut::mesh::TriMesh;
use transcut::optics::{Dipole, Medium};
use transcut::volume::noise::PerlinNoise;
use transcut::DVec3;

/// Marble (Jensen et al. 2001) at η = 1.3, the design note's sphere material.
pub fn marble() -> Medium {
    Medium { eta: 1.3, ..Medium::preset("marble").unwrap() }
}

pub fn dipoles(m: &Medium) -> [Dipole; 3] {
    [0, 1, 2].map(|c| m.dipole(c))
}

pub fn hierarchy(mesh: &TriMesh, options: DipoleOptions) -> DipoleHierarchy {
    DipoleHierarchy::new(mesh.positions().to_vec(), mesh.triangles().to_vec(), dipoles(&marble()), options).unwrap()
}

pub fn go() -> bool {
    true
}

/// q at every vertex of `h` under a sun of irradiance 3 along `direction`, no shadows.
pub fn sun_lit_from(h: &DipoleHierarchy, direction: DVec3) -> Vec<[f64; 3]> {
    let sun = [Light::Directional { direction, irradiance: [3.0; 3], angular_diameter_deg: 0.0 }];
    light::transmitted_source(&sun, h.positions(), &h.vertex_normals(), 1.3, None, &SourceOptions::default()).unwrap()
}

/// (peak-relative RMS, peak-relative max) of `b` against `reference`, per channel, worst.
pub fn errors(b: &[[f64; 3]], reference: &[[f64; 3]]) -> (f64, f64) {
    let (mut rms, mut max) = (0.0f64, 0.0f64);
    for c in 0..3 {
        let peak = reference.iter().map(|r| r[c]).fold(0.0, f64::max);
        let d: Vec<f64> = b.iter().zip(reference).map(|(x, r)| (x[c] - r[c]) / peak).collect();
        rms = rms.max((d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt());
        max = max.max(d.iter().fold(0.0, |m, x| m.max(x.abs())));
    }
    (rms, max)
}

/// The icosphere displaced along its normals by Perlin noise that drifts with `frame`.
pub fn displaced(base: &TriMesh, noise: &PerlinNoise, frame: usize) -> Vec<DVec3> {
    let t = DVec3::new(0.0, 0.0, 0.05 * frame as f64);
    base.positions().iter().map(|&p| p * (1.0 + 0.08 * noise.noise(p * 0.2 + t))).collect()
}

/// `base` with its vertices at `positions`.
pub fn moved_mesh(base: &TriMesh, positions: &[DVec3]) -> TriMesh {
    TriMesh::from_triangles(&positions.iter().map(|p| p.to_array()).collect::<Vec<_>>(), &base.triangles().concat()).unwrap()
}
