//! The core's integration tests, one module per subject, linked into one test binary: one link
//! of the library instead of one per file, and one harness that runs every test on every core.
//!
//! Tests that change process-wide state stay in binaries of their own beside this folder:
//! `bounded_input` (measures this process's bytes read and peak memory), `gpu_dipole` and
//! `gpu_prt` (set `TRANSCUT_BACKEND`), `gpu_fallback` (hides every adapter).
//!
//! Run one subject by its module path: `cargo test -p transcut --test integration diffusion::`.

#[path = "../common/mod.rs"]
mod common;
#[path = "../dipole_common/mod.rs"]
mod dipole_common;
#[cfg(feature = "gpu")]
#[path = "../gpu_common/mod.rs"]
mod gpu_common;

mod cancel;
mod cut;
mod cut_vs_fresh;
mod determinism;
mod diffusion;
mod edit;
mod fem_agreement;
mod fuzz_corpus;
mod gpu;
mod gpu_multigrid;
mod gpu_radiosity;
mod gpu_radiosity_bake;
mod gpu_relax;
mod gpu_shaders;
mod hierarchical_dipole;
mod inverse;
mod kept_meshes;
mod layering;
mod light;
mod mesh_input;
mod mesher;
mod methods;
mod multires;
mod optics;
mod orientation;
mod polygrid;
mod polygrid_bunny;
mod polygrid_relax;
mod prt;
mod prt_cache;
mod radiosity;
mod radiosity_method;
mod radiosity_profile;
mod radiosity_profile_het;
mod radiosity_profile_method;
mod radiosity_session;
mod render;
mod resolution;
mod scene;
mod scene_media;
mod session_relight;
mod sparse;
mod texture;
mod volume;
