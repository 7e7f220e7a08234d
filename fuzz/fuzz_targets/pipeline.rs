//! libFuzzer entry point of the `pipeline` target: see [`specula_fuzz::pipeline`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::pipeline(data));
