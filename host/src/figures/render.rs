//! Pictures of faces: an RGB image type with PNG output and a tiny bitmap font, and a small,
//! deterministic software rasteriser (orthographic camera, z-buffer, Lambert shading smoothed by
//! per-vertex normals, 3×3 supersampling) for meshes coloured per vertex, with a heat-map colour
//! scale and colour bar for error figures.
//!
//! Everything here is plain `f32` arithmetic in a fixed order with no threads, so the same input
//! gives the same bytes on every run of the same build.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::io::atomic::AtomicWriteError;

/// Why a picture could not be written as a PNG; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PngError {
    /// An empty picture, or one whose pixel bytes do not match its size.
    #[error(
        "{}: cannot write a {width}x{height} picture with {bytes} bytes of pixels (PNG needs a \
         non-empty picture of {expected} bytes)",
        path.display()
    )]
    BadPicture {
        /// The PNG file.
        path: PathBuf,
        /// The picture's width.
        width: u32,
        /// The picture's height.
        height: u32,
        /// Its bytes of pixels.
        bytes: usize,
        /// The bytes its size needs.
        expected: usize,
    },
    /// The encoder or the atomic write failed.
    #[error("{}: cannot write PNG", path.display())]
    Write {
        /// The PNG file.
        path: PathBuf,
        /// The failed write.
        #[source]
        source: AtomicWriteError,
    },
}

/// The light grey behind rendered meshes.
pub const BACKGROUND: [u8; 3] = [235, 235, 235];

/// Width of one character cell of the built-in font at scale 1, in pixels (5 glyph columns + 1).
pub const GLYPH_ADVANCE: u32 = 6;
/// Height of one text line of the built-in font at scale 1, in pixels (7 rows, 1 descender, 1 gap).
pub const LINE_HEIGHT: u32 = 9;

/// An 8-bit RGB picture, rows top to bottom, pixels left to right, 3 bytes per pixel.
#[derive(Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 3` bytes, row-major from the top-left corner.
    pub rgb: Vec<u8>,
}

impl fmt::Debug for Image {
    // The pixel bytes would drown any log, so only the size is shown.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Image")
            .field("width", &self.width)
            .field("height", &self.height)
            .finish_non_exhaustive()
    }
}

impl Image {
    /// A `width` × `height` picture filled with `background`.
    pub fn new(width: u32, height: u32, background: [u8; 3]) -> Image {
        let n = width as usize * height as usize;
        let mut rgb = Vec::with_capacity(n * 3);
        for _ in 0..n {
            rgb.extend_from_slice(&background);
        }
        Image { width, height, rgb }
    }

    /// The colour at (`x`, `y`), or `None` outside the picture.
    pub fn get(&self, x: i64, y: i64) -> Option<[u8; 3]> {
        let i = self.index(x, y)?;
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }

    /// Sets the colour at (`x`, `y`); points outside the picture are ignored.
    pub fn set(&mut self, x: i64, y: i64, color: [u8; 3]) {
        if let Some(i) = self.index(x, y) {
            self.rgb[i..i + 3].copy_from_slice(&color);
        }
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        if x < 0 || y < 0 || x >= i64::from(self.width) || y >= i64::from(self.height) {
            return None;
        }
        Some((y as usize * self.width as usize + x as usize) * 3)
    }

