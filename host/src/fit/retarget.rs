//! Performance retargeting (AIM Sec. 5.4, Fig. 8): a performance fitted on a source actor, played
//! on a target actor: in vertex correspondence, or of another topology and other shapes through
//! the built-in face template and the shapes' names ([`Plan`]).
//!
//! The fit's per-frame head and jaw transforms `T_g`, `T_b` and coefficients `w` are the
//! target's inputs as they are; only the actor changes, so the target moves as the source did
//! with its own rest shape, jaw pivot, skinning weights and correctives. Local coefficients
//! `w_j(c) = F_W(z_j, ĉ)` are evaluated at the source's template points, where the fit learned
//! them (the performance carries them as `perf.points`), and applied at the target's vertex of
//! the same index, or, across topologies, at the source point that corresponds to each target
//! vertex. The target's correctives take the source's coefficients of the shapes of their names.
//!
//! The same frames split into Fig. 8's two parts: the rigid jaw alone (`T_b` with no
//! correctives) and the soft tissue alone (the correctives with the jaw at rest); the head
//! transform stays in all three, so the parts overlay the full result. Each is a `.sinew`
//! performance of the target that plays through `sinew-core` like any fit.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};
use sinew_core::SinewFile;
use sinew_core::aim::AimActor;
use sinew_core::performance::{self as perf, Coefficients, Performance};
use sinew_core::replay::{hash_words, model_hash};

use crate::figures::render::{Image, View, render, text_scale, text_width};
use crate::fit::bake::play;
use crate::fit::setup::FitConfig;
use crate::io::container::SinewWriter;
use crate::io::mesh::{Mesh, points};
use crate::training::backend::Backend;

mod input;
mod plan;
pub use input::{Input, RetargetError};
pub use plan::Plan;

/// The jaw transform of the jaw at rest: the identity's 6D rotation, no translation.
const JAW_AT_REST: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];

/// Which part of a retargeted performance to keep (AIM Fig. 8's columns).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Part {
    /// Everything: head, jaw and correctives.
    Full,
    /// The rigid jaw motion alone: head and jaw, no correctives.
    Jaw,
    /// The soft tissue alone: head and correctives, the jaw at rest.
    Soft,
}

impl Part {
    /// All three, in the order of the outputs.
    pub const ALL: [Part; 3] = [Part::Full, Part::Jaw, Part::Soft];

    /// The output name of this part (`target`, `jaw`, `soft`).
    pub const fn name(self) -> &'static str {
        match self {
            Part::Full => "target",
            Part::Jaw => "jaw",
            Part::Soft => "soft",
        }
    }
}

/// Reads `input` as an AIM actor.
fn actor<'a>(input: Input<'a>) -> Result<AimActor<'a>, RetargetError> {
    Ok(crate::io::container::actor(input.path, input.bytes)?)
}

/// The `.sinew` performance of `part` of `fit` (a performance of the actor `source`) retargeted
/// onto the actor `target`, with each frame's f32 hash as the core plays it on `target`.
///
/// # Errors
/// If an input is not what it should be (an actor, a performance), the fit is not of `source`,
/// or the actors cannot be put in correspondence ([`Plan::new`]); the error names the files.
pub fn retarget(
    source: Input<'_>,
    target: Input<'_>,
    fit: Input<'_>,
    part: Part,
) -> Result<Vec<u8>, RetargetError> {
    check_fit(source, fit)?;
    let plan = Plan::new((source, &actor(source)?), (target, &actor(target)?))?;
    retarget_planned(source, target, fit, part, &plan)
}

/// Reads `fit` as a performance of the actor `source`.
fn check_fit<'a>(source: Input<'_>, fit: Input<'a>) -> Result<Performance<'a>, RetargetError> {
    let src = actor(source)?;
    let p = Performance::from_bytes(fit.bytes).map_err(|e| RetargetError::NotAPerformance {
        path: fit.path.to_owned(),
        source: e,
    })?;
    p.check_actor(source.bytes, &src)
        .map_err(|reason| RetargetError::OtherActor {
            fit: fit.path.to_owned(),
            actor: source.path.to_owned(),
            source: reason,
        })?;
    Ok(p)
}

