//! Turns the golden live track (`tests/data/driver-ict-live.csv`) into the frames a tracker
//! hands a device (`track::Frames`, in `OUT_DIR/driver-ict-live.frames`), read with the crate's
//! own CSV reader (`src/track.rs`); see that file for why.

use std::path::PathBuf;
use std::{env, fs};

#[allow(dead_code)]
#[path = "src/track.rs"]
mod track;

/// The live track, from this crate's folder.
const LIVE_CSV: &str = "../../tests/data/driver-ict-live.csv";

fn main() {
    println!("cargo::rerun-if-changed={LIVE_CSV}");
    println!("cargo::rerun-if-changed=src/track.rs");
    let text = fs::read(LIVE_CSV).unwrap_or_else(|e| panic!("{LIVE_CSV}: {e}"));
    // The landmarks are the header's x_ columns; the target checks their count against the
    // driver's.
    let header = text.split(|&b| b == b'\n').next().unwrap_or_default();
    let landmarks = String::from_utf8_lossy(header)
        .split(',')
        .filter(|c| c.trim().starts_with("x_"))
        .count();
    let track = track::Track::parse(&text, landmarks)
        .unwrap_or_else(|| panic!("{LIVE_CSV}: no timestamp, x_0…, y_0… columns"));
    let count = |n: usize| u32::try_from(n).expect("a count that fits in u32");
    let mut out = Vec::new();
    out.extend(count(track.rows).to_le_bytes());
    out.extend(count(landmarks).to_le_bytes());
    let mut pixels = vec![0.0f32; 2 * landmarks];
    for row in 0..track.rows {
        let (Some(time), Some(found)) = (track.row(row, &mut pixels), track.found(row)) else {
            panic!("{LIVE_CSV}: row {} is not a track row", row + 1);
        };
        let head = [time, if found { 1.0 } else { 0.0 }];
        for v in head.iter().chain(&pixels) {
            out.extend(v.to_le_bytes());
        }
    }
    let dir = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let path = dir.join("driver-ict-live.frames");
    fs::write(&path, out).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}
