//! `sinew train s2d` and `sinew eval s2d`: S2D-Dec against the PCA baselines on the paper's
//! protocols (S2D §4.2, Table 1 and Fig. 3; Table 2's loss ablation through [`Objective`]).
//!
//! Every error is the per-vertex Euclidean distance between the predicted and the ground-truth
//! expressive face, in mm (ICT is in cm), over every vertex of every test pair; the report gives
//! its mean and (population) standard deviation, as Table 1 does.

use std::path::{Path, PathBuf};
use std::time::Instant;

mod error;
pub use error::ExperimentError;

/// What the experiment functions return.
type Result<T> = std::result::Result<T, ExperimentError>;

use super::baseline::{DEFAULT_RIDGE, Dictionary, DictionaryConfig, Pca};
use super::checkpoint::{STATE_FILE, read_state};
use super::data::{Expressions, PairSet};
use super::decoder::{DecoderConfig, InputNormalisation, S2dDecoder};
use super::hierarchy;
pub use super::objective::Objective;
use super::protocol::{FOLDS, Protocol, Split, split};
pub use super::report::*;
use super::symmetry::{Mirror, partners};
use super::train::{Sample, TrainConfig, TrainOptions, landmark_distances, train};
use crate::training::backend::Backend;

/// Default epochs of `sinew train s2d` (one fold within 45 minutes on the shared 2-core machine;
/// docs/S2D.md has the measurement).
pub const DEFAULT_EPOCHS: usize = 70;

/// ICT is in cm; errors are reported in mm.
const MM_PER_UNIT: f32 = 10.0;

/// `train s2d --mirror`: the face region's left–right symmetry, and each expression shape's
/// mirror image among the shapes.
struct Mirroring {
    mirror: Mirror,
    partners: Vec<Option<usize>>,
}

