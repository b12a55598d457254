//! Every WGSL kernel of `shaders/` (with `common.wgsl`, and for the hierarchical dipole's
//! `dipole_common.wgsl`, prepended, as the GPU module loads it)
//! parses and validates with naga, so a broken shader fails `cargo test`, not a user's bake.
//! Needs no GPU.
#![cfg(feature = "gpu")]

use transcut::gpu::shaders::{Kernel, COMMON, DIPOLE_COMMON};

fn validate(name: &str, source: &str) -> naga::Module {
    let module =
        naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{name} does not parse:\n{}", e.emit_to_string(source)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name} does not validate:\n{}", e.emit_to_string(source)));
    module
}

#[test]
fn every_kernel_parses_and_validates_with_one_compute_entry_point() {
    for kernel in Kernel::ALL {
        let module = validate(kernel.file(), &kernel.source());
        assert_eq!(module.entry_points.len(), 1, "{}", kernel.file());
        let ep = &module.entry_points[0];
        assert_eq!(ep.name, "main", "{}", kernel.file());
        assert_eq!(ep.stage, naga::ShaderStage::Compute, "{}", kernel.file());
        // Every kernel runs in workgroups of WG = 256 (the host's grid assumes it).
        assert_eq!(ep.workgroup_size, [256, 1, 1], "{}", kernel.file());
    }
}

#[test]
fn every_shader_file_is_a_kernel() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|f| f.ends_with(".wgsl") && f != "common.wgsl" && f != "dipole_common.wgsl")
        .collect();
    files.sort();
    let mut kernels: Vec<String> = Kernel::ALL.iter().map(|k| k.file().to_owned()).collect();
    kernels.sort();
    assert_eq!(files, kernels, "shaders/ and gpu::Kernel disagree");
    // The embedded text is the file's.
    for kernel in Kernel::ALL {
        assert_eq!(std::fs::read_to_string(dir.join(kernel.file())).unwrap(), kernel.body());
    }
    assert_eq!(std::fs::read_to_string(dir.join("common.wgsl")).unwrap(), COMMON);
    assert_eq!(std::fs::read_to_string(dir.join("dipole_common.wgsl")).unwrap(), DIPOLE_COMMON);
}

#[test]
fn a_broken_shader_is_caught() {
    let broken = format!("{COMMON}\n@compute @workgroup_size(256) fn main() {{ let x: f32 = 1u; }}");
    assert!(naga::front::wgsl::parse_str(&broken)
        .map_err(|e| e.to_string())
        .and_then(|m| {
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
                .validate(&m)
                .map(|_| ())
                .map_err(|e| e.to_string())
        })
        .is_err());
}
