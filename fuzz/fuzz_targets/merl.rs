//! libFuzzer entry point of the `merl` target: see [`specula_fuzz::merl`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::merl(data));
