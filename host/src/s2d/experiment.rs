//! `sinew train s2d` and `sinew eval s2d`: S2D-Dec against the PCA baselines on the paper's
//! protocols (S2D §4.2, Table 1 and Fig. 3; Table 2's loss ablation through [`Objective`]).
//!
//! Every error is the per-vertex Euclidean distance between the predicted and the ground-truth
//! expressive face, in mm (ICT is in cm), over every vertex of every test pair; the report gives
//! its mean and (population) standard deviation, as Table 1 does.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail, ensure};
use serde::{Deserialize, Serialize};

use super::baseline::{DEFAULT_RIDGE, Dictionary, DictionaryConfig, Pca};
use super::checkpoint::{STATE_FILE, read_state};
use super::data::{Expressions, PairSet};
use super::decoder::{DecoderConfig, InputNormalisation, S2dDecoder};
use super::hierarchy;
use super::protocol::{FOLDS, Protocol, Split, split};
use super::symmetry::{Mirror, partners};
use super::train::{
    LossVariant, Sample, TrainConfig, TrainOptions, landmark_distances, train, vertex_weights,
};
use crate::backend::Backend;

/// Default epochs of `sinew train s2d` (one fold within 45 minutes on the shared 2-core machine;
/// docs/S2D.md has the measurement).
pub const DEFAULT_EPOCHS: usize = 70;

/// ICT is in cm; errors are reported in mm.
const MM_PER_UNIT: f32 = 10.0;

/// The training objective, including Table 2's ablations.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Objective {
    /// The authors' code (the published numbers): weighted sum + 0.1 · mean (Table 2's S3 as
    /// the code has it).
    #[default]
    Code,
    /// The paper's text: L_dr + 0.1 · L_pr with the 1/d weights (S3 as the paper writes it).
    Paper,
    /// Table 2's S1: L_dr alone (the paper's loss with every vertex weight 0).
    Dr,
    /// Table 2's S2: L_dr + 0.1 · L_pr without distance weights (every vertex weight 1).
    DrUnweighted,
}

impl Objective {
    /// The trainer's loss and the vertex weights it takes, from the landmark distances.
    pub fn loss_and_weights(self, distances: &[f32]) -> (LossVariant, Vec<f32>) {
        match self {
            Self::Code => (
                LossVariant::Code,
                vertex_weights(LossVariant::Code, distances),
            ),
            Self::Paper => (
                LossVariant::Paper,
                vertex_weights(LossVariant::Paper, distances),
            ),
            Self::Dr => (LossVariant::Paper, vec![0.0; distances.len()]),
            Self::DrUnweighted => (LossVariant::Paper, vec![1.0; distances.len()]),
        }
    }
}

/// Mean and standard deviation of per-vertex errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Mean per-vertex error (mm).
    pub mean_error_mm: f64,
    /// Standard deviation of the per-vertex error (mm).
    pub std_error_mm: f64,
    /// Components (PCA) or atoms (DL-3DMM) used, baselines only; in a pooled entry, only when
    /// all folds agree.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub components: Option<usize>,
}

impl ErrorStats {
    fn of(errors: &[f32], components: Option<usize>) -> Self {
        let n = errors.len().max(1) as f64;
        let mean = errors.iter().map(|&e| f64::from(e)).sum::<f64>() / n;
        let var = errors
            .iter()
            .map(|&e| (f64::from(e) - mean).powi(2))
            .sum::<f64>()
            / n;
        Self {
            mean_error_mm: mean,
            std_error_mm: var.sqrt(),
            components,
        }
    }
}

/// The 3DMM baselines of Table 1.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Baselines {
    /// PCA with the components that explain 99% of the training variance.
    pub pca99: ErrorStats,
    /// PCA with min(220, rank) components.
    pub pca_max: ErrorStats,
    /// DL-3DMM, a dictionary of 220 sparse-coded atoms ([`Dictionary`]); its count is the atoms
    /// the training codes use.
    pub dl_3dmm: ErrorStats,
    /// Not a method but a bound: the test displacements' orthogonal projection onto the
    /// training displacements' affine span ([`Pca::project`], all `rank` components, reading
    /// the whole dense ground truth). It is the least-squares closest displacement any model
    /// built from that span (the three above) can give, so their errors do not go below it
    /// (strictly so for the root-mean-square error; the mean per-vertex error is a different
    /// norm).
    pub span_floor: ErrorStats,
}

/// Per-vertex errors (mm) on a split's test pairs of the baselines, with their component
/// (atom) counts, and of the training span's floor ([`Baselines::span_floor`]).
#[derive(Clone, Debug)]
pub struct BaselineErrors {
    /// PCA, 99% of the variance.
    pub pca99: (Vec<f32>, usize),
    /// PCA, min(220, rank) components.
    pub pca_max: (Vec<f32>, usize),
    /// DL-3DMM, atoms used.
    pub dl_3dmm: (Vec<f32>, usize),
    /// The training span's floor, and the span's dimension (the PCA's rank).
    pub span_floor: (Vec<f32>, usize),
}

