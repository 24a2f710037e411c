//! Photographs of a face through a pinhole camera (`sinew render`): a perspective rasteriser
//! with a lit skin shading (albedo per vertex: skin, lips, brows, eyes; a key light, a fill light,
//! ambient light and a soft highlight) and eyeballs behind the eye openings (`eyes`) on a dark
//! background, so that a face detector and a
//! landmark tracker take the picture for a face. It gives a performance's frames as PNG and as a
//! `y4m` video, through the performance's own camera, so that a real tracker's landmarks can be
//! compared with the performance's truth.
//!
//! Plain `f32` arithmetic in a fixed order with no threads: the same input gives the same bytes.

use std::path::{Path, PathBuf};

use sinew_core::linalg::Vec3;

use super::render::{Image, PngError};
use crate::io::atomic::{self, AtomicWriteError, CreateFolderError};
use crate::io::performance::{Camera, Performance, PerformanceError};
use crate::io::y4m;

/// Behind the face: a dark grey, so that holes in the mesh (the open mouth) read as
/// shadow.
pub const BACKDROP: [u8; 3] = [58, 60, 66];
/// The skin's albedo.
pub const SKIN: [u8; 3] = [214, 160, 130];
/// The lips' albedo.
pub const LIPS: [u8; 3] = [170, 88, 86];
/// The brows' albedo.
pub const BROWS: [u8; 3] = [88, 62, 48];
/// The eyes' albedo (what of the mesh lies inside the eyelids' contour).
pub const EYES: [u8; 3] = [45, 38, 36];
/// Each frame is drawn at this many times its size in each direction and box-filtered down.
pub const SUPERSAMPLE: u32 = 3;

/// Share of the albedo lit by the ambient light.
const AMBIENT: f32 = 0.22;
/// The key light: its direction toward the light (upper left, in front; the camera looks along
/// −z with +y up) and its strength.
const KEY: ([f32; 3], f32) = ([-0.38, 0.46, 0.80], 0.72);
/// The fill light, from the right.
const FILL: ([f32; 3], f32) = ([0.70, 0.05, 0.71], 0.22);
/// The highlight's strength and Blinn–Phong exponent (skin is not a mirror).
const SPECULAR: (f32, f32) = (0.10, 24.0);

/// Draws the mesh as `camera` sees it: triangles z-buffered by depth, albedo and normals
/// interpolated perspective-correctly, both sides lit (the normal turned toward the camera),
/// drawn at `supersample` times the size and box-filtered down. Triangles with a corner behind
/// the camera, out of range or non-finite are skipped; vertices beyond `albedo` are skin.
pub fn photograph(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    albedo: &[[u8; 3]],
    camera: &Camera,
    supersample: u32,
) -> Image {
    let s = supersample.max(1);
    let big = Camera {
        width: camera.width.saturating_mul(s),
        height: camera.height.saturating_mul(s),
        fx: camera.fx * s as f32,
        fy: camera.fy * s as f32,
        cx: camera.cx * s as f32,
        cy: camera.cy * s as f32,
        position: camera.position,
    };
    rasterise(positions, triangles, albedo, &big).downsample(s)
}