/// [`retarget`] with the actors' [`Plan`] worked out before (once for several parts).
///
/// # Errors
/// As [`retarget`].
pub fn retarget_planned(
    source: Input<'_>,
    target: Input<'_>,
    fit: Input<'_>,
    part: Part,
    plan: &Plan,
) -> Result<Vec<u8>, RetargetError> {
    let src = actor(source)?;
    actor(target)?;
    let not_a_performance = |source| RetargetError::NotAPerformance {
        path: fit.path.to_owned(),
        source,
    };
    let p = check_fit(source, fit)?;
    let layout = |e| RetargetError::Layout {
        fit: fit.path.to_owned(),
        target_actor: target.path.to_owned(),
        source: Box::new(e),
    };
    let file = SinewFile::from_bytes(fit.bytes).map_err(not_a_performance)?;
    let mut w = SinewWriter::from_file(&file).map_err(layout)?;
    for name in [perf::MODEL_HASH, perf::POSES, perf::HASHES, perf::POINTS] {
        w.remove_prefixed(name);
    }
    w.meta(
        "retargeted_from",
        format!("{:016x}", model_hash(source.bytes)),
    )
    .meta("retargeted_part", part.name());
    if !plan.unmatched.is_empty() {
        w.meta("retargeted_at_rest", plan.unmatched.join(","));
    }
    w.u32s(
        perf::MODEL_HASH,
        &[2],
        &hash_words(model_hash(target.bytes)),
    )
    .map_err(layout)?;
    let frames = p.frames();
    let mut poses = Vec::with_capacity(frames * 18);
    for f in 0..frames {
        let (head, jaw) = p.head_jaw(f).ok_or_else(|| RetargetError::Frame {
            path: fit.path.to_owned(),
            frame: f,
        })?;
        poses.extend(head);
        poses.extend(if part == Part::Soft { JAW_AT_REST } else { jaw });
    }
    w.f32s(perf::POSES, &[frames, 18], &poses).map_err(layout)?;
    let m = plan.shapes.len();
    let in_order = plan.shapes_in_order(p.shape_count());
    match (part, p.coefficients()) {
        (Part::Jaw, _) => {
            for name in [perf::WEIGHTS, perf::CODES, perf::BOX, perf::F_W] {
                w.remove_prefixed(name);
            }
            w.f32s(perf::WEIGHTS, &[frames, m], &vec![0.0; frames * m])
                .map_err(layout)?;
        }
        (_, Coefficients::Local { points, fw, .. }) => {
            // F_W sees the points it was fitted at: the source's own, or those a retargeted
            // source performance already carries, at each target vertex's place on the source.
            let at = points.unwrap_or_else(|| src.template());
            let values = plan.points(at);
            w.f32s(perf::POINTS, &[values.len() / 3, 3], &values)
                .map_err(layout)?;
            if !in_order {
                // F_W's last layer gives one output per source shape: its rows, remapped, give
                // the target's.
                let last = fw.layers().len() - 1;
                let layer = &fw.layers()[last];
                let inputs = layer.inputs();
                let weight: Vec<f32> = layer.weight().iter().collect();
                let bias: Vec<f32> = layer.bias().iter().collect();
                let mut remapped = vec![0.0; m * inputs];
                for k in 0..inputs {
                    let column: Vec<f32> = (0..p.shape_count())
                        .map(|j| weight[j * inputs + k])
                        .collect();
                    for (i, v) in plan.remap(&column).into_iter().enumerate() {
                        remapped[i * inputs + k] = v;
                    }
                }
                let (w_name, b_name) = (
                    format!("{}.{last}.w", perf::F_W),
                    format!("{}.{last}.b", perf::F_W),
                );
                w.remove_prefixed(&w_name);
                w.remove_prefixed(&b_name);
                w.f32s(&w_name, &[m, inputs], &remapped).map_err(layout)?;
                w.f32s(&b_name, &[m], &plan.remap(&bias)).map_err(layout)?;
            }
        }
        (_, Coefficients::Global(weights)) => {
            if !in_order {
                let source: Vec<f32> = weights.iter().collect();
                let remapped: Vec<f32> = source
                    .chunks_exact(p.shape_count().max(1))
                    .flat_map(|frame| plan.remap(frame))
                    .collect();
                w.remove_prefixed(perf::WEIGHTS);
                w.f32s(perf::WEIGHTS, &[frames, m], &remapped)
                    .map_err(layout)?;
            }
        }
    }
    let unhashed = w.to_bytes().map_err(layout)?;
    let (_, hashes) = play(target.bytes, &unhashed).map_err(|e| RetargetError::Play {
        fit: fit.path.to_owned(),
        target_actor: target.path.to_owned(),
        source: Box::new(e),
    })?;
    let words: Vec<u32> = hashes.iter().flat_map(|&h| hash_words(h)).collect();
    w.u32s(perf::HASHES, &[frames, 2], &words).map_err(layout)?;
    w.to_bytes().map_err(layout)
}

