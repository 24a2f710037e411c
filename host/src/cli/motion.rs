//! `sinew data motions`, `sinew train motion`, `sinew generate`, `sinew interpolate` and
//! `sinew eval motion`: Motion3DGAN's data, training, generation and evaluation (docs/MOTION.md).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use sinew_host::motion::commands::{TrainMotion, train_motion};
use sinew_host::motion::data::{MotionsConfig, Split, generate_to};
use sinew_host::motion::evaluate::{EvalMotion, EvalSettings, eval_motion};
use sinew_host::motion::gan::{GanConfig, Pairing};
use sinew_host::motion::generate::Generate;
use sinew_host::motion::ground_truth::GroundTruth;
use sinew_host::motion::variation::Variation;
use sinew_host::training::backend::Backend;

/// `sinew data motions`'s options.
#[derive(Debug, Args)]
pub(crate) struct MotionsArgs {
    /// ICT-FaceKit folder.
    #[arg(long)]
    data: PathBuf,
    /// Output folder (motions.sinew and manifest.json).
    #[arg(long)]
    out: PathBuf,
    /// Seed of the identities, the sequences' timing and the noise.
    #[arg(long, env = "SINEW_SEED", default_value_t = MotionsConfig::default().seed)]
    seed: u64,
    /// Number of identities.
    #[arg(long, default_value_t = MotionsConfig::default().identities)]
    identities: usize,
    /// Sequences per identity and label; the first of each is a test sequence.
    #[arg(long, default_value_t = MotionsConfig::default().per_class)]
    per_class: usize,
    #[command(flatten)]
    variation: VariationArgs,
}

/// The knobs of what makes sequences of one label differ (docs/MOTION.md, "What makes sequences
/// differ"); each spread and probability is multiplied by --difficulty.
#[derive(Debug, Args)]
pub(crate) struct VariationArgs {
    /// Scales every knob below (0: each label's fixed pattern, timing and jitter only).
    #[arg(long, default_value_t = Variation::default().difficulty)]
    difficulty: f32,
    /// σ of each part's weight in an identity's style of a label.
    #[arg(long, default_value_t = Variation::default().style)]
    style: f32,
    /// Probability that a style drops a part (never the strongest).
    #[arg(long, default_value_t = Variation::default().drop)]
    drop: f32,
    /// Probability that a style borrows each delta of a neighbouring class.
    #[arg(long, default_value_t = Variation::default().borrow)]
    borrow: f32,
    /// Most a style leans towards a neighbouring class of its family (0 to 1).
    #[arg(long, default_value_t = Variation::default().lean)]
    lean: f32,
    /// σ of a style's left-right asymmetry.
    #[arg(long, default_value_t = Variation::default().asymmetry)]
    asymmetry: f32,
    /// Most a sequence mixes in the identity's style of a neighbouring class (0 to 1).
    #[arg(long, default_value_t = Variation::default().mix)]
    mix: f32,
    /// Probability of each of two co-activations (blink, brow, slight smile, frown) per sequence.
    #[arg(long, default_value_t = Variation::default().coactivation)]
    coactivation: f32,
    /// Probability that a sequence holds its apex and partly releases it.
    #[arg(long, default_value_t = Variation::default().release)]
    release: f32,
    /// Probability that a sequence has two peaks.
    #[arg(long, default_value_t = Variation::default().two_peaks)]
    two_peaks: f32,
    /// Probability that a sequence stops short of its apex.
    #[arg(long, default_value_t = Variation::default().short)]
    short: f32,
    /// σ of the landmarks' per-frame tracking noise, in cm.
    #[arg(long, default_value_t = Variation::default().tracking_noise)]
    tracking_noise: f32,
}

impl VariationArgs {
    fn variation(&self) -> Variation {
        Variation {
            difficulty: self.difficulty,
            style: self.style,
            drop: self.drop,
            borrow: self.borrow,
            lean: self.lean,
            asymmetry: self.asymmetry,
            mix: self.mix,
            coactivation: self.coactivation,
            release: self.release,
            two_peaks: self.two_peaks,
            short: self.short,
            tracking_noise: self.tracking_noise,
        }
    }
}