/// One fold's results.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FoldReport {
    /// The fold.
    pub fold: usize,
    /// Held-out identities (indices) or expression shapes (names).
    pub held_out: Vec<String>,
    /// Training pairs.
    pub train_pairs: usize,
    /// Test pairs.
    pub test_pairs: usize,
    /// S2D-Dec on the test pairs.
    pub s2d: ErrorStats,
    /// The baselines on the same split.
    pub baselines: Baselines,
    /// The baked model of this fold.
    pub model: PathBuf,
    /// Mean training loss of each epoch (empty for `eval`).
    pub losses: Vec<f32>,
    /// Training time (s), over every invocation when the fold was resumed.
    pub train_seconds: f64,
    /// Each held-out shape (expression split) or identity (identity split), with the errors on
    /// the test pairs that involve it (absent from reports written before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_held_out: Vec<HeldOutErrors>,
    /// Mirror images of training pairs added to the training set, of S2D-Dec and of every
    /// baseline (`train s2d --mirror`; absent when none).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub mirrored_pairs: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

/// `train s2d --mirror`: the face region's left–right symmetry, and each expression shape's
/// mirror image among the shapes.
struct Mirroring {
    mirror: Mirror,
    partners: Vec<Option<usize>>,
}

impl Mirroring {
    fn of(set: &PairSet) -> Result<Self> {
        let mirror = Mirror::of(&set.template).context("mirroring the pairs' face region")?;
        // On identity 0 (the shapes' images are the same for every identity when shared, and
        // within 6 % of each other when transferred: `symmetry::PARTNER_RESIDUAL`).
        let shapes: Vec<&[[f32; 3]]> = (0..set.manifest.expressions.len())
            .map(|e| set.delta(0, e))
            .collect();
        let partners = partners(&mirror, &shapes);
        Ok(Self { mirror, partners })
    }

    /// The training pairs of `s` whose mirror images may train: every pair on the identity split
    /// (a mirrored identity is a new identity); on the expression split, the pairs whose every
    /// shape mirrors onto a training shape (or onto no shape), so that no held-out shape is seen,
    /// not even as a training shape's mirror image (`mouthLeft` mirrored is `mouthRight`).
    fn mirrorable(&self, set: &PairSet, s: &Split) -> Vec<usize> {
        let names = &set.manifest.expressions;
        let allowed = |p: usize| match s.protocol {
            Protocol::Identity => true,
            Protocol::Expression => set.combinations[p]
                .iter()
                .all(|&(e, _)| self.partners[e].is_none_or(|b| !s.held_out.contains(&names[b]))),
        };
        s.train.iter().copied().filter(|&p| allowed(p)).collect()
    }

    /// The mirror images of [`Self::mirrorable`] pairs as training samples.
    fn training_samples(
        &self,
        set: &PairSet,
        s: &Split,
        input: InputNormalisation,
    ) -> Result<Vec<Sample>> {
        self.mirrorable(set, s)
            .into_iter()
            .map(|p| set.mirrored_sample(p, &self.mirror, input))
            .collect()
    }

    /// The mirrored dense displacements of [`Self::mirrorable`] pairs, flattened (what the
    /// baselines learn from besides the training pairs).
    fn displacements(&self, set: &PairSet, s: &Split) -> Vec<Vec<f32>> {
        self.mirrorable(set, s)
            .into_iter()
            .map(|p| {
                let d = self.mirror.vectors(&set.displacement(p));
                d.into_iter().flatten().collect()
            })
            .collect()
    }
}

/// The errors on the test pairs of a fold that involve one held-out expression shape (every pair
/// that combines it with others of its group) or identity: the mean per-vertex error (mm) over
/// those pairs' vertices, for S2D-Dec and each baseline (0 when no test pair involves it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeldOutErrors {
    /// The shape's name or the identity's index.
    pub held_out: String,
    /// Test pairs that involve it.
    pub pairs: usize,
    /// S2D-Dec.
    pub s2d_mm: f64,
    /// PCA, 99% of the variance.
    pub pca99_mm: f64,
    /// PCA, min(220, rank) components.
    pub pca_max_mm: f64,
    /// DL-3DMM.
    pub dl_3dmm_mm: f64,
}

/// [`HeldOutErrors`] of every held-out item of `s`; `involves(p, item)` says whether pair `p`
/// involves it, and `errors` are per-vertex errors of S2D-Dec, pca99, pca_max and DL-3DMM on
/// the test pairs in order, `vertices` a pair.
fn per_held_out(
    s: &Split,
    involves: impl Fn(usize, &str) -> bool,
    vertices: usize,
    errors: [&[f32]; 4],
) -> Vec<HeldOutErrors> {
    s.held_out
        .iter()
        .map(|item| {
            let pairs: Vec<usize> = (0..s.test.len())
                .filter(|&i| involves(s.test[i], item))
                .collect();
            let mean = |e: &[f32]| {
                let sum: f64 = pairs
                    .iter()
                    .flat_map(|&i| &e[i * vertices..(i + 1) * vertices])
                    .map(|&x| f64::from(x))
                    .sum();
                sum / (pairs.len() * vertices).max(1) as f64
            };
            HeldOutErrors {
                held_out: item.clone(),
                pairs: pairs.len(),
                s2d_mm: mean(errors[0]),
                pca99_mm: mean(errors[1]),
                pca_max_mm: mean(errors[2]),
                dl_3dmm_mm: mean(errors[3]),
            }
        })
        .collect()
}