fn rasterise(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    albedo: &[[u8; 3]],
    camera: &Camera,
) -> Image {
    let mut img = Image::new(camera.width, camera.height, BACKDROP);
    let (w, h) = (camera.width as usize, camera.height as usize);
    if w == 0 || h == 0 {
        return img;
    }
    let eye = Vec3::from_array(camera.position);
    // Per vertex: pixel, and 1 / depth (what interpolates linearly across the screen).
    let screen: Vec<Option<[f32; 3]>> = positions
        .iter()
        .map(|&p| {
            let depth = camera.position[2] - p[2];
            let uv = camera.project(p)?;
            (uv.iter().all(|v| v.is_finite()) && depth.is_finite())
                .then(|| [uv[0], uv[1], 1.0 / depth])
        })
        .collect();
    let normals = vertex_normals(positions, triangles);
    let colour = |i: usize| albedo.get(i).copied().unwrap_or(SKIN).map(f32::from);
    let lights = [KEY, FILL].map(|(d, k)| (Vec3::from_array(d).normalize(), k));
    let mut inv_depth = vec![0.0f32; w * h];
    for tri in triangles {
        let idx = tri.map(|i| i as usize);
        let (Some(Some(a)), Some(Some(b)), Some(Some(c))) = (
            screen.get(idx[0]).copied(),
            screen.get(idx[1]).copied(),
            screen.get(idx[2]).copied(),
        ) else {
            continue;
        };
        let area = edge(a, b, c);
        if area == 0.0 || !area.is_finite() {
            continue;
        }
        // Either winding fills: the corners are put in counter-clockwise screen order.
        let (b, c, ib, ic) = if area > 0.0 {
            (b, c, idx[1], idx[2])
        } else {
            (c, b, idx[2], idx[1])
        };
        let corners = [idx[0], ib, ic];
        let area = area.abs();
        let x0 = a[0].min(b[0]).min(c[0]).floor().max(0.0) as usize;
        let y0 = a[1].min(b[1]).min(c[1]).floor().max(0.0) as usize;
        let x1 = (a[0].max(b[0]).max(c[0]).ceil().max(0.0) as usize).min(w - 1);
        let y1 = (a[1].max(b[1]).max(c[1]).ceil().max(0.0) as usize).min(h - 1);
        for py in y0..=y1 {
            for px in x0..=x1 {
                let p = [px as f32 + 0.5, py as f32 + 0.5, 0.0];
                let l = [edge(b, c, p), edge(c, a, p), edge(a, b, p)];
                if l.iter().any(|&v| v < 0.0) {
                    continue;
                }
                let l = l.map(|v| v / area);
                let z = l[0] * a[2] + l[1] * b[2] + l[2] * c[2];
                let di = py * w + px;
                if z <= inv_depth[di] {
                    continue;
                }
                inv_depth[di] = z;
                // Perspective-correct weights: each corner's screen weight over its depth.
                let pw = [l[0] * a[2], l[1] * b[2], l[2] * c[2]].map(|v| v / z);
                let blend = |f: &dyn Fn(usize) -> [f32; 3]| -> [f32; 3] {
                    let mut out = [0.0; 3];
                    for (k, &v) in corners.iter().enumerate() {
                        let x = f(v);
                        for c in 0..3 {
                            out[c] += pw[k] * x[c];
                        }
                    }
                    out
                };
                let point = Vec3::from_array(blend(&|v| positions[v]));
                let mut n = Vec3::from_array(blend(&|v| normals[v]));
                let view = (eye - point).normalize();
                if n.dot(view) < 0.0 {
                    n = n.scale(-1.0);
                }
                let n = n.normalize();
                let mut diffuse = AMBIENT;
                let mut highlight = 0.0;
                for &(dir, strength) in &lights {
                    diffuse += strength * n.dot(dir).max(0.0);
                    let half = (dir + view).normalize();
                    highlight += strength * n.dot(half).max(0.0).powf(SPECULAR.1);
                }
                let base = blend(&colour);
                let rgb = base.map(|c| c * diffuse + 255.0 * SPECULAR.0 * highlight);
                img.set(
                    px as i64,
                    py as i64,
                    rgb.map(|v| v.round().clamp(0.0, 255.0) as u8),
                );
            }
        }
    }
    img
}

fn edge(a: [f32; 3], b: [f32; 3], p: [f32; 3]) -> f32 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Area-weighted vertex normals (zero for a vertex in no drawable triangle).
fn vertex_normals(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut normals = vec![Vec3::new(0.0, 0.0, 0.0); positions.len()];
    for tri in triangles {
        let idx = tri.map(|i| i as usize);
        let (Some(&a), Some(&b), Some(&c)) = (
            positions.get(idx[0]),
            positions.get(idx[1]),
            positions.get(idx[2]),
        ) else {
            continue;
        };
        let [a, b, c] = [a, b, c].map(Vec3::from_array);
        let n = (b - a).cross(c - a);
        if !n.to_array().iter().all(|v| v.is_finite()) {
            continue;
        }
        for &i in &idx {
            normals[i] = normals[i] + n;
        }
    }
    normals
        .into_iter()
        .map(|n| {
            let len = n.norm();
            if len > 0.0 && len.is_finite() {
                n.scale(1.0 / len).to_array()
            } else {
                [0.0; 3]
            }
        })
        .collect()
}

/// The albedo of each vertex of a face in its own frame (+y up, +z toward the camera) with its
/// 68 iBUG landmark vertices: lips inside the outer lip contour (48–59), eyes inside the eyelids
/// (36–41, 42–47), brows within a band about each brow's line (17–21, 22–26) as wide as a
/// tenth of the outer eye corners' distance, skin elsewhere. Without 68 landmarks in range: skin everywhere.
pub fn face_albedo(face: &[[f32; 3]], landmarks: &[u32]) -> Vec<[u8; 3]> {
    let mut out = vec![SKIN; face.len()];
    let Some(lm) = landmarks
        .iter()
        .map(|&v| face.get(v as usize).map(|p| [p[0], p[1]]))
        .collect::<Option<Vec<[f32; 2]>>>()
        .filter(|l| l.len() == 68)
    else {
        return out;
    };
    let eyes = {
        let d = [lm[36][0] - lm[45][0], lm[36][1] - lm[45][1]];
        (d[0] * d[0] + d[1] * d[1]).sqrt()
    };
    let band = eyes / 10.0;
    for (p, c) in face.iter().zip(out.iter_mut()) {
        let q = [p[0], p[1]];
        if inside(q, &lm[48..60]) {
            *c = LIPS;
        } else if inside(q, &lm[36..42]) || inside(q, &lm[42..48]) {
            *c = EYES;
        } else if [&lm[17..22], &lm[22..27]]
            .iter()
            .any(|brow| polyline_distance(q, brow) < band * 0.5)
        {
            *c = BROWS;
        }
    }
    out
}