/// `sinew data motions`.
pub(crate) fn motions(args: MotionsArgs) -> Result<()> {
    let config = MotionsConfig {
        seed: args.seed,
        identities: args.identities,
        per_class: args.per_class,
        variation: args.variation.variation(),
    };
    config.validate()?;
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let set = generate_to(&args.data, &args.out, &config)?;
    println!(
        "{}: {} synthetic sequences ({} train, {} test) of {} identities in 12 classes over {} \
         expression deltas, {} vertices, 68 landmarks",
        args.out.display(),
        set.len(),
        set.split(Split::Train).len(),
        set.split(Split::Test).len(),
        set.neutrals.len(),
        set.manifest.expressions.len(),
        set.vertices()
    );
    Ok(())
}

/// `sinew train motion`'s options.
#[derive(Debug, Args)]
pub(crate) struct TrainMotionArgs {
    /// Motion set folder (from `sinew data motions`); its training sequences train.
    #[arg(long)]
    motions: PathBuf,
    /// The baked generator to write (`.sinew`); the loss curves go beside it
    /// (`OUT.losses.png`), checkpoints into `OUT.ckpt/`.
    #[arg(long)]
    out: PathBuf,
    /// JSON report (settings, losses per step, time).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Continue from this checkpoint folder (same settings and motions).
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Seed of the weights, the noise and the batches.
    #[arg(long, env = "SINEW_SEED", default_value_t = GanConfig::default().seed)]
    seed: u64,
    /// Generator steps (each after 4 critic steps).
    #[arg(long, default_value_t = GanConfig::default().steps)]
    steps: usize,
    /// Sequences per batch.
    #[arg(long, default_value_t = GanConfig::default().batch)]
    batch: usize,
    /// Adam's learning rate (β = 0.5, 0.9).
    #[arg(long, default_value_t = GanConfig::default().lr)]
    lr: f64,
    /// Hidden widths of the generator and the critic, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = GanConfig::default().hidden)]
    hidden: Vec<usize>,
    /// α2, the weight of the reconstruction loss L_r beside the adversarial loss's 1.
    #[arg(long, default_value_t = GanConfig::default().alpha_rec)]
    rec_weight: f32,
    /// λ_div, the weight of the diversity term: minus the mean geodesic distance between two
    /// motions of one label from different noise (0: none, as the paper).
    #[arg(long, default_value_t = GanConfig::default().diversity)]
    diversity_weight: f32,
    /// λ_cls, the weight of the label guide's cross-entropy on the generated motions: a
    /// classifier of the training motions that rewards motions that look like their label
    /// (0: none, as the paper).
    #[arg(long, default_value_t = GanConfig::default().class_weight)]
    class_weight: f32,
    /// The real motion L_r compares each generated one with: the batch's motion in the same row
    /// (batch, the reference's) or the batch's motion of the same label nearest to it (nearest).
    #[arg(long, value_enum, default_value_t = GanConfig::default().pairing)]
    pairing: Pairing,
    /// Generator steps between checkpoints.
    #[arg(long, default_value_t = 500)]
    checkpoint_every: usize,
    /// burn backend.
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// `sinew train motion`.
pub(crate) fn train(args: TrainMotionArgs) -> Result<()> {
    let config = GanConfig {
        seed: args.seed,
        steps: args.steps,
        batch: args.batch,
        lr: args.lr,
        hidden: args.hidden,
        pairing: args.pairing,
        alpha_rec: args.rec_weight,
        diversity: args.diversity_weight,
        class_weight: args.class_weight,
        ..GanConfig::default()
    };
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let report = train_motion(&TrainMotion {
        motions: args.motions,
        out: args.out.clone(),
        report: args.report,
        resume: args.resume,
        config,
        checkpoint_every: args.checkpoint_every,
        backend: args.backend,
        quiet: args.quiet,
    })?;
    let last = report.history.last().copied().unwrap_or_default();
    println!(
        "{}: Motion3DGAN generator, {} steps on {} training sequences in {:.1} s; last step: \
         Wasserstein estimate {:.4}, gradient penalty {:.4}, L_r {:.5}",
        args.out.display(),
        report.history.len(),
        report.sequences,
        report.seconds,
        last.wasserstein,
        last.penalty,
        last.reconstruction
    );
    Ok(())
}

/// `sinew generate` and `sinew interpolate`'s shared options.
#[derive(Debug, Args)]
pub(crate) struct GenerateArgs {
    /// The baked generator (from `sinew train motion`).
    #[arg(long)]
    model: PathBuf,
    /// The baked S2D decoder (from `sinew train s2d`), whose landmarks the generator moves.
    #[arg(long)]
    decoder: PathBuf,
    /// Seed of the noise.
    #[arg(long, env = "SINEW_SEED", default_value_t = 1)]
    seed: u64,
    /// The neutral face (.obj or .ply) in the decoder's topology [default: the decoder's own
    /// template neutral and triangles; `sinew s2d template` writes it as a mesh].
    #[arg(long)]
    neutral: Option<PathBuf>,
    /// Scale of the motion (eq. 5; 1: a length drawn from the label's training motions, or for
    /// interpolate the two labels' mean lengths blended).
    #[arg(long, default_value_t = 1.0)]
    intensity: f32,
    /// Output folder: frame_NN.obj and strip.png.
    #[arg(long)]
    out: PathBuf,
}

impl GenerateArgs {
    fn options(&self) -> Generate {
        Generate {
            model: self.model.clone(),
            decoder: self.decoder.clone(),
            neutral: self.neutral.clone(),
            seed: self.seed,
            intensity: self.intensity,
            out: self.out.clone(),
        }
    }
}

/// `sinew generate`'s options.
#[derive(Debug, Args)]
pub(crate) struct GenerateLabelArgs {
    /// The expression label (one of CoMA's twelve, e.g. mouth_open).
    #[arg(long)]
    label: String,
    #[command(flatten)]
    common: GenerateArgs,
}

/// `sinew interpolate`'s options.
#[derive(Debug, Args)]
pub(crate) struct InterpolateArgs {
    /// The label the geodesic starts at.
    #[arg(long)]
    from: String,
    /// The label it ends at.
    #[arg(long)]
    to: String,
    /// Points along the geodesic, ends included.
    #[arg(long, default_value_t = 8)]
    steps: usize,
    #[command(flatten)]
    common: GenerateArgs,
}

/// `sinew generate`.
pub(crate) fn generate(args: GenerateLabelArgs) -> Result<()> {
    eprintln!(
        "seed {} (override with --seed or SINEW_SEED)",
        args.common.seed
    );
    sinew_host::motion::generate::generate(&args.common.options(), &args.label)?;
    println!(
        "{}: {} frames of {} (frame_01.obj to frame_{:02}.obj) and strip.png",
        args.common.out.display(),
        sinew_core::srvf::FRAMES,
        args.label,
        sinew_core::srvf::FRAMES
    );
    Ok(())
}

/// `sinew interpolate`.
pub(crate) fn interpolate(args: InterpolateArgs) -> Result<()> {
    eprintln!(
        "seed {} (override with --seed or SINEW_SEED)",
        args.common.seed
    );
    sinew_host::motion::generate::interpolate(
        &args.common.options(),
        &args.from,
        &args.to,
        args.steps,
    )?;
    println!(
        "{}: {} apexes from {} to {} along the geodesic (frame_01.obj to frame_{:02}.obj) and \
         strip.png",
        args.common.out.display(),
        args.steps,
        args.from,
        args.to,
        args.steps
    );
    Ok(())
}

/// `sinew eval motion`'s options.
#[derive(Debug, Args)]
pub(crate) struct EvalMotionArgs {
    /// The baked generator (from `sinew train motion`). Without it and --decoder: only the
    /// ground truth's accuracy, per label and confused (how hard the set is).
    #[arg(long, requires = "decoder")]
    model: Option<PathBuf>,
    /// The baked S2D decoder whose 68 landmarks the generator moves (Det-LM decodes through it).
    #[arg(long, requires = "model")]
    decoder: Option<PathBuf>,
    /// Motion set folder (from `sinew data motions`): its training sequences train the
    /// classifier and the LSTM baseline, its test sequences are the ground truth.
    #[arg(long)]
    motions: PathBuf,
    /// JSON report to write.
    #[arg(long)]
    report: PathBuf,
    /// Seed of the classifier, the LSTM baseline and the generated motions' seeds.
    #[arg(long, env = "SINEW_SEED", default_value_t = 1)]
    seed: u64,
    /// Training epochs of the classifier and of the LSTM baseline.
    #[arg(long, default_value_t = 40)]
    epochs: usize,
    /// Motions per label (from different seeds) for the diversity.
    #[arg(long, default_value_t = 10)]
    diversity_seeds: usize,
    /// burn backend.
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// `sinew eval motion`.
pub(crate) fn eval(args: EvalMotionArgs) -> Result<()> {
    eprintln!("seed {} (override with --seed or SINEW_SEED)", args.seed);
    let settings = EvalSettings {
        diversity_seeds: args.diversity_seeds,
        ..EvalSettings::new(args.seed, args.epochs)
    };
    let (Some(model), Some(decoder)) = (args.model, args.decoder) else {
        return ground_truth(
            args.motions,
            args.report,
            settings,
            args.backend,
            args.quiet,
        );
    };
    let r = eval_motion(&EvalMotion {
        model,
        decoder,
        motions: args.motions,
        report: args.report.clone(),
        settings,
        backend: args.backend,
        quiet: args.quiet,
    })?;
    println!(
        "{} test sequences, {} training; classifier {:.1} % on its training set",
        r.test_sequences,
        r.train_sequences,
        100.0 * r.classifier_train_accuracy
    );
    println!("row     accuracy GT / Motion3DGAN / LSTM   Fréchet Motion3DGAN / LSTM   diversity");
    for (name, row) in [("Gen-LM", &r.gen_lm), ("Det-LM", &r.det_lm)] {
        println!(
            "{name}  {:5.1} % / {:5.1} % / {:5.1} %        {:8.3} / {:8.3}          {:.3} (LSTM {:.3})",
            100.0 * row.accuracy_gt,
            100.0 * row.accuracy_motion3dgan,
            100.0 * row.accuracy_lstm,
            row.frechet_motion3dgan,
            row.frechet_lstm,
            row.diversity,
            row.diversity_lstm
        );
    }
    println!("{}: report ({:.1} s)", args.report.display(), r.seconds);
    Ok(())
}

/// `sinew eval motion` without a generator: the ground truth's accuracy alone.
fn ground_truth(
    motions: PathBuf,
    report: PathBuf,
    settings: EvalSettings,
    backend: Backend,
    quiet: bool,
) -> Result<()> {
    let r = sinew_host::motion::ground_truth::ground_truth(&GroundTruth {
        motions,
        report: report.clone(),
        settings,
        backend,
        quiet,
    })?;
    println!(
        "{} test sequences, {} training; ground truth (Gen-LM) {:.1} % (classifier {:.1} % \
         on its training set)",
        r.test_sequences,
        r.train_sequences,
        100.0 * r.accuracy,
        100.0 * r.train_accuracy
    );
    let labels = sinew_host::motion::classes::LABELS;
    for (l, acc) in r.per_label_accuracy.iter().enumerate() {
        let confused: Vec<String> = r.confusion[l]
            .iter()
            .enumerate()
            .filter(|&(p, &n)| p != l && n > 0)
            .map(|(p, n)| format!("{} {n}", labels[p]))
            .collect();
        println!(
            "  {:<14} {:5.1} %  {}",
            labels[l],
            100.0 * acc,
            confused.join(", ")
        );
    }
    println!("{}: report ({:.1} s)", report.display(), r.seconds);
    Ok(())
}
