//! libFuzzer entry point of the `xml_scene` target: see [`specula_fuzz::xml_scene`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| specula_fuzz::xml_scene(data));
