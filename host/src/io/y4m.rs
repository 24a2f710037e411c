//! YUV4MPEG2 (`.y4m`) video out: the uncompressed stream that Chromium's fake camera
//! (`--use-file-for-fake-video-capture`), ffmpeg and MediaPipe's readers take as it is.
//!
//! # Layout
//! One header line, `YUV4MPEG2 W<width> H<height> F<num>:<den> Ip A1:1 C420jpeg`, then per frame
//! `FRAME\n` and its planes: Y (`width × height` bytes), then Cb and Cr (`⌈width/2⌉ ×
//! ⌈height/2⌉` bytes each, the mean of each 2 × 2 block, sited at its centre as `C420jpeg`
//! says). The colours are BT.601 in the limited ("TV") range, Y in 16–235 and Cb, Cr in
//! 16–240, which is what a reader assumes when the header names no range.

use std::io::Write;

/// The stream's header for `width` × `height` frames at `fps` frames a second (kept to three
/// decimals, as the rational `round(fps · 1000) / 1000`).
pub fn header(width: u32, height: u32, fps: f32) -> String {
    let num = (f64::from(fps) * 1000.0).round().max(1.0) as u64;
    let (num, den) = reduce(num, 1000);
    format!("YUV4MPEG2 W{width} H{height} F{num}:{den} Ip A1:1 C420jpeg\n")
}

fn reduce(a: u64, b: u64) -> (u64, u64) {
    let (mut x, mut y) = (a, b);
    while y != 0 {
        (x, y) = (y, x % y);
    }
    (a / x, b / x)
}

/// BT.601 limited-range Y, Cb, Cr of an 8-bit RGB colour (before rounding).
fn ycbcr(rgb: [u8; 3]) -> [f32; 3] {
    let [r, g, b] = rgb.map(f32::from);
    [
        16.0 + (65.481 * r + 128.553 * g + 24.966 * b) / 255.0,
        128.0 + (-37.797 * r - 74.203 * g + 112.0 * b) / 255.0,
        128.0 + (112.0 * r - 93.786 * g - 18.214 * b) / 255.0,
    ]
}

fn byte(v: f32) -> u8 {
    v.round().clamp(0.0, 255.0) as u8
}

/// One frame of `width` × `height` RGB pixels (3 bytes each, rows top to bottom) as the bytes that
/// follow `FRAME\n`.
///
/// # Panics
/// Never: a picture whose bytes do not match its size is cut or padded with black.
pub fn frame_planes(width: u32, height: u32, rgb: &[u8]) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
    let pixel = |x: usize, y: usize| -> [f32; 3] {
        let i = (y * w + x) * 3;
        match rgb.get(i..i + 3) {
            Some(p) => ycbcr([p[0], p[1], p[2]]),
            None => ycbcr([0, 0, 0]),
        }
    };
    let mut out = Vec::with_capacity(w * h + 2 * cw * ch);
    for y in 0..h {
        for x in 0..w {
            out.push(byte(pixel(x, y)[0]));
        }
    }
    let mut cb = Vec::with_capacity(cw * ch);
    let mut cr = Vec::with_capacity(cw * ch);
    for by in 0..ch {
        for bx in 0..cw {
            let mut sum = [0.0f32; 2];
            let mut n = 0.0f32;
            for y in (2 * by)..(2 * by + 2).min(h) {
                for x in (2 * bx)..(2 * bx + 2).min(w) {
                    let p = pixel(x, y);
                    sum[0] += p[1];
                    sum[1] += p[2];
                    n += 1.0;
                }
            }
            cb.push(byte(sum[0] / n));
            cr.push(byte(sum[1] / n));
        }
    }
    out.extend_from_slice(&cb);
    out.extend_from_slice(&cr);
    out
}

/// Writes one frame (`FRAME\n` and its planes) to `w`.
pub fn write_frame(w: &mut dyn Write, width: u32, height: u32, rgb: &[u8]) -> std::io::Result<()> {
    w.write_all(b"FRAME\n")?;
    w.write_all(&frame_planes(width, height, rgb))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_names_size_and_rate() {
        assert_eq!(
            header(640, 480, 30.0),
            "YUV4MPEG2 W640 H480 F30:1 Ip A1:1 C420jpeg\n"
        );
        assert_eq!(
            header(2, 2, 29.97),
            "YUV4MPEG2 W2 H2 F2997:100 Ip A1:1 C420jpeg\n"
        );
    }

    #[test]
    fn planes_hold_bt601_limited_range() {
        // 3 × 3 picture: white, black and red pixels; odd sizes round the chroma planes up.
        let mut rgb = vec![255u8; 27];
        rgb[3..6].copy_from_slice(&[0, 0, 0]);
        rgb[24..27].copy_from_slice(&[255, 0, 0]);
        let planes = frame_planes(3, 3, &rgb);
        assert_eq!(planes.len(), 9 + 2 * 4);
        assert_eq!(planes[0], 235, "white is Y 235");
        assert_eq!(planes[1], 16, "black is Y 16");
        assert_eq!(planes[8], 81, "red is Y 81");
        // The last chroma block holds the red pixel alone: Cb 90, Cr 240.
        assert_eq!(planes[9 + 3], 90);
        assert_eq!(planes[9 + 4 + 3], 240);
        // A grey block has no colour.
        assert_eq!(planes[9 + 1], 128);
    }
}
