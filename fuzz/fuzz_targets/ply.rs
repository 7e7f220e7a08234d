//! libFuzzer entry point of the `ply` target: see [`specula_fuzz::ply`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::ply(data));
