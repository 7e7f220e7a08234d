//! libFuzzer entry point of the `serialized` target: see [`specula_fuzz::serialized`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::serialized(data));
