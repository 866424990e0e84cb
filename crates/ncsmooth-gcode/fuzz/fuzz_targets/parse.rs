//! Fuzz target: `parse_bytes` must never panic, and whatever parses must write and parse
//! again.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ncsmooth_gcode::{parse_bytes, parse_str, write, ParseOptions, WriteOptions};

fuzz_target!(|data: &[u8]| {
    if let Ok(p) = parse_bytes(data, "fuzz", &ParseOptions::default()) {
        let opts = WriteOptions {
            decimals: 6,
            ..Default::default()
        };
        let text = write(&p.toolpath, &opts);
        let _ = parse_str(&text, "fuzz-written", &ParseOptions::default());
    }
});
