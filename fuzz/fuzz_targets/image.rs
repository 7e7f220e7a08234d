//! libFuzzer entry point of the `image` target: see [`specula_fuzz::image`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::image(data));