impl Mirroring {
    fn of(set: &PairSet) -> Result<Self> {
        let mirror = Mirror::of(&set.template).map_err(ExperimentError::Symmetry)?;
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
            .collect::<std::result::Result<_, _>>()
            .map_err(Into::into)
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
    /// The folder of cached mesh hierarchies ([`hierarchy::cached`]; usually
    /// [`default_cache_dir`]).
    pub cache: PathBuf,
}

/// The default hierarchy cache folder: `sinew-cache` in the system's temporary folder (`sinew
/// train s2d --cache DIR` or `SINEW_CACHE` choose another).
pub fn default_cache_dir() -> PathBuf {
    std::env::temp_dir().join("sinew-cache")
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
    crate::training::checkpoint::checkpoint_dir_for(&fold_model_path(out, fold))
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
    let dec =
        sinew_core::s2d::S2dDecoder::from_bytes(model).map_err(ExperimentError::NotADecoder)?;
    if dec.vertex_count() != set.vertices() {
        return Err(ExperimentError::VertexCount {
            model: dec.vertex_count(),
            pairs: set.vertices(),
        });
    }
    if !dec
        .landmarks()
        .iter()
        .eq(set.manifest.landmarks.iter().copied())
    {
        return Err(ExperimentError::Landmarks);
    }
    let input = InputNormalisation::from_code(dec.input_normalisation())?;
    let mut scratch = vec![0.0f32; dec.scratch_len()];
    let mut out = vec![0.0f32; 3 * set.vertices()];
    let mut errors = Vec::with_capacity(s.test.len() * set.vertices());
    for &p in &s.test {
        let sample = set.sample(p, input)?;
        dec.displacements(&sample.input, &mut scratch, &mut out)
            .map_err(|error| ExperimentError::Decode { pair: p, error })?;
        vertex_errors(set, p, &out, &mut errors);
    }
    Ok(errors)
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
    cumulative_plot(&methods, &title).save_png(&plot)?;
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
    crate::io::atomic::write(report, serde_json::to_string_pretty(&r)?.as_bytes())?;
    Ok(r)
}

/// `sinew train s2d`: per fold, trains S2D-Dec on the training pairs (the hierarchy of the face
/// region from [`hierarchy::cached`]) with a checkpoint folder beside the fold's model (or
/// continues from it, `args.resume`), bakes it, evaluates the baked model and the baselines on
/// the test pairs, then writes the pooled report and the cumulative-error plot.
pub fn train_s2d(args: &TrainS2d, quiet: bool) -> Result<Report> {
    let started = Instant::now();
    if !(1..=FOLDS).contains(&args.folds) {
        return Err(ExperimentError::Folds(args.folds));
    }
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
    let h = hierarchy::cached(&set.template, &args.factors, &args.cache)
        .map_err(ExperimentError::Hierarchy)?;
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
            .collect::<std::result::Result<Vec<_>, _>>()?;
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
                return Err(ExperimentError::NoCheckpoint {
                    path: checkpoint,
                    file: STATE_FILE,
                });
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
            ("units", set.manifest.units.name().to_owned()),
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
        crate::io::atomic::write(&model, &bytes)?;
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
    let file =
        sinew_core::SinewFile::from_bytes(bytes).map_err(|source| ExperimentError::Format {
            path: model.to_path_buf(),
            source,
        })?;
    let meta = file.metadata();
    let protocol = match meta.get("protocol") {
        Some("identity") => Protocol::Identity,
        Some("expression") => Protocol::Expression,
        other => {
            return Err(ExperimentError::NoProtocol {
                path: model.to_path_buf(),
                protocol: other.map(str::to_owned),
            });
        }
    };
    let fold: usize = meta
        .get("fold")
        .and_then(|f| f.parse().ok())
        .ok_or_else(|| ExperimentError::NoFold {
            path: model.to_path_buf(),
        })?;
    if let Some(seed) = meta.get("pairs_seed")
        && seed != set.manifest.config.seed.to_string()
    {
        return Err(ExperimentError::PairsSeed {
            path: model.to_path_buf(),
            model_seed: seed.to_owned(),
            pairs: pairs.to_path_buf(),
            pairs_seed: set.manifest.config.seed,
        });
    }
    Ok((protocol, fold, meta.get("mirror") == Some("true")))
}

/// `sinew eval s2d`: evaluates a model from `train s2d` on the test pairs of the fold it was
/// trained for (its `protocol` and `fold` metadata), with the baselines on the same split. With
/// `folds` K > 1, `model` is fold 0's and folds 1 to K − 1 are read beside it
/// ([`fold_model_path`], as `train s2d --folds K` writes them), each checked to be its fold of the
/// same protocol, and the report pools them as `train s2d`'s does.
pub fn eval_s2d(model: &Path, pairs: &Path, folds: usize, report: &Path) -> Result<Report> {
    if !(1..=FOLDS).contains(&folds) {
        return Err(ExperimentError::Folds(folds));
    }
    let started = Instant::now();
    let set = PairSet::read(pairs)?;
    let mut errors: [Vec<f32>; 5] = Default::default();
    let mut per_fold = Vec::with_capacity(folds);
    let mut first = None;
    let mut mirroring = None;
    for k in 0..folds {
        let path = fold_model_path(model, k);
        let bytes = crate::io::container::read(&path)?;
        let (protocol, fold, mirrored) = trained_split(&path, &bytes, &set, pairs)?;
        if folds > 1 && fold != k {
            return Err(ExperimentError::WrongFold {
                path,
                fold,
                folds,
                expected: k,
            });
        }
        if let Some(p) = first
            && protocol != p
        {
            return Err(ExperimentError::OtherProtocol {
                path,
                protocol,
                first: p,
            });
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
            ..evaluate_fold(&bytes, &set, &s, &extra, &mut errors).map_err(|e| {
                ExperimentError::InModel {
                    path: path.clone(),
                    source: Box::new(e),
                }
            })?
        };
        per_fold.push(fr);
    }
    // The fold loop ran at least once (folds ≥ 1), so fold 0 set the protocol.
    let protocol = first.ok_or(ExperimentError::Folds(folds))?;
    finish(per_fold, errors, protocol, None, pairs, report, started)
}

#[cfg(test)]
mod tests;