/// Whether `p` lies inside the closed polygon (even–odd rule).
fn inside(p: [f32; 2], polygon: &[[f32; 2]]) -> bool {
    let mut odd = false;
    let n = polygon.len();
    for i in 0..n {
        let (a, b) = (polygon[i], polygon[(i + n - 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                odd = !odd;
            }
        }
    }
    odd
}

/// The distance from `p` to the open polyline.
fn polyline_distance(p: [f32; 2], line: &[[f32; 2]]) -> f32 {
    line.windows(2)
        .map(|s| {
            let (a, b) = (s[0], s[1]);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let t = if len2 > 0.0 {
                (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let d = [p[0] - a[0] - t * ab[0], p[1] - a[1] - t * ab[1]];
            (d[0] * d[0] + d[1] * d[1]).sqrt()
        })
        .fold(f32::INFINITY, f32::min)
}

/// Why a performance could not be rendered; each names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// The performance folder could not be read.
    #[error(transparent)]
    Performance(#[from] PerformanceError),
    /// The output folder could not be made.
    #[error(transparent)]
    Folder(#[from] CreateFolderError),
    /// A frame's picture could not be written.
    #[error(transparent)]
    Png(#[from] PngError),
    /// The video could not be written.
    #[error(transparent)]
    Video(#[from] AtomicWriteError),
    /// The picture is too small for the frame-number code (`--stamp`).
    #[error(
        "{}: the camera's image is {width}×{height}; the frame-number code needs at least {}×{}",
        path.display(), STAMP_BITS * STAMP_CELL, STAMP_CELL
    )]
    TooSmallForStamp {
        /// The performance's manifest.
        path: PathBuf,
        /// Its image width.
        width: u32,
        /// Its image height.
        height: u32,
    },
    /// The frame rate asked for is not a positive finite number.
    #[error("--fps {0}: a video's frame rate must be a positive number")]
    FrameRate(f32),
    /// The camera's image has an odd side, which 4:2:0 video cannot hold whole.
    #[error("{}: the camera's image is {width}×{height}; a y4m video needs even sides", path.display())]
    OddSize {
        /// The performance's manifest.
        path: PathBuf,
        /// Its image width.
        width: u32,
        /// Its image height.
        height: u32,
    },
}

/// What `sinew render` wrote.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The frames' pictures (empty without PNGs).
    pub pictures: Vec<PathBuf>,
    /// The video.
    pub video: PathBuf,
    /// Frames rendered.
    pub frames: usize,
    /// Picture size.
    pub size: [u32; 2],
}

/// The video's file name in `sinew render`'s output folder.
pub const VIDEO: &str = "performance.y4m";

/// Bits of the frame-number code (`sinew render --stamp`): frame numbers modulo 2^16.
pub const STAMP_BITS: u32 = 16;
/// Side of one cell of the frame-number code, in pixels (whole 4:2:0 chroma blocks).
pub const STAMP_CELL: u32 = 8;

/// What `sinew render` makes besides the video.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// A PNG per frame as well.
    pub pngs: bool,
    /// The video's frame rate; `None` keeps the performance's. A slower video suits a tracker
    /// slower than real time reading it as a camera.
    pub fps: Option<f32>,
    /// The frame-number code in the top-left corner of every frame ([`stamp`]).
    pub stamp: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            pngs: true,
            fps: None,
            stamp: false,
        }
    }
}

/// Draws the frame-number code of frame `frame` into `image`: bit k of `frame` (least
/// significant first, modulo 2^[`STAMP_BITS`]) as the k-th of a row of square cells of
/// [`STAMP_CELL`] pixels along the top edge from the left corner, white for 1 and black for 0, so
/// that whoever reads the picture as a camera (a browser test, a latency measurement) can tell
/// which frame it is looking at. An image too small for the row is left alone.
pub fn stamp(image: &mut Image, frame: usize) {
    if image.width < STAMP_BITS * STAMP_CELL || image.height < STAMP_CELL {
        return;
    }
    for k in 0..STAMP_BITS {
        let value = if (frame >> k) & 1 == 1 { 255 } else { 0 };
        for y in 0..STAMP_CELL {
            for x in k * STAMP_CELL..(k + 1) * STAMP_CELL {
                let i = 3 * (y as usize * image.width as usize + x as usize);
                image.rgb[i..i + 3].fill(value);
            }
        }
    }
}