/// The report of `train s2d` / `eval s2d`: the folds pooled (every test vertex of every fold),
/// then each fold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The protocol.
    pub protocol: Protocol,
    /// Folds run.
    pub folds: usize,
    /// Test pairs over all folds run.
    pub test_pairs: usize,
    /// S2D-Dec mean per-vertex error (mm).
    pub mean_error_mm: f64,
    /// S2D-Dec standard deviation (mm).
    pub std_error_mm: f64,
    /// Baselines, pooled the same way.
    pub baselines: Baselines,
    /// Each fold.
    pub per_fold: Vec<FoldReport>,
    /// The training configuration (absent for `eval`).
    pub train: Option<TrainConfig>,
    /// The objective.
    pub objective: Option<Objective>,
    /// The data set folder.
    pub pairs: PathBuf,
    /// The cumulative-error plot written beside the report.
    pub plot: PathBuf,
    /// Wall time (s).
    pub seconds: f64,
}

/// What `train s2d` runs.
#[derive(Clone, Debug)]
pub struct TrainS2d {
    /// Data set folder.
    pub pairs: PathBuf,
    /// Protocol.
    pub protocol: Protocol,
    /// Folds to run (the first `folds` of [`FOLDS`]).
    pub folds: usize,
    /// Trainer settings.
    pub train: TrainConfig,
    /// Objective (sets `train.loss` and the vertex weights).
    pub objective: Objective,
    /// Output model of fold 0; fold k > 0 goes to `MODEL.fold<k>.sinew`.
    pub out: PathBuf,
    /// Output report.
    pub report: PathBuf,
    /// burn backend.
    pub backend: Backend,
    /// The network's shape (default: the reference configuration).
    pub decoder: DecoderConfig,
    /// Decimation factors of the hierarchy (default [`hierarchy::DEFAULT_FACTORS`]; one per stage).
    pub factors: Vec<usize>,
    /// Continue each fold from its checkpoint ([`fold_checkpoint_path`]); a fold without one
    /// (after fold 0) starts from the beginning, a complete one is only baked and evaluated.
    pub resume: bool,
    /// Add the mirror images of training pairs to the training set, of S2D-Dec and of the
    /// baselines (`Mirroring::mirrorable` says which).
    pub mirror: bool,
}

