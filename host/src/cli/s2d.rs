//! `train s2d`, `eval s2d` and `sinew s2d …`: the arguments, and the hand-over to
//! [`sinew_host::s2d`].

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use sinew_host::s2d::decoder::{DecoderConfig, InputNormalisation, StageActivation};
use sinew_host::s2d::experiment::{self, DEFAULT_EPOCHS, Objective, TrainS2d};
use sinew_host::s2d::hierarchy::{Config, DEFAULT_FACTORS};
use sinew_host::s2d::protocol::{FOLDS, Protocol};
use sinew_host::s2d::train::TrainConfig;
use sinew_host::training::backend::Backend;

#[derive(Debug, Subcommand)]
pub(crate) enum S2d {
    /// Build the mesh hierarchy (quadric decimation, up/down-sampling, spirals) of a template
    /// and write it as a .sinew file.
    Hierarchy {
        /// Template mesh (.obj or .ply); quads and polygons are triangulated.
        #[arg(long)]
        template: PathBuf,
        /// Output .sinew file.
        #[arg(long)]
        out: PathBuf,
        /// Decimation factor of each level, comma-separated.
        #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_FACTORS)]
        factors: Vec<usize>,
        /// Spiral length of each level, comma-separated (one more than factors), instead of
        /// int(mean + 2·std); `15,14,9,9,7` gives the reference network's shapes on FLAME.
        #[arg(long, value_delimiter = ',')]
        spiral_lengths: Option<Vec<usize>>,
    },
    /// The face a decoder decodes onto by default, as a mesh file: its template neutral with
    /// the template's triangles (a face in the decoder's topology for `sinew generate
    /// --neutral`, `s2d neutralize`, `s2d transfer`).
    Template {
        /// The baked S2D decoder.
        #[arg(long)]
        model: PathBuf,
        /// The pairs folder the decoder was trained on (from `sinew data s2d-pairs`): the
        /// triangles of a decoder baked without them (from 2026-11-23 to 2026-11-26).
        #[arg(long)]
        pairs: Option<PathBuf>,
        /// Output mesh (.obj, .obj.gz or .ply).
        #[arg(long)]
        out: PathBuf,
    },
    /// A decoder baked without its template's triangles (from 2026-11-23 to 2026-11-26) written
    /// again with them, taken from the pairs it was trained on, so that `sinew generate` and
    /// `sinew interpolate` decode onto its own face without --neutral. Every other section is
    /// kept, so it decodes to the same bits; its content hash changes.
    AddTriangles {
        /// The baked S2D decoder without triangles.
        #[arg(long)]
        model: PathBuf,
        /// The pairs folder the decoder was trained on (from `sinew data s2d-pairs`).
        #[arg(long)]
        pairs: PathBuf,
        /// Output .sinew file.
        #[arg(long)]
        out: PathBuf,
    },
    /// Expression neutralisation: an expressive face in, its neutral out (the decoder maps the
    /// face's landmarks onto the template's neutral landmarks).
    Neutralize {
        /// The baked S2D decoder.
        #[arg(long)]
        model: PathBuf,
        /// The expressive face (the decoder's template topology).
        #[arg(long)]
        input: PathBuf,
        /// Output mesh.
        #[arg(long)]
        out: PathBuf,
    },
    /// Expression transfer: a source sequence's landmark motion applied to a target neutral.
    Transfer {
        /// The baked S2D decoder.
        #[arg(long)]
        model: PathBuf,
        /// The source actor's neutral face.
        #[arg(long)]
        source_neutral: PathBuf,
        /// The source sequence: a folder of meshes (name order) or one mesh.
        #[arg(long)]
        source: PathBuf,
        /// The target actor's neutral face.
        #[arg(long)]
        target: PathBuf,
        /// Output folder: one OBJ per frame.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Debug, Args)]
pub(crate) struct TrainS2dArgs {
    /// Pairs folder (from `sinew data s2d-pairs`).
    #[arg(long)]
    pairs: PathBuf,
    /// Protocol: identity- or expression-independent.
    #[arg(long, value_enum)]
    protocol: Protocol,
    /// Output baked model of fold 0 (.sinew); fold k goes to MODEL.fold<k>.sinew, and each
    /// fold's checkpoints to MODEL.ckpt/ and MODEL.fold<k>.ckpt/.
    #[arg(long)]
    out: PathBuf,
    /// Output JSON report; the plot goes beside it (REPORT.png).
    #[arg(long)]
    report: PathBuf,
    #[arg(long, help = format!(
        "Epochs [default: {DEFAULT_EPOCHS}; {} with --paper-protocol] (the learning rate \
         decays by 0.99^(300/epochs) per epoch)",
        TrainConfig::default().epochs
    ))]
    epochs: Option<usize>,
    #[arg(long, help = format!("Folds to run, of {FOLDS} [default: 1; {FOLDS} with --paper-protocol]"))]
    folds: Option<usize>,
    /// The paper's schedule: 300 epochs on all 4 folds (unless --epochs/--folds say otherwise).
    #[arg(long)]
    paper_protocol: bool,
    /// Objective: the authors' code, the paper's text, or Table 2's ablations (dr: L_dr alone;
    /// dr-unweighted: L_dr + unweighted L_pr).
    #[arg(long, value_enum, default_value_t = Objective::Code)]
    loss: Objective,
    /// Seed of the weights and the shuffling.
    #[arg(long, env = "SINEW_SEED", default_value_t = TrainConfig::default().seed)]
    seed: u64,
    /// burn backend.
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    /// Say nothing while training.
    #[arg(long)]
    quiet: bool,
    /// Decimation factor of each hierarchy level, comma-separated (one per stage).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_FACTORS)]
    factors: Vec<usize>,
    /// Features per coarsest-level vertex after the fully connected layer.
    #[arg(long, default_value_t = DecoderConfig::default().fc_features)]
    fc_features: usize,
    /// Filters of each up-sampling stage, coarsest first, comma-separated (one per factor;
    /// default: the reference's 64,32,32,16).
    #[arg(long, value_delimiter = ',')]
    filters: Option<Vec<usize>>,
    /// Activation after each stage's spiral convolution (the reference's is ELU).
    #[arg(long, value_enum, default_value_t = StageActivation::Elu)]
    activation: StageActivation,
    /// How the decoder's input is made from the neutral and expressive landmarks (the
    /// reference's is `frobenius`).
    #[arg(long, value_enum, default_value_t = InputNormalisation::Frobenius)]
    input: InputNormalisation,
    /// Continue each fold from its checkpoint (MODEL.ckpt/, MODEL.fold<k>.ckpt/ beside the
    /// models, written after every epoch and on Ctrl-C); give the same other arguments. A fold
    /// whose checkpoint is complete is only baked and evaluated.
    #[arg(long)]
    resume: bool,
    /// Also train on the training pairs mirrored left to right (needs a left-right symmetric
    /// face region). On the expression split a pair is mirrored only when each of its shapes
    /// mirrors onto a training shape, so no held-out shape is seen mirrored; the baselines learn
    /// from the same pairs.
    #[arg(long)]
    mirror: bool,
    /// Folder of cached mesh hierarchies, reused across runs [default: sinew-cache in the
    /// system's temporary folder].
    #[arg(long, env = "SINEW_CACHE", value_name = "DIR")]
    cache: Option<PathBuf>,
}