/// The frame number [`stamp`] drew into `image`, read at each cell's centre (a cell is 1 where
/// its luma is above mid-grey); `None` for an image too small to hold the code.
pub fn read_stamp(image: &Image) -> Option<u32> {
    if image.width < STAMP_BITS * STAMP_CELL || image.height < STAMP_CELL {
        return None;
    }
    let c = STAMP_CELL / 2;
    Some((0..STAMP_BITS).fold(0, |code, k| {
        let i = 3 * (c as usize * image.width as usize + (k * STAMP_CELL + c) as usize);
        let [r, g, b] = [image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]].map(u32::from);
        let luma = (299 * r + 587 * g + 114 * b) / 1000;
        if luma > 127 { code | (1 << k) } else { code }
    }))
}

/// `sinew render`: every frame of the performance in `dir` photographed through its camera, as
/// `out/frame_00000.png`… (unless `options.pngs` is false) and `out/performance.y4m` at the
/// performance's frame rate or `options.fps`, each frame stamped with its number when
/// `options.stamp` is set. The albedo is laid out on the first frame with the head's pose taken
/// off.
///
/// # Errors
/// [`RenderError`], naming the file.
pub fn render_performance(
    dir: &Path,
    out: &Path,
    options: RenderOptions,
) -> Result<Rendered, RenderError> {
    if let Some(fps) = options.fps
        && !(fps.is_finite() && fps > 0.0)
    {
        return Err(RenderError::FrameRate(fps));
    }
    let perf = Performance::read(dir)?;
    let m = &perf.manifest;
    let camera = m.camera;
    let manifest = dir.join(crate::io::performance::MANIFEST);
    if camera.width % 2 != 0 || camera.height % 2 != 0 {
        return Err(RenderError::OddSize {
            path: manifest,
            width: camera.width,
            height: camera.height,
        });
    }
    if options.stamp && (camera.width < STAMP_BITS * STAMP_CELL || camera.height < STAMP_CELL) {
        return Err(RenderError::TooSmallForStamp {
            path: manifest,
            width: camera.width,
            height: camera.height,
        });
    }
    let pngs = options.pngs;
    atomic::create_folder(out, "output folder")?;
    let triangles = triangulate(&perf.polygons);
    let albedo = match (perf.frames.first(), m.parameters.first()) {
        (Some(first), Some(params)) => {
            let head = sinew_core::rotation::rigid_from_9d(&params.head).inverse();
            let face: Vec<[f32; 3]> = first
                .iter()
                .map(|&p| head.apply(Vec3::from_array(p)).to_array())
                .collect();
            face_albedo(&face, &m.landmarks.vertices)
        }
        _ => Vec::new(),
    };
    let mut pictures = Vec::new();
    let video = out.join(VIDEO);
    let mut png_error = None;
    let written = atomic::write_with(&video, |w| {
        let fps = options.fps.unwrap_or(m.fps);
        w.write_all(y4m::header(camera.width, camera.height, fps).as_bytes())?;
        for (f, positions) in perf.frames.iter().enumerate() {
            let (mut positions, mut triangles, mut albedo) =
                (positions.clone(), triangles.clone(), albedo.clone());
            let landmarks: Vec<[f32; 3]> = m
                .landmarks
                .vertices
                .iter()
                .filter_map(|&v| positions.get(v as usize).copied())
                .collect();
            eyes::add_eyes(&mut positions, &mut triangles, &mut albedo, &landmarks);
            let mut image = photograph(&positions, &triangles, &albedo, &camera, SUPERSAMPLE);
            if options.stamp {
                stamp(&mut image, f);
            }
            y4m::write_frame(w, image.width, image.height, &image.rgb)?;
            if pngs {
                let path = out.join(format!("frame_{f:05}.png"));
                if let Err(e) = image.save_png(&path) {
                    png_error = Some(e);
                    return Err(std::io::Error::other("a frame's picture failed"));
                }
                pictures.push(path);
            }
        }
        Ok(())
    });
    if let Some(e) = png_error {
        return Err(e.into());
    }
    written?;
    Ok(Rendered {
        pictures,
        video,
        frames: perf.frames.len(),
        size: [camera.width, camera.height],
    })
}

/// Polygons fanned into triangles.
fn triangulate(polygons: &[Vec<u32>]) -> Vec<[u32; 3]> {
    polygons
        .iter()
        .flat_map(|p| (2..p.len()).map(move |k| [p[0], p[k - 1], p[k]]))
        .collect()
}

mod eyes;

#[cfg(test)]
mod tests;
