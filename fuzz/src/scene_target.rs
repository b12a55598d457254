//! The body of the `scene_toml` fuzz target: the scene-file parser of `transcut render`
//! (`cli/src/scene_file/schema.rs`, the module `super::schema` wherever this file is included)
//! on the bytes, as UTF-8 with invalid bytes replaced. A panic is a finding.
//!
//! Shared by the `cargo fuzz` target and the CLI's smoke test of the corpus
//! (`cli/src/scene_file/mod.rs`), which includes this file as a module.

use super::schema::SceneFile;

/// The longest error message the parser may give, in bytes.
pub const MAX_MESSAGE_BYTES: usize = 1024;

/// Parses the bytes as a scene file: `Ok` with the number of objects, or the message.
///
/// # Panics
/// On a message longer than [`MAX_MESSAGE_BYTES`]: that is a finding.
pub fn scene_toml(data: &[u8]) -> Result<usize, String> {
    match SceneFile::parse(&String::from_utf8_lossy(data)) {
        Ok(file) => Ok(file.objects.len()),
        Err(e) => {
            let message = format!("{e:#}");
            assert!(message.len() <= MAX_MESSAGE_BYTES, "a message of {} bytes", message.len());
            Err(message)
        }
    }
}
