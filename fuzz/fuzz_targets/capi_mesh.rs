#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = transcut_fuzz::capi_target::capi_mesh(data);
});