/// The hierarchy cache folder: `$SINEW_CACHE`, else `sinew-cache` in the system's temporary
/// folder.
pub fn cache_dir() -> PathBuf {
    std::env::var_os("SINEW_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("sinew-cache"))
}

/// The model path of `fold` for the `--out` path of fold 0.
pub fn fold_model_path(out: &Path, fold: usize) -> PathBuf {
    if fold == 0 {
        return out.to_owned();
    }
    let stem = out
        .file_stem()
        .map_or_else(|| "model".to_owned(), |s| s.to_string_lossy().into_owned());
    out.with_file_name(format!("{stem}.fold{fold}.sinew"))
}

/// The checkpoint folder of `fold` for the `--out` path of fold 0: beside the fold's model
/// ([`fold_model_path`]) with the extension `ckpt`, `MODEL.ckpt/` and `MODEL.fold<k>.ckpt/`.
pub fn fold_checkpoint_path(out: &Path, fold: usize) -> PathBuf {
    crate::commands::checkpoint_dir_for(&fold_model_path(out, fold))
}

/// The plot path beside a report: `REPORT.png` (the report's extension replaced).
pub fn plot_path(report: &Path) -> PathBuf {
    report.with_extension("png")
}

/// Per-vertex errors (mm) of `predicted` displacements against pair `p`'s ground truth.
fn vertex_errors(set: &PairSet, p: usize, predicted: &[f32], out: &mut Vec<f32>) {
    let truth = set.displacement(p);
    for (t, q) in truth.iter().zip(predicted.chunks_exact(3)) {
        let d = [q[0] - t[0], q[1] - t[1], q[2] - t[2]];
        out.push((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() * MM_PER_UNIT);
    }
}

/// Per-vertex errors (mm) of pca99, pca_max and DL-3DMM on the test pairs of `s`, and the
/// training span's floor; the models learn from the training pairs' displacements and `extra`
/// ones (flattened, as [`Sample::displacement`]: the mirrored pairs of `train s2d --mirror`).
pub fn baseline_errors(set: &PairSet, s: &Split, extra: &[&[f32]]) -> Result<BaselineErrors> {
    let train: Vec<Vec<f32>> = s
        .train
        .iter()
        .map(|&p| set.displacement(p).iter().flatten().copied().collect())
        .collect();
    let refs: Vec<&[f32]> = train
        .iter()
        .map(Vec::as_slice)
        .chain(extra.iter().copied())
        .collect();
    let pca = Pca::fit(&refs)?;
    let k99 = pca.components_for(0.99);
    let kmax = pca.rank().min(220);
    let dictionary = Dictionary::learn(&pca, &DictionaryConfig::default())?;
    let landmarks = &set.manifest.landmarks;
    let fitters = [
        pca.fitter(k99, landmarks, DEFAULT_RIDGE)?,
        pca.fitter(kmax, landmarks, DEFAULT_RIDGE)?,
        dictionary.fitter(&pca, landmarks, DEFAULT_RIDGE)?,
    ];
    // Each test pair's landmark displacements, once for all three fits.
    let inputs: Vec<Vec<[f32; 3]>> = s
        .test
        .iter()
        .map(|&p| {
            let (n, e) = set.landmark_pair(p);
            n.iter()
                .zip(&e)
                .map(|(a, b)| [b[0] - a[0], b[1] - a[1], b[2] - a[2]])
                .collect()
        })
        .collect();
    let mut out = fitters.map(|f| (f, Vec::new()));
    for (fit, errors) in &mut out {
        for (&p, y) in s.test.iter().zip(&inputs) {
            vertex_errors(set, p, &fit.predict(y)?, errors);
        }
    }
    let mut floor = Vec::with_capacity(s.test.len() * set.vertices());
    for &p in &s.test {
        let truth: Vec<f32> = set.displacement(p).iter().flatten().copied().collect();
        vertex_errors(set, p, &pca.project(&truth)?, &mut floor);
    }
    let [pca99, pca_max, dl_3dmm] = out.map(|(f, e)| (e, f.k()));
    Ok(BaselineErrors {
        pca99,
        pca_max,
        dl_3dmm,
        span_floor: (floor, pca.rank()),
    })
}

/// Per-vertex errors (mm) of a baked decoder, run through `sinew_core` (the playback path), on
/// the test pairs of `s`.
pub fn decoder_errors(model: &[u8], set: &PairSet, s: &Split) -> Result<Vec<f32>> {
    let dec = sinew_core::s2d::S2dDecoder::from_bytes(model)
        .map_err(|e| anyhow::anyhow!("not an S2D decoder: {e}"))?;
    ensure!(
        dec.vertex_count() == set.vertices(),
        "the model decodes {} vertices, the pairs have {}",
        dec.vertex_count(),
        set.vertices()
    );
    ensure!(
        dec.landmarks()
            .iter()
            .eq(set.manifest.landmarks.iter().copied()),
        "the model's landmark vertices differ from the pairs'"
    );
    let input = InputNormalisation::from_code(dec.input_normalisation())?;
    let mut scratch = vec![0.0f32; dec.scratch_len()];
    let mut out = vec![0.0f32; 3 * set.vertices()];
    let mut errors = Vec::with_capacity(s.test.len() * set.vertices());
    for &p in &s.test {
        let sample = set.sample(p, input)?;
        dec.displacements(&sample.input, &mut scratch, &mut out)
            .map_err(|e| anyhow::anyhow!("decoding pair {p}: {e:?}"))?;
        vertex_errors(set, p, &out, &mut errors);
    }
    Ok(errors)
}

/// The cumulative per-vertex error curves (S2D Fig. 3): for each method, the percentage of
/// vertices with an error at most x mm, x from 0 to the largest 99th percentile.
pub fn cumulative_plot(methods: &[(&str, &[f32])], title: &str) -> crate::render::Image {
    let sorted: Vec<Vec<f32>> = methods
        .iter()
        .map(|(_, e)| {
            let mut v = e.to_vec();
            v.sort_by(f32::total_cmp);
            v
        })
        .collect();
    let x_max = sorted
        .iter()
        .filter(|v| !v.is_empty())
        .map(|v| f64::from(v[(v.len() - 1) * 99 / 100]))
        .fold(0.0f64, f64::max)
        .max(1e-3);
    let curves: Vec<Vec<(f64, f64)>> = sorted
        .iter()
        .map(|v| {
            (0..=200)
                .map(|i| {
                    let x = x_max * f64::from(i) / 200.0;
                    let below = v.partition_point(|&e| f64::from(e) <= x);
                    (x, 100.0 * below as f64 / v.len().max(1) as f64)
                })
                .collect()
        })
        .collect();
    let series: Vec<(&str, &[(f64, f64)])> = methods
        .iter()
        .zip(&curves)
        .map(|((name, _), c)| (*name, c.as_slice()))
        .collect();
    crate::plot::line_plot(
        &series,
        title,
        "per-vertex error (mm)",
        "% of vertices",
        false,
        720,
        480,
    )
}

/// Pools the folds and writes the report and its plot.
fn finish(
    per_fold: Vec<FoldReport>,
    errors: [Vec<f32>; 5],
    protocol: Protocol,
    trained: Option<(TrainConfig, Objective)>,
    pairs: &Path,
    report: &Path,
    started: Instant,
) -> Result<Report> {
    let (train, objective) = trained.unzip();
    let [s2d, p99, pmax, dl, floor] = &errors;
    // The pooled entry names a component count only when every fold used the same one.
    let k = |f: fn(&Baselines) -> &ErrorStats| {
        let first = per_fold.first().and_then(|r| f(&r.baselines).components);
        per_fold
            .iter()
            .all(|r| f(&r.baselines).components == first)
            .then_some(first)
            .flatten()
    };
    let plot = plot_path(report);
    let title = format!("S2D vs 3DMM baselines: cumulative per-vertex error, {protocol} split");
    let methods = [
        ("S2D", s2d.as_slice()),
        ("PCA 99%", p99),
        ("PCA max", pmax),
        ("DL-3DMM", dl),
        ("training span (floor)", floor),
    ];
    cumulative_plot(&methods, &title).write_png(&plot)?;
    let s2d_stats = ErrorStats::of(s2d, None);
    let r = Report {
        protocol,
        folds: per_fold.len(),
        test_pairs: per_fold.iter().map(|f| f.test_pairs).sum(),
        mean_error_mm: s2d_stats.mean_error_mm,
        std_error_mm: s2d_stats.std_error_mm,
        baselines: Baselines {
            pca99: ErrorStats::of(p99, k(|b| &b.pca99)),
            pca_max: ErrorStats::of(pmax, k(|b| &b.pca_max)),
            dl_3dmm: ErrorStats::of(dl, k(|b| &b.dl_3dmm)),
            span_floor: ErrorStats::of(floor, k(|b| &b.span_floor)),
        },
        per_fold,
        train,
        objective,
        pairs: pairs.to_owned(),
        plot,
        seconds: started.elapsed().as_secs_f64(),
    };
    crate::atomic::write(report, serde_json::to_string_pretty(&r)?.as_bytes())?;
    Ok(r)
}

/// `sinew train s2d`: per fold, trains S2D-Dec on the training pairs (the hierarchy of the face
/// region from [`hierarchy::cached`]) with a checkpoint folder beside the fold's model (or
/// continues from it, `args.resume`), bakes it, evaluates the baked model and the baselines on
/// the test pairs, then writes the pooled report and the cumulative-error plot.
pub fn train_s2d(args: &TrainS2d, quiet: bool) -> Result<Report> {
    let started = Instant::now();
    ensure!(
        (1..=FOLDS).contains(&args.folds),
        "--folds {}: between 1 and {FOLDS}",
        args.folds
    );
    let set = PairSet::read(&args.pairs)?;
    if !quiet
        && args.protocol == Protocol::Identity
        && set.manifest.config.expressions == Expressions::Shared
    {
        eprintln!(
            "note: {} has ICT's shared expression deltas, so the training identities' \
             displacements span the test identities' and this split says little (docs/S2D.md); \
             `sinew data s2d-pairs --expressions transferred` makes them identity-specific",
            args.pairs.display()
        );
    }
    let h = hierarchy::cached(&set.template, &args.factors, &cache_dir())
        .context("building the face region's mesh hierarchy")?;
    let distances = landmark_distances(&set.template.positions, &set.manifest.landmarks)?;
    let (loss, weights) = args.objective.loss_and_weights(&distances);
    let config = TrainConfig {
        loss,
        ..args.train.clone()
    };
    let mirroring = args.mirror.then(|| Mirroring::of(&set)).transpose()?;
    let mut per_fold = Vec::new();
    let mut errors: [Vec<f32>; 5] = Default::default();
    for fold in 0..args.folds {
        let s = split(&set.manifest, args.protocol, fold)?;
        let mut samples = s
            .train
            .iter()
            .map(|&p| set.sample(p, args.decoder.input))
            .collect::<Result<Vec<_>>>()?;
        if let Some(m) = &mirroring {
            samples.extend(m.training_samples(&set, &s, args.decoder.input)?);
        }
        let device = args.backend.autodiff_device(config.seed)?;
        let decoder = S2dDecoder::new(&args.decoder, &h, &device)?;
        if !quiet {
            eprintln!(
                "{} fold {fold}: {} training pairs ({} of them mirrored), {} test pairs, {} \
                 epochs, {} parameters",
                args.protocol,
                samples.len(),
                samples.len() - s.train.len(),
                s.test.len(),
                config.epochs,
                decoder.parameter_count()
            );
        }
        let checkpoint = fold_checkpoint_path(&args.out, fold);
        let resume = args.resume && checkpoint.join(STATE_FILE).exists();
        if args.resume && !resume {
            // Folds run in order, so any earlier run left fold 0's checkpoint.
            if fold == 0 {
                bail!(
                    "{}: no checkpoint to resume (no {STATE_FILE}); run without --resume to \
                     start, or give the --out of the run to continue",
                    checkpoint.display()
                );
            }
            if !quiet {
                eprintln!(
                    "fold {fold}: no checkpoint in {}, training from the start",
                    checkpoint.display()
                );
            }
        }
        if resume
            && !quiet
            && let Ok(st) = read_state(&checkpoint)
        {
            eprintln!(
                "fold {fold}: resuming from {} at epoch {} of {}, step {}",
                checkpoint.display(),
                st.epochs_done,
                st.config.epochs,
                st.steps_in_epoch
            );
        }
        let options = TrainOptions {
            checkpoint_dir: Some(checkpoint),
            resume,
            stop_after: None,
            context: run_context(args, &set, &s)?,
        };
        let trained = train(decoder, &samples, &weights, &config, &device, &options)?;
        let train_seconds = trained.state.seconds;
        let (decoder, losses) = (trained.decoder, trained.state.losses);
        let mut meta = vec![
            ("content", "s2d-decoder".to_owned()),
            ("units", set.manifest.units.clone()),
            ("protocol", args.protocol.to_string()),
            ("fold", fold.to_string()),
            ("pairs_seed", set.manifest.config.seed.to_string()),
            ("seed", config.seed.to_string()),
            ("config", serde_json::to_string(&config)?),
            ("objective", serde_json::to_string(&args.objective)?),
            ("decoder", serde_json::to_string(&args.decoder)?),
            ("factors", serde_json::to_string(&args.factors)?),
            ("source", set.manifest.source.clone()),
        ];
        if args.mirror {
            meta.push(("mirror", "true".to_owned()));
        }
        let meta: Vec<(String, String)> =
            meta.into_iter().map(|(k, v)| (k.to_owned(), v)).collect();
        let bytes = super::bake::bake(&decoder, &h, &set.manifest.landmarks, &meta)?;
        let model = fold_model_path(&args.out, fold);
        crate::atomic::write(&model, &bytes)?;
        let mirrored: Vec<&[f32]> = samples[s.train.len()..]
            .iter()
            .map(|m| m.displacement.as_slice())
            .collect();
        let fr = FoldReport {
            model,
            losses,
            train_seconds,
            ..evaluate_fold(&bytes, &set, &s, &mirrored, &mut errors)?
        };
        if !quiet {
            eprintln!(
                "fold {fold}: S2D {:.3} ± {:.3} mm, pca99 ({} comp.) {:.3} mm, pca_max ({} comp.) \
                 {:.3} mm, DL-3DMM ({} atoms) {:.3} mm, training-span floor {:.3} mm; trained in \
                 {train_seconds:.0} s",
                fr.s2d.mean_error_mm,
                fr.s2d.std_error_mm,
                fr.baselines.pca99.components.unwrap_or(0),
                fr.baselines.pca99.mean_error_mm,
                fr.baselines.pca_max.components.unwrap_or(0),
                fr.baselines.pca_max.mean_error_mm,
                fr.baselines.dl_3dmm.components.unwrap_or(0),
                fr.baselines.dl_3dmm.mean_error_mm,
                fr.baselines.span_floor.mean_error_mm
            );
        }
        per_fold.push(fr);
    }
    finish(
        per_fold,
        errors,
        args.protocol,
        Some((config, args.objective)),
        &args.pairs,
        &args.report,
        started,
    )
}

/// What a fold's checkpoint must match besides the configuration, decoder and data (which
/// [`train`] checks itself): the protocol and fold, the held-out set, the pairs' seed, the
/// objective and the hierarchy.
fn run_context(
    args: &TrainS2d,
    set: &PairSet,
    s: &Split,
) -> Result<std::collections::BTreeMap<String, String>> {
    let hierarchy = hierarchy::Config {
        factors: args.factors.clone(),
        spiral_lengths: None,
    };
    let mirror = args
        .mirror
        .then(|| ("mirror".to_owned(), "true".to_owned()));
    Ok([
        ("protocol", args.protocol.to_string()),
        ("fold", s.fold.to_string()),
        ("held_out", s.held_out.join(", ")),
        ("pairs_seed", set.manifest.config.seed.to_string()),
        (
            "objective",
            serde_json::to_value(args.objective)?
                .as_str()
                .unwrap_or_default()
                .to_owned(),
        ),
        (
            "hierarchy",
            format!("{:016x}", hierarchy::cache_key(&set.template, &hierarchy)),
        ),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_owned(), v))
    .chain(mirror)
    .collect())
}

/// Evaluates a baked model and the baselines on split `s` (the baselines learning from the
/// training pairs and the `mirrored` displacements), appending the per-vertex errors to `errors`
/// (S2D, pca99, pca_max, DL-3DMM, the span's floor). The report's model path, losses and
/// training time are left empty for the caller.
fn evaluate_fold(
    model_bytes: &[u8],
    set: &PairSet,
    s: &Split,
    mirrored: &[&[f32]],
    errors: &mut [Vec<f32>; 5],
) -> Result<FoldReport> {
    let s2d = decoder_errors(model_bytes, set, s)?;
    let b = baseline_errors(set, s, mirrored)?;
    let pairs = &set.manifest.pairs;
    let involves = |p: usize, item: &str| match s.protocol {
        Protocol::Identity => pairs[p].identity.to_string() == item,
        Protocol::Expression => pairs[p].shapes.iter().any(|c| c.shape == item),
    };
    let by_held_out = per_held_out(
        s,
        involves,
        set.vertices(),
        [&s2d, &b.pca99.0, &b.pca_max.0, &b.dl_3dmm.0],
    );
    let fr = FoldReport {
        fold: s.fold,
        held_out: s.held_out.clone(),
        train_pairs: s.train.len(),
        test_pairs: s.test.len(),
        s2d: ErrorStats::of(&s2d, None),
        baselines: Baselines {
            pca99: ErrorStats::of(&b.pca99.0, Some(b.pca99.1)),
            pca_max: ErrorStats::of(&b.pca_max.0, Some(b.pca_max.1)),
            dl_3dmm: ErrorStats::of(&b.dl_3dmm.0, Some(b.dl_3dmm.1)),
            span_floor: ErrorStats::of(&b.span_floor.0, Some(b.span_floor.1)),
        },
        model: PathBuf::new(),
        losses: Vec::new(),
        train_seconds: 0.0,
        per_held_out: by_held_out,
        mirrored_pairs: mirrored.len(),
    };
    errors[0].extend(s2d);
    errors[1].extend(b.pca99.0);
    errors[2].extend(b.pca_max.0);
    errors[3].extend(b.dl_3dmm.0);
    errors[4].extend(b.span_floor.0);
    Ok(fr)
}

/// The protocol and fold a model from `train s2d` was trained for, and whether with `--mirror`
/// (its metadata), checked against the pairs' seed.
fn trained_split(
    model: &Path,
    bytes: &[u8],
    set: &PairSet,
    pairs: &Path,
) -> Result<(Protocol, usize, bool)> {
    let file = sinew_core::SinewFile::from_bytes(bytes)
        .map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let meta = file.metadata();
    let protocol = match meta.get("protocol") {
        Some("identity") => Protocol::Identity,
        Some("expression") => Protocol::Expression,
        other => anyhow::bail!(
            "{}: no S2D protocol in the metadata (protocol={other:?}); train it with `sinew \
             train s2d`",
            model.display()
        ),
    };
    let fold: usize = meta
        .get("fold")
        .and_then(|f| f.parse().ok())
        .with_context(|| format!("{}: no fold in the metadata", model.display()))?;
    if let Some(seed) = meta.get("pairs_seed") {
        ensure!(
            seed == set.manifest.config.seed.to_string(),
            "{}: trained on pairs of seed {seed}, but {} has seed {}",
            model.display(),
            pairs.display(),
            set.manifest.config.seed
        );
    }
    Ok((protocol, fold, meta.get("mirror") == Some("true")))
}

/// `sinew eval s2d`: evaluates a model from `train s2d` on the test pairs of the fold it was
/// trained for (its `protocol` and `fold` metadata), with the baselines on the same split. With
/// `folds` K > 1, `model` is fold 0's and folds 1 to K − 1 are read beside it
/// ([`fold_model_path`], as `train s2d --folds K` writes them), each checked to be its fold of the
/// same protocol, and the report pools them as `train s2d`'s does.
pub fn eval_s2d(model: &Path, pairs: &Path, folds: usize, report: &Path) -> Result<Report> {
    ensure!(
        (1..=FOLDS).contains(&folds),
        "--folds {folds}: between 1 and {FOLDS}"
    );
    let started = Instant::now();
    let set = PairSet::read(pairs)?;
    let mut errors: [Vec<f32>; 5] = Default::default();
    let mut per_fold = Vec::with_capacity(folds);
    let mut first = None;
    let mut mirroring = None;
    for k in 0..folds {
        let path = fold_model_path(model, k);
        let bytes = crate::container::read(&path)?;
        let (protocol, fold, mirrored) = trained_split(&path, &bytes, &set, pairs)?;
        if folds > 1 {
            ensure!(
                fold == k,
                "{}: a model of fold {fold}, where `train s2d --folds {folds}` puts fold {k}",
                path.display()
            );
        }
        if let Some(p) = first {
            ensure!(
                protocol == p,
                "{}: trained on the {protocol} split, fold 0 on the {p} split",
                path.display()
            );
        }
        first = Some(protocol);
        let s = split(&set.manifest, protocol, fold)?;
        // A model trained with --mirror is compared with baselines that learnt from the same
        // mirrored pairs.
        let mirrored = if mirrored {
            let m = match &mirroring {
                Some(m) => m,
                None => mirroring.insert(Mirroring::of(&set)?),
            };
            m.displacements(&set, &s)
        } else {
            Vec::new()
        };
        let extra: Vec<&[f32]> = mirrored.iter().map(Vec::as_slice).collect();
        let fr = FoldReport {
            model: path.clone(),
            ..evaluate_fold(&bytes, &set, &s, &extra, &mut errors)
                .with_context(|| format!("{}", path.display()))?
        };
        per_fold.push(fr);
    }
    let protocol = first.context("no fold evaluated")?;
    finish(per_fold, errors, protocol, None, pairs, report, started)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_and_paths() {
        let s = ErrorStats::of(&[1.0, 3.0], None);
        assert_eq!((s.mean_error_mm, s.std_error_mm), (2.0, 1.0));
        assert_eq!(
            fold_model_path(Path::new("out/m.sinew"), 2),
            Path::new("out/m.fold2.sinew")
        );
        assert_eq!(
            fold_model_path(Path::new("out/m.sinew"), 0),
            Path::new("out/m.sinew")
        );
        assert_eq!(plot_path(Path::new("r/rep.json")), Path::new("r/rep.png"));
        assert_eq!(
            fold_checkpoint_path(Path::new("out/m.sinew"), 0),
            Path::new("out/m.ckpt")
        );
        assert_eq!(
            fold_checkpoint_path(Path::new("out/m.sinew"), 3),
            Path::new("out/m.fold3.ckpt")
        );
        let (l, w) = Objective::Dr.loss_and_weights(&[0.0, 1.0]);
        assert_eq!((l, w), (LossVariant::Paper, vec![0.0, 0.0]));
        let (_, w) = Objective::DrUnweighted.loss_and_weights(&[0.0, 1.0]);
        assert_eq!(w, [1.0, 1.0]);
        let (_, w) = Objective::Code.loss_and_weights(&[0.0, 1.0]);
        assert_eq!(w, [1.0, 0.0]);
    }

    /// Each held-out item's errors average the vertices of exactly the test pairs that involve
    /// it, per method; an item no test pair involves gets no pairs and zero error.
    #[test]
    fn held_out_errors_average_the_pairs_that_involve_each_item() {
        let s = Split {
            protocol: Protocol::Expression,
            fold: 0,
            held_out: vec!["a".into(), "b".into(), "c".into()],
            train: vec![0, 1],
            test: vec![2, 5, 7],
        };
        // Pair 2 uses a, pair 5 a and b, pair 7 b.
        let involves = |p: usize, item: &str| match item {
            "a" => p == 2 || p == 5,
            "b" => p == 5 || p == 7,
            _ => false,
        };
        // Two vertices a pair; method m (1 to 4) has errors m × [1, 2 | 3, 4 | 5, 6].
        let e: Vec<Vec<f32>> = (1..=4)
            .map(|m| (1..=6).map(|x| (m * x) as f32).collect())
            .collect();
        let h = per_held_out(&s, involves, 2, [&e[0], &e[1], &e[2], &e[3]]);
        let got: Vec<_> = h
            .iter()
            .map(|h| {
                (
                    h.held_out.as_str(),
                    h.pairs,
                    [h.s2d_mm, h.pca99_mm, h.pca_max_mm, h.dl_3dmm_mm],
                )
            })
            .collect();
        assert_eq!(
            got,
            [
                ("a", 2, [2.5, 5.0, 7.5, 10.0]),
                ("b", 2, [4.5, 9.0, 13.5, 18.0]),
                ("c", 0, [0.0; 4]),
            ]
        );
    }

    /// Small real pair sets (8 identities, 160 pairs, seed 3) of each kind, generated once for
    /// the tests of this module that use them; none without the data.
    fn real_pairs(expressions: Expressions) -> Option<&'static PairSet> {
        static SETS: [std::sync::OnceLock<PairSet>; 2] =
            [std::sync::OnceLock::new(), std::sync::OnceLock::new()];
        let root = crate::testing::data_dir()?;
        let slot = &SETS[usize::from(expressions == Expressions::Transferred)];
        Some(slot.get_or_init(|| {
            let kit = crate::ict::IctFaceKit::open(&root.join("ict-facekit")).unwrap();
            let config = super::super::data::PairsConfig {
                seed: 3,
                identities: 8,
                pairs: 160,
                max_shapes: 3,
                expressions,
            };
            super::super::data::generate(&kit, &config).unwrap()
        }))
    }

    /// On real pairs the larger PCA fits at least as well as pca99, and on the identity split
    /// (ICT's expression deltas are shared by all identities) it is nearly exact.
    #[test]
    fn pca_max_is_no_worse_than_pca99_on_real_pairs() {
        let Some(set) = real_pairs(Expressions::Shared) else {
            return;
        };
        for protocol in [Protocol::Identity, Protocol::Expression] {
            let s = split(&set.manifest, protocol, 0).unwrap();
            let all = baseline_errors(set, &s, &[]).unwrap();
            let [(p99, k99), (pmax, kmax), (dl, atoms)] = [all.pca99, all.pca_max, all.dl_3dmm];
            let (a, b) = (ErrorStats::of(&p99, None), ErrorStats::of(&pmax, None));
            let d = ErrorStats::of(&dl, None);
            let f = ErrorStats::of(&all.span_floor.0, None);
            eprintln!(
                "{protocol}: pca99 ({k99}) {:.4} mm, pca_max ({kmax}) {:.4} mm, DL-3DMM ({atoms}) \
                 {:.4} mm, span floor {:.4} mm",
                a.mean_error_mm, b.mean_error_mm, d.mean_error_mm, f.mean_error_mm
            );
            assert!(
                f.mean_error_mm < d.mean_error_mm.min(b.mean_error_mm),
                "{protocol}"
            );
            assert!(k99 <= kmax);
            assert!(b.mean_error_mm <= a.mean_error_mm * 1.001, "{protocol}");
            if protocol == Protocol::Identity {
                // Both models span the test displacements: only the prior's bias is left.
                assert!(b.mean_error_mm < 0.05, "{}", b.mean_error_mm);
                assert!(d.mean_error_mm < 0.1, "{}", d.mean_error_mm);
                assert!(f.mean_error_mm < 0.02, "{}", f.mean_error_mm);
            } else {
                assert!(d.mean_error_mm < 1.1 * b.mean_error_mm, "{protocol}");
            }
            assert!(atoms > kmax, "an overcomplete dictionary: {atoms} atoms");
        }
    }

    /// With identity-specific (transferred) expressions the identity split is no longer
    /// spanned by the training identities: `pca_max` misses the unseen identities' own way of
    /// performing each expression, by far more than the ridge's bias it had on shared deltas.
    #[test]
    fn transferred_expressions_make_the_identity_split_a_test() {
        let mut pca_max = Vec::new();
        for expressions in [Expressions::Shared, Expressions::Transferred] {
            let Some(set) = real_pairs(expressions) else {
                return;
            };
            let s = split(&set.manifest, Protocol::Identity, 0).unwrap();
            let (pmax, kmax) = baseline_errors(set, &s, &[]).unwrap().pca_max;
            let e = ErrorStats::of(&pmax, None).mean_error_mm;
            eprintln!("identity split, {expressions:?} expressions: pca_max ({kmax}) {e:.4} mm");
            pca_max.push(e);
        }
        assert!(pca_max[1] > 5.0 * pca_max[0], "{pca_max:?}");
    }
}
