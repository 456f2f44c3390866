//! Any bytes as a Quake-family .bsp, with a fixed two-leaf portal file: read or refused with a
//! diagnostic, matched to the portal file or refused, written, and read back, without a panic
//! or an allocation sized by an unchecked count.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

const PRT: &str = "PRT1\n2\n1\n4 0 1 (64 0 0) (64 64 0) (64 64 64) (64 0 64)\n";

fuzz_target!(|data: &[u8]| {
    let Ok(bsp) = portcullis::bsp::parse(data.to_vec(), Path::new("fuzz.bsp")) else {
        return;
    };
    let _ = portcullis::bsp::stored(&bsp);
    let Ok((prt, _)) = portcullis::prt::parse(PRT, Path::new("fuzz.prt")) else {
        return;
    };
    let Ok(map) = portcullis::bsp::match_prt(&bsp, &prt, Path::new("fuzz.prt")) else {
        return;
    };
    let pvs = portcullis::vis::Pvs::identity(map.cells);
    if let Ok(w) = portcullis::bsp::visited(&bsp, &map, &pvs, &Default::default()) {
        let again = portcullis::bsp::parse(w.bytes, Path::new("fuzz.bsp"))
            .expect("what was written reads back");
        let _ = portcullis::bsp::stored(&again);
    }
});