/// Where the source's performance comes from.
#[derive(Debug, Clone)]
pub enum SourceFit {
    /// A performance folder (`sinew data performance`) to fit the source actor to first.
    Fit {
        /// The folder.
        performance: PathBuf,
        /// The fit's settings.
        config: FitConfig,
        /// Its burn backend.
        backend: Backend,
    },
    /// A fit of the source actor baked before (`sinew fit --out`).
    Baked(PathBuf),
}

/// The `sinew retarget` report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RetargetReport {
    /// Frames retargeted.
    pub frames: usize,
    /// The source actor's file.
    pub source: PathBuf,
    /// The target actor's file.
    pub target: PathBuf,
    /// The fit of the source played on the target (a `.sinew` performance).
    pub performance: PathBuf,
    /// Seconds per frame of fitting the source, when this command fitted it.
    pub fit_seconds_per_frame: Option<f64>,
    /// The fit's mean per-vertex error on the source's performance, mm, when fitted here.
    pub fit_mean_error_mm: Option<f64>,
    /// Seconds per frame to retarget (all three parts baked and played through the core).
    pub seconds_per_frame: f64,
    /// Frames drawn in strip.png (0-based).
    pub strip_frames: Vec<usize>,
    /// How the target's vertices were matched to the source's: `vertex` (the same vertices and
    /// triangles) or `template` (another topology, through the built-in face template).
    pub correspondence: String,
    /// The target's shapes that play none of the source's (no shape of their name), at rest.
    pub shapes_at_rest: Vec<String>,
}

/// The three parts of a fit retargeted and written by [`write_parts`], with what the report
/// and the strip need.
#[derive(Debug)]
pub struct Retargeted {
    /// Frames retargeted.
    pub frames: usize,
    /// Seconds per frame to retarget (all three parts baked and played through the core).
    pub seconds_per_frame: f64,
    /// Frames drawn in the strip (0-based).
    pub strip_frames: Vec<usize>,
    /// The strip: one row per strip frame; columns the source as fitted, the target, jaw only,
    /// soft tissue only.
    pub strip: Image,
    /// How the actors were matched.
    pub plan: Plan,
}

/// Creates the output folder `out`.
///
/// # Errors
/// [`RetargetError::CreateFolder`], naming the folder.
pub fn create_output(out: &Path) -> Result<(), RetargetError> {
    Ok(crate::io::atomic::create_folder(out, "output folder")?)
}

