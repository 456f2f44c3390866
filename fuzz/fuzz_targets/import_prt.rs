//! Any bytes as a Quake portal file (.prt): parsed into a portal graph or refused with a
//! diagnostic, and a parsed graph's PVS computed by every method without a panic.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use portcullis::vis::{self, Method, VisOptions};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok((prt, _)) = portcullis::prt::parse(text, Path::new("fuzz.prt")) else {
        return;
    };
    let graph = prt.graph(None);
    for method in Method::ALL {
        let opts = VisOptions {
            method,
            samples: 20,
            threads: Some(1),
            ..Default::default()
        };
        let _ = vis::compute(&graph, &opts);
    }
});
