//! libFuzzer entry point of the `spec` target: see [`specula_fuzz::spec`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::spec(data));
