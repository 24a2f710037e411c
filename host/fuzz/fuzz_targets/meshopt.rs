//! Any bytes as an `EXT_meshopt_compression` (or `KHR_meshopt_compression`) view: the first
//! five bytes choose the extension, mode, filter, stride (1 to 256) and count (below 2^24), the
//! rest is the compressed stream. The view is checked and decoded as the glTF rig reader does
//! it; an error is fine, a panic or an abort (a decoder precondition left unchecked) is a
//! finding. Seeds: the views of rigs packed by `gltfpack -c` and `-cc` (docs/ROBUSTNESS.md).

#![no_main]

use libfuzzer_sys::fuzz_target;

#[path = "../../src/io/rig/gltf/meshopt.rs"]
#[allow(dead_code)]
mod view;

const MODES: [&str; 3] = ["ATTRIBUTES", "TRIANGLES", "INDICES"];
const FILTERS: [&str; 5] = ["NONE", "OCTAHEDRAL", "QUATERNION", "EXPONENTIAL", "COLOR"];

fuzz_target!(|data: &[u8]| {
    let [choice, stride, c0, c1, c2, stream @ ..] = data else {
        return;
    };
    let extension = if choice & 0x80 == 0 {
        "EXT_meshopt_compression"
    } else {
        "KHR_meshopt_compression"
    };
    let pick = usize::from(choice & 0x7f);
    let stride = usize::from(*stride) + 1;
    let count = u32::from_le_bytes([*c0, *c1, *c2, 0]) as usize;
    let value = serde_json::json!({
        "buffer": 0, "byteLength": stream.len(), "byteStride": stride, "count": count,
        "mode": MODES[pick % 3], "filter": FILTERS[(pick / 3) % 5],
    });
    if let Ok(c) = view::Compressed::parse(extension, &value) {
        if let Ok(out) = c.decode(stream, stride * count, None) {
            assert_eq!(out.len(), stride * count);
        }
    }
});