/// `sinew eval s2d`.
#[derive(Debug, Args)]
pub(crate) struct EvalS2d {
    /// The baked S2D model.
    #[arg(long)]
    model: PathBuf,
    /// Pairs folder (the one it was trained on).
    #[arg(long)]
    pairs: PathBuf,
    /// Output JSON report; the plot goes beside it (REPORT.png).
    #[arg(long)]
    report: PathBuf,
    /// Evaluate the first K folds of a `train s2d --folds K` run: MODEL is fold 0's,
    /// MODEL.fold<k>.sinew beside it the others; the report pools them.
    #[arg(long, default_value_t = 1)]
    folds: usize,
}

/// `sinew train s2d`.
pub(crate) fn train(args: TrainS2dArgs) -> Result<()> {
    let mut train = TrainConfig {
        epochs: if args.paper_protocol {
            TrainConfig::default().epochs
        } else {
            DEFAULT_EPOCHS
        },
        ..TrainConfig::default()
    };
    if let Some(e) = args.epochs {
        train.epochs = e;
    }
    train.seed = args.seed;
    anyhow::ensure!(train.epochs > 0, "--epochs must be positive");
    let folds = args
        .folds
        .unwrap_or(if args.paper_protocol { FOLDS } else { 1 });
    eprintln!("seed {} (override with --seed or SINEW_SEED)", train.seed);
    let cache = args.cache.unwrap_or_else(experiment::default_cache_dir);
    eprintln!(
        "hierarchy cache {} (override with --cache or SINEW_CACHE)",
        cache.display()
    );
    let job = TrainS2d {
        pairs: args.pairs,
        protocol: args.protocol,
        folds,
        train,
        objective: args.loss,
        out: args.out,
        report: args.report.clone(),
        backend: args.backend,
        decoder: DecoderConfig {
            fc_features: args.fc_features,
            filters: args.filters.unwrap_or(DecoderConfig::default().filters),
            activation: args.activation,
            input: args.input,
            ..DecoderConfig::default()
        },
        factors: args.factors,
        resume: args.resume,
        mirror: args.mirror,
        cache,
    };
    let r = experiment::train_s2d(&job, args.quiet)?;
    print_s2d(&r, &args.report);
    Ok(())
}

