#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = transcut_fuzz::scene_target::scene_toml(data);
});