    /// Fills the rectangle with top-left corner (`x`, `y`) and size `w` × `h`, clipped to the picture.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: i64, h: i64, color: [u8; 3]) {
        let x0 = x.max(0);
        let y0 = y.max(0);
        let x1 = x.saturating_add(w).min(i64::from(self.width));
        let y1 = y.saturating_add(h).min(i64::from(self.height));
        for yy in y0..y1 {
            for xx in x0..x1 {
                self.set(xx, yy, color);
            }
        }
    }

    /// Draws the outline of a rectangle, one pixel wide, clipped to the picture.
    pub fn stroke_rect(&mut self, x: i64, y: i64, w: i64, h: i64, color: [u8; 3]) {
        if w <= 0 || h <= 0 {
            return;
        }
        self.fill_rect(x, y, w, 1, color);
        self.fill_rect(x, y + h - 1, w, 1, color);
        self.fill_rect(x, y, 1, h, color);
        self.fill_rect(x + w - 1, y, 1, h, color);
    }

    /// Draws a straight line from (`x0`, `y0`) to (`x1`, `y1`) (pixel coordinates, rounded) with
    /// Bresenham's algorithm, stamping a `thickness` × `thickness` square at every step.
    pub fn line(&mut self, x0: f32, y0: f32, x1: f32, y1: f32, color: [u8; 3], thickness: u32) {
        // Far-off or non-finite ends would make the step loop run for ever; nothing this crate
        // draws lies outside a few picture widths, so such lines are simply skipped.
        const FAR: f32 = 1.0e6;
        if ![x0, y0, x1, y1]
            .iter()
            .all(|v| v.is_finite() && v.abs() < FAR)
        {
            return;
        }
        let t = i64::from(thickness.max(1));
        let off = (t - 1) / 2;
        let (mut x, mut y) = (x0.round() as i64, y0.round() as i64);
        let (xe, ye) = (x1.round() as i64, y1.round() as i64);
        let dx = (xe - x).abs();
        let dy = -(ye - y).abs();
        let sx = if x < xe { 1 } else { -1 };
        let sy = if y < ye { 1 } else { -1 };
        let mut err = dx + dy;
        loop {
            self.fill_rect(x - off, y - off, t, t, color);
            if x == xe && y == ye {
                break;
            }
            let e2 = 2 * err;
            if e2 >= dy {
                err += dy;
                x += sx;
            }
            if e2 <= dx {
                err += dx;
                y += sy;
            }
        }
    }

    /// Copies `src` into this picture with its top-left corner at (`x`, `y`), clipped.
    pub fn blit(&mut self, src: &Image, x: i64, y: i64) {
        for sy in 0..i64::from(src.height) {
            for sx in 0..i64::from(src.width) {
                if let Some(c) = src.get(sx, sy) {
                    self.set(x + sx, y + sy, c);
                }
            }
        }
    }

    /// Places `images` side by side, top-aligned; shorter ones are padded below with
    /// [`BACKGROUND`]. An empty slice gives a 0 × 0 picture.
    pub fn hstack(images: &[Image]) -> Image {
        let width = images.iter().map(|i| i.width).sum();
        let height = images.iter().map(|i| i.height).max().unwrap_or(0);
        let mut out = Image::new(width, height, BACKGROUND);
        let mut x = 0i64;
        for im in images {
            out.blit(im, x, 0);
            x += i64::from(im.width);
        }
        out
    }

    /// The pictures one above the other, left-aligned, on [`BACKGROUND`].
    pub fn vstack(images: &[Image]) -> Image {
        let width = images.iter().map(|i| i.width).max().unwrap_or(0);
        let height = images.iter().map(|i| i.height).sum();
        let mut out = Image::new(width, height, BACKGROUND);
        let mut y = 0i64;
        for im in images {
            out.blit(im, 0, y);
            y += i64::from(im.height);
        }
        out
    }

    /// The picture shrunk by `factor` in each direction, each pixel the mean of the `factor` ×
    /// `factor` block it covers (a box filter, rounded to nearest); a partial block at the right or
    /// bottom edge is dropped. A factor of 0 or 1 returns the picture unchanged.
    pub fn downsample(&self, factor: u32) -> Image {
        if factor <= 1 {
            return self.clone();
        }
        let (w, h) = (self.width / factor, self.height / factor);
        let mut out = Image::new(w, h, BACKGROUND);
        let n = factor * factor;
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0u32; 3];
                for dy in 0..factor {
                    let row = (y * factor + dy) as usize * self.width as usize;
                    for dx in 0..factor {
                        let i = (row + (x * factor + dx) as usize) * 3;
                        for (s, &v) in sum.iter_mut().zip(&self.rgb[i..i + 3]) {
                            *s += u32::from(v);
                        }
                    }
                }
                out.set(
                    i64::from(x),
                    i64::from(y),
                    sum.map(|v| ((v + n / 2) / n) as u8),
                );
            }
        }
        out
    }

    /// Writes the picture as an 8-bit RGB PNG, atomically (temporary file, then rename).
    pub fn save_png(&self, path: &Path) -> Result<(), PngError> {
        let expected = self.width as usize * self.height as usize * 3;
        if self.width == 0 || self.height == 0 || self.rgb.len() != expected {
            return Err(PngError::BadPicture {
                path: path.to_path_buf(),
                width: self.width,
                height: self.height,
                bytes: self.rgb.len(),
                expected,
            });
        }
        crate::io::atomic::write_with(path, |w| {
            let mut enc = png::Encoder::new(w, self.width, self.height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut writer = enc.write_header().map_err(std::io::Error::other)?;
            writer
                .write_image_data(&self.rgb)
                .map_err(std::io::Error::other)?;
            writer.finish().map_err(std::io::Error::other)
        })
        .map_err(|source| PngError::Write {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Draws `s` with the built-in 5 × 7 font, each font pixel a `scale` × `scale` square, with the
    /// top-left corner of the first character cell at (`x`, `y`). `'\n'` starts a new line;
    /// characters the font lacks are drawn as `?`. See [`text_width`] for layout.
    pub fn text(&mut self, x: i64, y: i64, s: &str, color: [u8; 3], scale: u32) {
        let k = i64::from(scale.max(1));
        let (mut cx, mut cy) = (x, y);
        for ch in s.chars() {
            if ch == '\n' {
                cx = x;
                cy += i64::from(LINE_HEIGHT) * k;
                continue;
            }
            for (r, row) in glyph(ch).split(' ').enumerate() {
                for (c, b) in row.bytes().enumerate() {
                    if b == b'#' {
                        self.fill_rect(cx + c as i64 * k, cy + r as i64 * k, k, k, color);
                    }
                }
            }
            cx += i64::from(GLYPH_ADVANCE) * k;
        }
    }
}

/// Width in pixels of the longest line of `s` drawn by [`Image::text`] at `scale`
/// (including the one-pixel gap after the last character).
pub fn text_width(s: &str, scale: u32) -> u32 {
    let longest = s.split('\n').map(|l| l.chars().count()).max().unwrap_or(0);
    (longest as u32)
        .saturating_mul(GLYPH_ADVANCE)
        .saturating_mul(scale.max(1))
}

/// The text scale that keeps labels readable on a picture of this size: 1 up to 599 pixels on the
/// shorter side, 2 from 600, 3 from 1200, and so on.
pub fn text_scale(width: u32, height: u32) -> u32 {
    (width.min(height) / 600 + 1).max(1)
}

mod font;
#[cfg(test)]
use font::FONT;
use font::glyph;

/// An orthographic camera. The mesh is turned by `yaw_deg` about the y axis (positive turns its
/// +z side toward +x, the right of the picture), then by `pitch_deg` about the x axis (positive
/// turns its +z side down, so the camera looks from above), and viewed along −z with +y up. The
/// turned mesh's bounding box is fitted into the `width` × `height` picture with a margin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Turn about the vertical (y) axis, degrees.
    pub yaw_deg: f32,
    /// Turn about the horizontal (x) axis after the yaw, degrees.
    pub pitch_deg: f32,
    /// Picture width in pixels.
    pub width: u32,
    /// Picture height in pixels.
    pub height: u32,
}

impl View {
    /// Straight-on view (yaw 0, pitch 0) of the given size.
    pub fn front(width: u32, height: u32) -> View {
        View {
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            width,
            height,
        }
    }
}

/// Margin left around the fitted mesh on each side, as a fraction of the shorter picture side.
const FIT_MARGIN: f32 = 0.05;
/// Colour of vertices that `colors` does not cover.
const DEFAULT_COLOR: [u8; 3] = [200, 200, 200];
/// Share of a colour kept on surfaces facing away from the light.
const AMBIENT: f32 = 0.4;
/// Unit direction toward the light: front, upper left. It sits near the camera so that heat-map
/// colours stay close to their scale (a colour bar is only readable if shading darkens little),
/// yet far enough off-axis to show the shape.
const LIGHT: [f32; 3] = [-0.268_328_16, 0.357_770_9, 0.894_427_2];

/// Supersampling factor of [`render`]: every picture is drawn at 3 × 3 times its size and
/// box-filtered down, so edges and silhouettes are anti-aliased.
pub const SUPERSAMPLE: u32 = 3;

/// Rasterises the mesh as seen by `view`: vertices turned and fitted as [`View`] describes,
/// triangles filled where sample centres fall inside them (z-buffered, the nearer surface wins;
/// on exact ties the earlier triangle stays), colours interpolated barycentrically from the
/// per-vertex `colors`, then shaded by `AMBIENT + (1 − AMBIENT)·|n·l|` with `n` the
/// barycentric blend of the vertex normals (area-weighted triangle normals around each vertex;
/// two-sided, so open meshes and inward-wound faces light the same): smooth shading, no facets.
/// Drawn at [`SUPERSAMPLE`] times the size in each direction and box-filtered down
/// ([`Image::downsample`]).
///
/// Bad input never panics: triangles with an out-of-range index or a non-finite corner, and
/// degenerate (zero-area) ones, are skipped; vertices beyond `colors` are drawn light grey; the
/// fit uses only finite vertices. An empty mesh gives a plain [`BACKGROUND`] picture.
pub fn render(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    colors: &[[u8; 3]],
    view: &View,
) -> Image {
    let (Some(width), Some(height)) = (
        view.width.checked_mul(SUPERSAMPLE),
        view.height.checked_mul(SUPERSAMPLE),
    ) else {
        return Image::new(view.width, view.height, BACKGROUND);
    };
    let big = View {
        width,
        height,
        ..*view
    };
    rasterise(positions, triangles, colors, &big).downsample(SUPERSAMPLE)
}

/// Area-weighted vertex normals of the drawable triangles (unit length, or zero for a vertex in
/// none of them): each triangle adds its unnormalised normal to its corners.
fn vertex_normals(turned: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut normals = vec![[0.0f32; 3]; turned.len()];
    for tri in triangles {
        let idx = tri.map(|i| i as usize);
        if idx.iter().any(|&i| i >= turned.len()) {
            continue;
        }
        let (a, b, c) = (turned[idx[0]], turned[idx[1]], turned[idx[2]]);
        let n = cross(sub(b, a), sub(c, a));
        if !n.iter().all(|v| v.is_finite()) {
            continue;
        }
        for &i in &idx {
            for k in 0..3 {
                normals[i][k] += n[k];
            }
        }
    }
    for n in &mut normals {
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        *n = if len > 0.0 && len.is_finite() {
            n.map(|v| v / len)
        } else {
            [0.0; 3]
        };
    }
    normals
}

/// [`render`] without the supersampling: one sample at each pixel centre.
fn rasterise(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    colors: &[[u8; 3]],
    view: &View,
) -> Image {
    let mut img = Image::new(view.width, view.height, BACKGROUND);
    if view.width == 0 || view.height == 0 {
        return img;
    }
    let (sy, cy) = view.yaw_deg.to_radians().sin_cos();
    let (sp, cp) = view.pitch_deg.to_radians().sin_cos();
    // Rotate every vertex once: yaw about y, then pitch about x.
    let turned: Vec<[f32; 3]> = positions
        .iter()
        .map(|&[x, y, z]| {
            let x1 = cy * x + sy * z;
            let z1 = -sy * x + cy * z;
            let y2 = cp * y - sp * z1;
            let z2 = sp * y + cp * z1;
            [x1, y2, z2]
        })
        .collect();

    // Fit the finite vertices' x/y bounding box into the frame, keeping the aspect ratio.
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for p in turned.iter().filter(|p| p.iter().all(|v| v.is_finite())) {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
        return img;
    }
    let (w, h) = (view.width as f32, view.height as f32);
    let margin = FIT_MARGIN * w.min(h);
    let span = [(hi[0] - lo[0]).max(1e-30), (hi[1] - lo[1]).max(1e-30)];
    let scale = ((w - 2.0 * margin) / span[0])
        .min((h - 2.0 * margin) / span[1])
        .max(0.0);
    let centre = [(lo[0] + hi[0]) * 0.5, (lo[1] + hi[1]) * 0.5];
    // Screen x right, screen y down; z kept as depth (larger = nearer the camera).
    let screen: Vec<[f32; 3]> = turned
        .iter()
        .map(|&[x, y, z]| {
            [
                w * 0.5 + (x - centre[0]) * scale,
                h * 0.5 - (y - centre[1]) * scale,
                z,
            ]
        })
        .collect();

    let normals = vertex_normals(&turned, triangles);
    let mut depth = vec![f32::NEG_INFINITY; view.width as usize * view.height as usize];
    let vcolor = |i: usize| -> [f32; 3] {
        let c = colors.get(i).copied().unwrap_or(DEFAULT_COLOR);
        [f32::from(c[0]), f32::from(c[1]), f32::from(c[2])]
    };
    let (wi, hi_px) = (view.width as i64, view.height as i64);

    for tri in triangles {
        let idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        let (Some(&a), Some(&b), Some(&c)) =
            (screen.get(idx[0]), screen.get(idx[1]), screen.get(idx[2]))
        else {
            continue;
        };
        if ![a, b, c].iter().flatten().all(|v| v.is_finite()) {
            continue;
        }
        // Twice the signed screen area; its sign is the winding, which we normalise away so
        // both windings fill (two-sided rendering).
        let area = edge(a, b, c);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        let (b, c, ib, ic) = if area > 0.0 {
            (b, c, idx[1], idx[2])
        } else {
            (c, b, idx[2], idx[1])
        };
        let area = area.abs();

        // The triangle's own (view-space) normal stands in where the vertex normals cancel out.
        let (ta, tb, tc) = (turned[idx[0]], turned[idx[1]], turned[idx[2]]);
        let face = cross(sub(tb, ta), sub(tc, ta));
        let (na, nb, nc) = (normals[idx[0]], normals[ib], normals[ic]);
        let (ca, cb, cc) = (vcolor(idx[0]), vcolor(ib), vcolor(ic));

        let x0 = (a[0].min(b[0]).min(c[0]).floor() as i64).max(0);
        let x1 = (a[0].max(b[0]).max(c[0]).ceil() as i64).min(wi - 1);
        let y0 = (a[1].min(b[1]).min(c[1]).floor() as i64).max(0);
        let y1 = (a[1].max(b[1]).max(c[1]).ceil() as i64).min(hi_px - 1);
        for py in y0..=y1 {
            for px in x0..=x1 {
                let p = [px as f32 + 0.5, py as f32 + 0.5, 0.0];
                // Barycentric weights: each is the sub-triangle area opposite its vertex.
                let wa = edge(b, c, p);
                let wb = edge(c, a, p);
                let wc = edge(a, b, p);
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let (la, lb, lc) = (wa / area, wb / area, wc / area);
                let z = la * a[2] + lb * b[2] + lc * c[2];
                let di = py as usize * view.width as usize + px as usize;
                if z <= depth[di] {
                    continue;
                }
                depth[di] = z;
                // Smooth shading: the vertex normals blended like the colours; |n·l| makes it
                // two-sided.
                let mut n = [0.0f32; 3];
                for k in 0..3 {
                    n[k] = la * na[k] + lb * nb[k] + lc * nc[k];
                }
                let mut len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                if !(len > 1e-6 && len.is_finite()) {
                    n = face;
                    len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                }
                let lambert = if len > 0.0 && len.is_finite() {
                    ((n[0] * LIGHT[0] + n[1] * LIGHT[1] + n[2] * LIGHT[2]) / len).abs()
                } else {
                    1.0
                };
                let shade = AMBIENT + (1.0 - AMBIENT) * lambert;
                let mut rgb = [0u8; 3];
                for k in 0..3 {
                    let v = (la * ca[k] + lb * cb[k] + lc * cc[k]) * shade;
                    rgb[k] = v.round().clamp(0.0, 255.0) as u8;
                }
                img.set(px, py, rgb);
            }
        }
    }
    img
}

/// The edge function: twice the signed area of the screen triangle (a, b, p). Only its sign
/// relative to the whole triangle's area matters, which is why either winding works.
fn edge(a: [f32; 3], b: [f32; 3], p: [f32; 3]) -> f32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Colour for NaN values in a heat map.
pub const NAN_COLOR: [u8; 3] = [128, 128, 128];

/// Heat-map stops, low to high: dark blue, blue, cyan, yellow, red. Lightness rises from the
/// dark-blue end to yellow, so small errors recede and large ones stand out, as in the papers'
/// per-vertex error figures.
const RAMP: [(f32, [f32; 3]); 5] = [
    (0.0, [15.0, 25.0, 110.0]),
    (0.2, [30.0, 90.0, 220.0]),
    (0.45, [20.0, 210.0, 230.0]),
    (0.72, [250.0, 225.0, 40.0]),
    (1.0, [205.0, 20.0, 20.0]),
];

/// The heat-map colour at `t` ∈ [0, 1] (clamped), interpolated linearly between the stops.
fn ramp(t: f32) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0);
    let mut i = 0;
    while i + 2 < RAMP.len() && t > RAMP[i + 1].0 {
        i += 1;
    }
    let (t0, c0) = RAMP[i];
    let (t1, c1) = RAMP[i + 1];
    let f = (t - t0) / (t1 - t0);
    let mut out = [0u8; 3];
    for k in 0..3 {
        out[k] = (c0[k] + (c1[k] - c0[k]) * f).round().clamp(0.0, 255.0) as u8;
    }
    out
}

