//! libFuzzer entry point of the `overrides` target: see [`specula_fuzz::overrides`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::overrides(data));
