//! libFuzzer entry point of the `obj` target: see [`specula_fuzz::obj`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::obj(data));
