//! Helpers shared by the GPU tests (`gpu.rs`, `gpu_multigrid.rs`): the device (a test FAILS
//! without an adapter unless `TRANSCUT_GPU_TESTS=skip`, which skips loudly), one test at a time
//! on it, the shared meshes tetrahedralised and scaled to 60 mm, a lit system, relative RMS.
#![allow(dead_code)] // each test binary uses its own subset

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use transcut::diffusion::{assemble, DiffusionSystem};
use transcut::gpu::GpuContext;
use transcut::mesh::{self, TetMesh};
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::Medium;
use transcut::DVec3;

/// The device, or `None` (after a loud message) when `TRANSCUT_GPU_TESTS=skip`.
pub fn device() -> Option<&'static GpuContext> {
    if std::env::var("TRANSCUT_GPU_TESTS").is_ok_and(|v| v == "skip") {
        eprintln!("\n**** TRANSCUT_GPU_TESTS=skip: GPU TEST SKIPPED, THE GPU PATH IS NOT TESTED ****\n");
        return None;
    }
    match GpuContext::shared() {
        Ok(c) => Some(c),
        Err(e) => panic!(
            "the GPU tests need a GPU adapter: {e}\nRun scripts/install-lavapipe.sh (Mesa's software Vulkan), \
             or set TRANSCUT_GPU_TESTS=skip to skip these tests explicitly."
        ),
    }
}

/// Serialises the tests on the one device (lavapipe uses every core).
pub fn lock() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The folder of the shared test meshes.
pub fn shared_mesh_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes")
}

/// The surface at `path` tetrahedralised at about `tets` tets: (file stem, tet mesh, mm per
/// unit that makes its bounding-box diagonal 60 mm).
pub fn scaled_tets(path: &Path, tets: usize) -> (String, TetMesh, f64) {
    let surface = mesh::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let tets = tetrahedralize(&surface, &MesherOptions::with_tets(tets)).unwrap();
    let (lo, hi) = tets.positions().iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    (path.file_stem().unwrap().to_string_lossy().into_owned(), tets, 60.0 / (hi - lo).length())
}

/// A directional light plus ambient, different per channel: q per boundary vertex.
pub fn lit(system: &mut DiffusionSystem) {
    let light = DVec3::new(0.3, 0.8, 0.5).normalize();
    let q: Vec<[f64; 3]> = system
        .boundary()
        .normal
        .iter()
        .map(|n| {
            let d = n.dot(light).max(0.0);
            [2.0 * d + 0.05, 1.5 * d + 0.1, 1.0 * d + 0.2]
        })
        .collect();
    system.set_source(&q).unwrap();
}

/// `mesh` assembled with a preset at `scale` mm per unit, lit by [`lit`].
pub fn system_for(mesh: &TetMesh, scale: f64, preset: &str) -> DiffusionSystem {
    let mut s = assemble(mesh, &[Medium::preset(preset).unwrap()], scale).unwrap();
    lit(&mut s);
    s
}

/// √(Σ|a − b|² / Σ|b|²) per channel.
pub fn rel_rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    [0, 1, 2].map(|c| {
        let num: f64 = a.iter().zip(b).map(|(x, y)| (x[c] - y[c]).powi(2)).sum();
        let den: f64 = b.iter().map(|y| y[c] * y[c]).sum();
        (num / den).sqrt()
    })
}
