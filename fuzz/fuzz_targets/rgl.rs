//! libFuzzer entry point of the `rgl` target: see [`specula_fuzz::rgl`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::rgl(data));
