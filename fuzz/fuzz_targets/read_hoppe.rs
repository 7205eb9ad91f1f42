//! Fuzzes the HoppeM reader: any bytes must give a scene or an error, never a panic,
//! and an accepted scene must be valid and writable.
#![no_main]

use libfuzzer_sys::fuzz_target;
use meshlod::io::{read_scene_from_bytes, write_scene_to_bytes, Format, WriteOptions};

fuzz_target!(|data: &[u8]| {
    if let Ok(scene) = read_scene_from_bytes(data, Format::HoppeM, None) {
        for part in &scene.parts {
            assert!(part.mesh.validate().is_ok());
        }
        let _ = write_scene_to_bytes(&scene, Format::HoppeM, &WriteOptions::default());
    }
});
