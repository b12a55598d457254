//! The bodies of the core's fuzz targets: each feeds the bytes to one reader of the library,
//! as the reader's file entry point would after its bounded read, and checks the answer. A
//! panic anywhere (in the reader, or in a check here) is a finding.
//!
//! Shared by the `cargo fuzz` targets (`fuzz/fuzz_targets/`) and by the stable-Rust smoke test
//! of the corpus (`core/tests/integration/fuzz_corpus.rs`), which includes this file as a module.

use transcut::light::EquirectMap;
use transcut::mesh::{parse_obj, parse_ply};
use transcut::volume::VoxelGrid;

/// The longest error message a reader may give, in bytes.
pub const MAX_MESSAGE_BYTES: usize = 1024;

/// What a reader answered: accepted, or refused with this message.
pub type Outcome = Result<(), String>;

/// Checks a reader's answer: an error's message is at most [`MAX_MESSAGE_BYTES`] long.
///
/// # Panics
/// On a longer message: that is a finding.
pub fn checked<T, E: std::fmt::Display>(result: Result<T, E>) -> Outcome {
    match result {
        Ok(_) => Ok(()),
        Err(e) => {
            let message = e.to_string();
            assert!(message.len() <= MAX_MESSAGE_BYTES, "a message of {} bytes: {}…", message.len(), &message[..200]);
            Err(message)
        }
    }
}

/// The OBJ reader on the bytes (as `load_obj` reads them: UTF-8 with invalid bytes replaced).
pub fn obj(data: &[u8]) -> Outcome {
    checked(parse_obj(&String::from_utf8_lossy(data), "fuzz.obj"))
}

/// The PLY reader on the bytes.
pub fn ply(data: &[u8]) -> Outcome {
    checked(parse_ply(data, "fuzz.ply"))
}

/// The TCVOX1 voxel-file reader on the bytes.
pub fn voxel(data: &[u8]) -> Outcome {
    checked(VoxelGrid::from_bytes(data))
}

/// The environment-map reader (Radiance HDR and OpenEXR, by magic number) on the bytes.
pub fn environment(data: &[u8]) -> Outcome {
    checked(EquirectMap::from_file_bytes(data, 1.0))
}
