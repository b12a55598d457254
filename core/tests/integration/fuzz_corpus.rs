//! The fuzz corpus (`fuzz/corpus/`) through the bodies of the core's fuzz targets
//! (`fuzz/src/core_targets.rs`, the functions `cargo fuzz` calls): no panic, every message at
//! most 1 KiB, the seeds named `ok_*` accepted and `bad_*` refused, and each file read through
//! its file entry point (the bounded read) with the same answer as from its bytes.
//!
//! `fuzz_core_mutations` (ignored: run it with `--ignored`) mutates the corpus at random for
//! `TRANSCUT_FUZZ_SECONDS` per target (default 60), see `fuzz/src/mutate.rs`.

#[allow(dead_code)]
#[path = "../../../fuzz/src/core_targets.rs"]
mod core_targets;
#[allow(dead_code)]
#[path = "../../../fuzz/src/mutate.rs"]
mod mutate;

use std::path::{Path, PathBuf};

use core_targets::{checked, Outcome};
use transcut::light::EquirectMap;
use transcut::volume::VoxelGrid;

/// The target's body and its file entry point.
type Target = (&'static str, fn(&[u8]) -> Outcome, fn(&Path) -> Outcome);

const TARGETS: [Target; 5] = [
    ("obj", core_targets::obj, |p| checked(transcut::mesh::load_obj(p))),
    ("ply", core_targets::ply, |p| checked(transcut::mesh::load_ply(p))),
    ("voxel", core_targets::voxel, |p| checked(VoxelGrid::read(p))),
    ("hdr", core_targets::environment, |p| checked(EquirectMap::load(p, 1.0))),
    ("exr", core_targets::environment, |p| checked(EquirectMap::load(p, 1.0))),
];

#[test]
fn every_corpus_file_gets_its_answer() {
    for (target, body, load) in TARGETS {
        let files = mutate::corpus(target);
        let (mut ok, mut bad) = (0, 0);
        for (path, bytes) in &files {
            let name = path.file_name().unwrap().to_str().unwrap();
            let from_bytes = body(bytes);
            let from_file = load(path);
            assert_eq!(from_bytes.is_ok(), from_file.is_ok(), "{target}/{name}: {from_bytes:?} vs {from_file:?}");
            if name.starts_with("ok_") {
                assert!(from_bytes.is_ok(), "{target}/{name}: refused: {from_bytes:?}");
                ok += 1;
            } else {
                assert!(name.starts_with("bad_"), "{target}/{name}: name it ok_* or bad_*");
                let message = from_bytes.expect_err(name);
                assert!(!message.is_empty() && message.len() <= 1024, "{target}/{name}: {message}");
                bad += 1;
            }
        }
        assert!(ok >= 2 && bad >= 3, "{target}: {ok} ok and {bad} bad seeds");
    }
}

#[test]
#[ignore = "a fuzzing run: TRANSCUT_FUZZ_SECONDS per target (default 60)"]
fn fuzz_core_mutations() {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-findings");
    for (target, body, _) in TARGETS {
        let runs = mutate::run(target, mutate::seconds(), &out, body);
        println!("{target}: {runs} inputs, no finding");
    }
}