/// `sinew eval s2d`.
pub(crate) fn eval(args: EvalS2d) -> Result<()> {
    let r = experiment::eval_s2d(&args.model, &args.pairs, args.folds, &args.report)?;
    print_s2d(&r, &args.report);
    Ok(())
}

/// `sinew s2d`.
pub(crate) fn run(cmd: S2d) -> Result<()> {
    match cmd {
        S2d::Hierarchy {
            template,
            out,
            factors,
            spiral_lengths,
        } => {
            let config = Config {
                factors,
                spiral_lengths,
            };
            let h = sinew_host::s2d::hierarchy::s2d_hierarchy(&template, &out, &config)?;
            let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
            let lens: Vec<usize> = h.levels.iter().map(|l| l.spiral_len).collect();
            println!(
                "{}: vertices per level {sizes:?}, spiral lengths {lens:?}",
                out.display()
            );
        }
        S2d::Template { model, pairs, out } => {
            let face = sinew_host::s2d::apply::write_template(&model, pairs.as_deref(), &out)?;
            println!(
                "{}: the template of {}, {} vertices, {} triangles",
                out.display(),
                model.display(),
                face.positions.len(),
                face.polygons.len()
            );
        }
        S2d::AddTriangles { model, pairs, out } => {
            let face = sinew_host::s2d::apply::add_triangles(&model, &pairs, &out)?;
            println!(
                "{}: {} with its template's {} triangles",
                out.display(),
                model.display(),
                face.polygons.len()
            );
        }
        S2d::Neutralize { model, input, out } => {
            sinew_host::s2d::apply::neutralize(&model, &input, &out)?;
            println!("neutral face written to {}", out.display());
        }
        S2d::Transfer {
            model,
            source_neutral,
            source,
            target,
            out,
        } => {
            let frames = sinew_host::s2d::apply::mesh_files(&source)?;
            let n =
                sinew_host::s2d::apply::transfer(&model, &source_neutral, &frames, &target, &out)?;
            println!("{n} frames written to {}", out.display());
        }
    }
    Ok(())
}

fn print_s2d(r: &experiment::Report, report: &std::path::Path) {
    // A report over several folds has a component count per fold only.
    let count = |c: Option<usize>, unit: &str| {
        c.map_or_else(|| "per fold".to_owned(), |k| format!("{k} {unit}"))
    };
    let comp = |c| count(c, "comp.");
    let atoms = |c| count(c, "atoms");
    println!(
        "{}: {} split, {} fold(s), {} test pairs: S2D {:.3} ± {:.3} mm, pca99 ({}) {:.3} ± {:.3} \
         mm, pca_max ({}) {:.3} ± {:.3} mm, DL-3DMM ({}) {:.3} ± {:.3} mm; training-span floor \
         {:.3} mm; plot {}",
        report.display(),
        r.protocol,
        r.folds,
        r.test_pairs,
        r.mean_error_mm,
        r.std_error_mm,
        comp(r.baselines.pca99.components),
        r.baselines.pca99.mean_error_mm,
        r.baselines.pca99.std_error_mm,
        comp(r.baselines.pca_max.components),
        r.baselines.pca_max.mean_error_mm,
        r.baselines.pca_max.std_error_mm,
        atoms(r.baselines.dl_3dmm.components),
        r.baselines.dl_3dmm.mean_error_mm,
        r.baselines.dl_3dmm.std_error_mm,
        r.baselines.span_floor.mean_error_mm,
        r.plot.display()
    );
}