/// The fit at `fit_path` (a performance of `source`) retargeted onto `target` in each of the
/// three [`Part`]s, written to `out`: `target.sinew`, `jaw.sinew`, `soft.sinew` (performances of
/// the target) and one OBJ per frame of each in `target/`, `jaw/`, `soft/`. The strip shows the
/// `strip` frames (default: four spread over the performance).
///
/// # Errors
/// Any refusal of [`retarget`]; a fit that does not play ([`RetargetError::Play`],
/// [`RetargetError::PlaySource`]); a strip frame past the end; a file that cannot be read or
/// written. Each names the files concerned.
pub fn write_parts(
    source: Input<'_>,
    target: Input<'_>,
    fit_path: &Path,
    out: &Path,
    strip: Option<&[usize]>,
) -> Result<Retargeted, RetargetError> {
    let fit = crate::io::container::read(fit_path)?;
    let fit_input = Input {
        path: fit_path,
        bytes: &fit,
    };
    let start = Instant::now();
    check_fit(source, fit_input)?;
    let plan = Plan::new((source, &actor(source)?), (target, &actor(target)?))?;
    let mut parts = Vec::with_capacity(Part::ALL.len());
    for part in Part::ALL {
        let baked = retarget_planned(source, target, fit_input, part, &plan)?;
        let (frames, _) = play(target.bytes, &baked).map_err(|e| RetargetError::Play {
            fit: fit_path.to_owned(),
            target_actor: target.path.to_owned(),
            source: Box::new(e),
        })?;
        parts.push((part, baked, frames));
    }
    let frames = parts[0].2.len();
    let seconds_per_frame = start.elapsed().as_secs_f64() / frames as f64;
    let strip_frames = match strip {
        Some(s) => {
            if let Some(&frame) = s.iter().find(|&&f| f >= frames) {
                return Err(RetargetError::StripFrame {
                    fit: fit_path.to_owned(),
                    frame,
                    frames,
                });
            }
            s.to_vec()
        }
        None => spread(frames, 4),
    };
    let dst = actor(target)?;
    let mesh = Mesh::of_actor(&dst);
    for (part, baked, played) in &parts {
        crate::io::atomic::write(&out.join(format!("{}.sinew", part.name())), baked)?;
        let dir = out.join(part.name());
        for (f, positions) in played.iter().enumerate() {
            mesh.with_positions(points(positions.iter().copied()))
                .write(&dir.join(format!("frame_{f:05}.obj")))?;
        }
    }
    let (source_frames, _) = play(source.bytes, &fit).map_err(|e| RetargetError::PlaySource {
        fit: fit_path.to_owned(),
        actor: source.path.to_owned(),
        source: Box::new(e),
    })?;
    let mut columns = vec![("source", &source_frames)];
    columns.extend(
        parts
            .iter()
            .map(|(part, _, played)| (column_title(*part), played)),
    );
    Ok(Retargeted {
        frames,
        seconds_per_frame,
        strip: strip_picture(&mesh, &columns, &strip_frames),
        strip_frames,
        plan,
    })
}

fn column_title(part: Part) -> &'static str {
    match part {
        Part::Full => "target",
        Part::Jaw => "jaw only",
        Part::Soft => "soft tissue only",
    }
}

/// `n` frames spread evenly over `frames` (all of them when there are fewer).
fn spread(frames: usize, n: usize) -> Vec<usize> {
    if frames <= n {
        return (0..frames).collect();
    }
    (0..n).map(|i| i * (frames - 1) / (n - 1)).collect()
}

/// A grid: one row per frame of `rows`, one column per entry of `columns` (title, per-frame
/// positions), each panel the frame's mesh from the front with the title above the first row.
fn strip_picture(mesh: &Mesh, columns: &[(&str, &Vec<Vec<f32>>)], rows: &[usize]) -> Image {
    let (width, height) = (220, 260);
    let view = View::front(width, height);
    let triangles = mesh.triangles();
    let scale = text_scale(width, height);
    let title_height = 12 * scale;
    let mut grid = Vec::with_capacity(rows.len() + 1);
    let titles: Vec<Image> = columns
        .iter()
        .map(|(title, _)| {
            let mut header = Image::new(width, title_height, crate::figures::render::BACKGROUND);
            let x = (i64::from(width) - i64::from(text_width(title, scale))) / 2;
            header.text(x, i64::from(2 * scale), title, [40, 40, 40], scale);
            header
        })
        .collect();
    grid.push(Image::hstack(&titles));
    for &f in rows {
        let panels: Vec<Image> = columns
            .iter()
            .map(|(_, frames)| render(&points(frames[f].iter().copied()), &triangles, &[], &view))
            .collect();
        grid.push(Image::hstack(&panels));
    }
    Image::vstack(&grid)
}

#[cfg(test)]
mod tests {
    use super::spread;

    #[test]
    fn strip_frames_spread_over_the_performance() {
        assert_eq!(spread(3, 4), vec![0, 1, 2]);
        assert_eq!(spread(10, 4), vec![0, 3, 6, 9]);
        assert_eq!(spread(4, 4), vec![0, 1, 2, 3]);
    }
}
