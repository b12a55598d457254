#![no_main]

// The environment-map reader; the exr corpus seeds it with exr files (the format is chosen by
// magic number, so the fuzzer may also cross into the other format).
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = transcut_fuzz::core_targets::environment(data);
});
