//! Fuzz target: the CityGML reader must return `Ok` or a `ReadError` for any input, never
//! panic, hang or exhaust memory.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(model) = skylod::io::citygml::read_bytes(data, "fuzz.gml") {
        // Touch the result so that the derived data (bboxes) is computed too.
        for a in &model.assets {
            let _ = a.bbox();
        }
    }
});