/// Maps each value to a heat-map colour: dark blue at `lo`, through cyan and yellow, to red at
/// `hi`; values outside are clamped, NaN is [`NAN_COLOR`]. If `hi <= lo` (or either is not
/// finite), values above `lo` are red and the rest dark blue.
pub fn heatmap(values: &[f32], lo: f32, hi: f32) -> Vec<[u8; 3]> {
    let span = hi - lo;
    values
        .iter()
        .map(|&v| {
            if v.is_nan() {
                NAN_COLOR
            } else if span > 0.0 && span.is_finite() {
                ramp((v - lo) / span)
            } else {
                ramp(if v > lo { 1.0 } else { 0.0 })
            }
        })
        .collect()
}

/// Formats a value with about three significant digits, switching to `1.5e-4` style outside
/// [0.01, 10000), for ticks and colour-bar labels.
pub fn format_value(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return if v.is_nan() {
            "NaN".into()
        } else if v == 0.0 {
            "0".into()
        } else if v > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    let a = v.abs();
    if !(0.01..10000.0).contains(&a) {
        let s = format!("{v:.2e}");
        // "1.50e-4" → "1.5e-4", "1.00e2" → "1e2".
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        return format!("{}e{}", trim_zeros(m), e);
    }
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    trim_zeros(&format!("{v:.decimals$}")).to_string()
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// Geometry of the colour bar [`colorbar`] draws on a picture of this size, so callers can keep
/// that strip clear: (strip width from the right edge, text scale).
fn colorbar_layout(width: u32, height: u32, lo: f32, hi: f32, label: &str) -> (u32, u32) {
    let s = text_scale(width, height);
    let pad = 4 * s;
    let bar_w = 8 * s;
    let labels = [lo, (lo + hi) * 0.5, hi].map(|v| format_value(f64::from(v)));
    let text_w = labels.iter().map(|l| text_width(l, s)).max().unwrap_or(0);
    let strip = (pad + bar_w + pad + text_w + pad).max(text_width(label, s) + 2 * pad);
    (strip, s)
}

/// Width of the strip at the right edge that [`colorbar`] uses on a `width` × `height` picture.
pub fn colorbar_width(width: u32, height: u32, lo: f32, hi: f32, label: &str) -> u32 {
    colorbar_layout(width, height, lo, hi, label).0
}

/// Draws a vertical heat-map colour bar at the right edge of `image` (see [`colorbar_width`]):
/// `hi` at the top, `lo` at the bottom, their midpoint in between, and `label` above it.
pub fn colorbar(image: &mut Image, lo: f32, hi: f32, label: &str) {
    let (w, h) = (image.width, image.height);
    let (strip, s) = colorbar_layout(w, h, lo, hi, label);
    let pad = i64::from(4 * s);
    let bar_w = i64::from(8 * s);
    let x0 = i64::from(w) - i64::from(strip) + pad;
    let top = i64::from(h) / 5;
    let bottom = i64::from(h) - i64::from(h) / 6;
    if bottom <= top {
        return;
    }
    for y in top..=bottom {
        let t = (bottom - y) as f32 / (bottom - top) as f32;
        image.fill_rect(x0, y, bar_w, 1, ramp(t));
    }
    let ink = [20, 20, 20];
    image.stroke_rect(x0 - 1, top - 1, bar_w + 2, bottom - top + 3, ink);
    let half_line = i64::from(7 * s) / 2;
    let tx = x0 + bar_w + pad;
    let mid = (top + bottom) / 2;
    for (v, y) in [(hi, top), ((lo + hi) * 0.5, mid), (lo, bottom)] {
        image.fill_rect(x0 + bar_w, y, pad / 2, 1, ink);
        image.text(tx, y - half_line, &format_value(f64::from(v)), ink, s);
    }
    let lw = i64::from(text_width(label, s));
    let lx = (i64::from(w) - pad - lw).min(x0);
    image.text(lx, top - i64::from(LINE_HEIGHT * s) - pad, label, ink, s);
}

/// A heat-map figure: the mesh coloured by per-vertex `values` on the [`heatmap`] scale from `lo`
/// to `hi`, rendered by [`render`] into the part of the `view.width` × `view.height` picture left
/// free by `title` (top-left) and the colour bar labelled `label` (right edge).
#[allow(clippy::too_many_arguments)] // Mirrors the figure's parts one to one; a struct would only rename them.
pub fn render_heatmap(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    values: &[f32],
    lo: f32,
    hi: f32,
    label: &str,
    title: &str,
    view: &View,
) -> Image {
    let (w, h) = (view.width, view.height);
    let mut out = Image::new(w, h, BACKGROUND);
    let (strip, s) = colorbar_layout(w, h, lo, hi, label);
    let title_h = if title.is_empty() {
        0
    } else {
        LINE_HEIGHT * s + 8 * s
    };
    let mesh_view = View {
        width: w.saturating_sub(strip),
        height: h.saturating_sub(title_h),
        ..*view
    };
    let colors = heatmap(values, lo, hi);
    out.blit(
        &render(positions, triangles, &colors, &mesh_view),
        0,
        i64::from(title_h),
    );
    colorbar(&mut out, lo, hi, label);
    if !title.is_empty() {
        out.text(i64::from(4 * s), i64::from(4 * s), title, [20, 20, 20], s);
    }
    out
}

#[cfg(test)]
mod tests;
