//! The `capi_mesh` fuzz corpus (`fuzz/corpus/capi_mesh/`) through the body of the fuzz target
//! (`fuzz/src/capi_target.rs`): `tc_scene_add_mesh` and `tc_scene_add_tet_mesh` with arrays
//! decoded from each file, called as a C caller would. No panic crosses the ABI, a failed call
//! leaves the scene's object count as it was and sets a message of at most 1 KiB, the seeds
//! named `ok_*` are accepted by at least one entry point and `bad_*` by neither.
//!
//! `fuzz_capi_mutations` (ignored: run it with `--ignored`) mutates the corpus at random for
//! `TRANSCUT_FUZZ_SECONDS` (default 60), see `fuzz/src/mutate.rs`.

use crate::abi;
#[allow(dead_code)]
#[path = "../../../fuzz/src/capi_target.rs"]
mod capi_target;
#[allow(dead_code)]
#[path = "../../../fuzz/src/mutate.rs"]
mod mutate;

use abi::{TC_INVALID_MESH, TC_OK};

#[test]
fn every_corpus_file_gets_its_answer() {
    let files = mutate::corpus("capi_mesh");
    let (mut ok, mut bad) = (0, 0);
    for (path, bytes) in &files {
        let name = path.file_name().unwrap().to_str().unwrap();
        let [tri, tet] = capi_target::capi_mesh(bytes);
        for s in [tri, tet] {
            assert!(s == TC_OK || s == TC_INVALID_MESH, "{name}: status {s:?}");
        }
        if name.starts_with("ok_") {
            assert!(tri == TC_OK || tet == TC_OK, "{name}: refused by both");
            ok += 1;
        } else {
            assert!(name.starts_with("bad_"), "{name}: name it ok_* or bad_*");
            assert!(tri != TC_OK && tet != TC_OK, "{name}: accepted ({tri:?}, {tet:?})");
            bad += 1;
        }
    }
    assert!(ok >= 2 && bad >= 3, "{ok} ok and {bad} bad seeds");
}

#[test]
fn decoding_follows_the_documented_layout() {
    // Byte 0: two vertices; 24 bytes of coordinates, the last one cut short (read as 0 bytes);
    // no index.
    let mut data = vec![2u8];
    for x in [1.0f32, 2.0, 3.0, 4.0, 5.0] {
        data.extend_from_slice(&x.to_le_bytes());
    }
    data.extend_from_slice(&[0, 0]);
    let (positions, indices) = capi_target::decode(&data);
    assert_eq!(positions, [1.0, 2.0, 3.0, 4.0, 5.0, 0.0]);
    assert!(indices.is_empty());
    // One vertex, then two whole indices and a partial one (dropped).
    let mut data = vec![1u8];
    data.extend_from_slice(&[0; 12]);
    data.extend_from_slice(&7u32.to_le_bytes());
    data.extend_from_slice(&u32::MAX.to_le_bytes());
    data.push(9);
    assert_eq!(capi_target::decode(&data).1, [7, u32::MAX]);
}

#[test]
#[ignore = "a fuzzing run: TRANSCUT_FUZZ_SECONDS (default 60)"]
fn fuzz_capi_mutations() {
    let out = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-findings");
    let runs = mutate::run("capi_mesh", mutate::seconds(), &out, capi_target::capi_mesh);
    println!("capi_mesh: {runs} inputs, no finding");
}
