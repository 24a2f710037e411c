//! The `sinew` command line: parse, validate, then hand over to `sinew_host::commands`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use sinew_host::aim::AimConfig;
use sinew_host::aim::config::{JawInit, Schedule};
use sinew_host::aim::run::Outputs;
use sinew_host::backend::Backend;
use sinew_host::commands;
use sinew_host::s2d::data::{Expressions, PairsConfig};
use sinew_host::s2d::decoder::{DecoderConfig, InputNormalisation, StageActivation};
use sinew_host::s2d::experiment::{self, DEFAULT_EPOCHS, Objective, TrainS2d};
use sinew_host::s2d::hierarchy::{Config, DEFAULT_FACTORS};
use sinew_host::s2d::protocol::{FOLDS, Protocol};
use sinew_host::s2d::train::TrainConfig;

/// Sinew: learn an actor's face from meshes, and play it back anywhere, bit for bit.
#[derive(Debug, Parser)]
#[command(name = "sinew", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The built-in demo: train a small AIM on a procedural face, bake it, play it back through
    /// sinew-core, and write the report, pictures and OBJs. Needs no data files.
    Demo {
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Optimisation steps (default: the demo configuration's).
        #[arg(long)]
        iterations: Option<usize>,
        #[command(flatten)]
        jaw: JawArgs,
        /// Hide the progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Train a model.
    #[command(subcommand)]
    Train(Train),
    /// Measure a baked model on data.
    #[command(subcommand)]
    Eval(Eval),
    /// Re-bake a model from a training checkpoint.
    Bake {
        /// Checkpoint folder (MODEL.ckpt from `sinew train aim`).
        #[arg(long)]
        checkpoint: PathBuf,
        /// Output .sinew file.
        #[arg(long)]
        out: PathBuf,
        /// Evaluate the networks at this mesh's vertices instead of the training template (e.g.
        /// another resolution of the same face).
        #[arg(long)]
        template: Option<PathBuf>,
        /// Leave the networks out (small targets).
        #[arg(long)]
        playback_only: bool,
        /// Add the Q16.16 playback cache for the core's fixed-point mode (FPU-less targets).
        #[arg(long)]
        q16: bool,
    },
    /// Pose a baked actor through sinew-core, one OBJ per frame.
    Play {
        /// The baked actor.
        #[arg(long)]
        model: PathBuf,
        /// Pose file: {"frames": [{"head": [9], "jaw": [9], "weights": [M]}, ...]}.
        #[arg(long)]
        poses: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Show what a .sinew file holds: kind, version, sections, shapes, sizes, checksum status.
    Inspect {
        /// The .sinew file.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Anatomy editing.
    #[command(subcommand)]
    Edit(Edit),
    /// Bones under the skin.
    #[command(subcommand)]
    Bones(Bones),
    /// Record and verify bit-exact playback replays.
    #[command(subcommand)]
    Replay(Replay),
    /// S2D: sparse-to-dense expression decoding.
    #[command(subcommand)]
    S2d(S2d),
    /// Generate data sets.
    #[command(subcommand)]
    Data(Data),
}

#[derive(Debug, Subcommand)]
enum Data {
    /// S2D training pairs (neutral, expressive) on the ICT-FaceKit face region: random
    /// identities (N(0, 1) weights of the identity modes) and sparse combinations of expression
    /// shapes; writes pairs.sinew and manifest.json into the output folder.
    S2dPairs {
        /// ICT-FaceKit folder.
        #[arg(long)]
        data: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Seed (default 1; SINEW_SEED overrides the default, --seed overrides both).
        #[arg(long)]
        seed: Option<u64>,
        /// Number of identities.
        #[arg(long, default_value_t = PairsConfig::default().identities)]
        identities: usize,
        /// Number of pairs.
        #[arg(long, default_value_t = PairsConfig::default().pairs)]
        pairs: usize,
        /// Most expression shapes combined in one pair.
        #[arg(long, default_value_t = PairsConfig::default().max_shapes)]
        max_shapes: usize,
        /// Decimate the face region by this factor (quadric decimation; landmarks move to the
        /// nearest kept vertex): data for decoders small enough for microcontrollers.
        #[arg(long)]
        decimate: Option<usize>,
        /// `shared`: the kit's expression deltas, the same for every identity; `transferred`:
        /// each delta deformation-transferred onto each identity (identity-specific
        /// expressions, stored per identity).
        #[arg(long, value_enum, default_value_t = PairsConfig::default().expressions)]
        expressions: Expressions,
    },
}

#[derive(Debug, Subcommand)]
enum Replay {
    /// Play a pose file through sinew-core and record each frame's hash with the model's content
    /// hash into a replay (.sinew).
    Record {
        /// The baked actor, or a baked S2D decoder.
        #[arg(long)]
        model: PathBuf,
        /// Pose file: {"frames": [{"head": [9], "jaw": [9], "weights": [M]}, ...]}; for an S2D
        /// decoder {"frames": [{"input": [I]}, ...], "neutral": [V·3]} (neutral optional: without
        /// it the frames decode onto the decoder's template).
        #[arg(long)]
        poses: PathBuf,
        /// Output replay (.sinew).
        #[arg(long)]
        out: PathBuf,
        /// Numeric mode: f32 (reference), q16 (fixed point; needs `bake --q16`), fast
        /// (micromath).
        #[arg(long, default_value = "f32", value_parser = parse_mode)]
        mode: sinew_core::replay::Mode,
    },
    /// Play a replay through sinew-core and compare every frame's hash with the recorded one;
    /// fails naming the first frame that differs.
    Verify {
        /// The baked actor (or S2D decoder) the replay was recorded with.
        #[arg(long)]
        model: PathBuf,
        /// The replay (.sinew).
        #[arg(long)]
        replay: PathBuf,
    },
}

fn parse_mode(s: &str) -> Result<sinew_core::replay::Mode, String> {
    sinew_core::replay::Mode::from_name(s)
        .ok_or_else(|| format!("unknown mode {s:?}: f32, q16 or fast"))
}

#[derive(Debug, Subcommand)]
enum S2d {
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

#[derive(Debug, Subcommand)]
enum Bones {
    /// Register the template skull and jaw to an ICT-FaceKit neutral (similarity from landmarks
    /// offset by soft-tissue thickness, then ICP); writes skull.obj, jaw.obj, fit.json, bones.png.
    Fit {
        /// ICT-FaceKit folder.
        #[arg(long)]
        data: PathBuf,
        /// Folder with the template bones (artisynth-jaw/, skull-odedstein/); default
        /// $SINEW_DATA or ../shared/data.
        #[arg(long)]
        templates: Option<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Debug, Subcommand)]
enum Train {
    /// Learn an AIM actor from ICT-FaceKit blendshapes.
    Aim(TrainAim),
    /// Train S2D-Dec on pairs from `sinew data s2d-pairs` under a cross-validation protocol,
    /// bake each fold's model, and compare it with the PCA baselines on the held-out pairs
    /// (report JSON, and a cumulative-error PNG beside it).
    S2d(TrainS2dArgs),
}

#[derive(Debug, Args)]
struct TrainS2dArgs {
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
    /// Seed of the weights and the shuffling (SINEW_SEED overrides the default).
    #[arg(long)]
    seed: Option<u64>,
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
}

#[derive(Debug, Args)]
struct TrainAim {
    /// ICT-FaceKit folder.
    #[arg(long)]
    data: PathBuf,
    /// Output baked model (.sinew); its checkpoints go to MODEL.ckpt/.
    #[arg(long)]
    out: PathBuf,
    /// Output JSON report.
    #[arg(long)]
    report: PathBuf,
    /// Optimisation steps (overrides the configuration).
    #[arg(long)]
    iterations: Option<usize>,
    /// JSON configuration file (fields of AimConfig; missing ones take their defaults).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Continue from this checkpoint folder.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Folder with skull.obj and jaw.obj aligned to the neutral (from `sinew bones fit`);
    /// without it the bones are fitted now from the template bones in ../shared/data.
    #[arg(long)]
    bones: Option<PathBuf>,
    /// burn backend.
    #[arg(long, value_enum, default_value_t = Backend::Flex)]
    backend: Backend,
    /// Learning rate (overrides the configuration).
    #[arg(long)]
    lr: Option<f64>,
    /// Final learning rate (overrides the configuration).
    #[arg(long)]
    lr_end: Option<f64>,
    /// Learning-rate schedule (overrides the configuration).
    #[arg(long, value_enum)]
    schedule: Option<Schedule>,
    /// Seed (overrides the configuration).
    #[arg(long)]
    seed: Option<u64>,
    /// Thickness activation: softplus (positive by construction, the default) or identity (the
    /// paper); overrides the configuration.
    #[arg(long, value_enum)]
    thickness_activation: Option<sinew_host::aim::config::ThicknessActivation>,
    #[command(flatten)]
    jaw: JawArgs,
    /// Folder for pictures (error heatmaps, anatomy, loss curve) and OBJs.
    #[arg(long)]
    pictures: Option<PathBuf>,
    /// Hide the progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, Subcommand)]
enum Eval {
    /// Evaluate a model from `sinew train s2d` (through sinew-core) and the 3DMM baselines on the
    /// held-out pairs of the fold it was trained for (or of each of its folds, `--folds`).
    S2d {
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
    },
    /// Per-vertex error of a baked AIM actor on its ICT-FaceKit training shapes.
    Aim {
        /// The baked actor.
        #[arg(long)]
        model: PathBuf,
        /// ICT-FaceKit folder.
        #[arg(long)]
        data: PathBuf,
        /// Output JSON report.
        #[arg(long)]
        report: PathBuf,
        /// Bones folder (as for `train aim`), for the constraint statistics.
        #[arg(long)]
        bones: Option<PathBuf>,
    },
}

#[derive(Debug, Subcommand)]
enum Edit {
    /// Scale the learned soft-tissue thickness in a region and re-derive the skin (AIM Fig. 5).
    Thickness {
        /// The baked actor.
        #[arg(long)]
        model: PathBuf,
        /// Region: JSON list of vertex indices, or {"weights": [...]} with one weight per vertex.
        #[arg(long)]
        mask: PathBuf,
        /// Thickness factor inside the region.
        #[arg(long)]
        scale: f32,
        /// Output folder (edited neutral OBJ and a before/after picture).
        #[arg(long)]
        out: PathBuf,
    },
}

/// The jaw options of `train aim` and `demo`.
#[derive(Debug, Args)]
struct JawArgs {
    /// How the jaw transforms start: bones (rigid fits of the jaw-constrained skin, the default)
    /// or identity (the paper's; use with --lambda-jaw 0); overrides the configuration.
    #[arg(long, value_enum)]
    jaw_init: Option<JawInit>,
    /// λ_J of the jaw skinning term (k = 1 on the skin over the jaw; default 1; 0 = the paper's
    /// objective); overrides the configuration.
    #[arg(long)]
    lambda_jaw: Option<f32>,
}

impl JawArgs {
    fn apply(&self, config: &mut AimConfig) {
        if let Some(j) = self.jaw_init {
            config.jaw_init = j;
        }
        if let Some(l) = self.lambda_jaw {
            config.lambda_jaw = l;
        }
    }
}

fn config_for(args: &TrainAim) -> Result<AimConfig> {
    let mut config = match &args.config {
        Some(p) => commands::read_config(p)?,
        None => AimConfig::default(),
    };
    if let Some(n) = args.iterations {
        config.iterations = n;
    }
    if let Some(v) = args.lr {
        config.lr = v;
    }
    if let Some(v) = args.lr_end {
        config.lr_end = v;
    }
    if let Some(s) = args.schedule {
        config.schedule = s;
    }
    if let Some(a) = args.thickness_activation {
        config.thickness_activation = a;
    }
    args.jaw.apply(&mut config);
    if let Some(s) = args.seed {
        config.seed = s;
    }
    if let Some(s) = std::env::var("SINEW_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        config.seed = s;
    }
    config.validate()?;
    Ok(config)
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Demo {
            out,
            iterations,
            jaw,
            quiet,
        } => {
            let mut config = AimConfig::demo();
            if let Some(n) = iterations {
                config.iterations = n;
            }
            jaw.apply(&mut config);
            let report = commands::demo(&out, &config, quiet)?;
            println!("{}", serde_json::to_string_pretty(&report)?);
            eprintln!("demo written to {}", out.display());
        }
        Command::Train(Train::Aim(args)) => {
            let config = config_for(&args)?;
            eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
            let (set, said) =
                commands::ict_training_set(&args.data, args.bones.as_deref(), &config)?;
            eprintln!(
                "{said}; {:.1}% of {} vertices constrained",
                100.0 * set.constrained_fraction(),
                set.vertices()
            );
            let outputs = Outputs {
                model: args.out.clone(),
                report: args.report.clone(),
                pictures: args.pictures.clone(),
            };
            let report = commands::train_aim(
                &set,
                &config,
                args.backend,
                &outputs,
                args.resume.as_deref(),
                args.quiet,
            )?;
            println!(
                "{}: mean {:.3} mm, p95 {:.3} mm, max {:.3} mm over {} shapes in {:.0} s",
                args.out.display(),
                report.mean_error_mm,
                report.p95_error_mm,
                report.max_error_mm,
                report.shapes,
                report.seconds
            );
        }
        Command::Train(Train::S2d(args)) => {
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
            if let Some(s) = std::env::var("SINEW_SEED")
                .ok()
                .and_then(|s| s.parse().ok())
            {
                train.seed = s;
            }
            if let Some(s) = args.seed {
                train.seed = s;
            }
            anyhow::ensure!(train.epochs > 0, "--epochs must be positive");
            let folds = args
                .folds
                .unwrap_or(if args.paper_protocol { FOLDS } else { 1 });
            eprintln!("seed {} (override with --seed or SINEW_SEED)", train.seed);
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
            };
            let r = experiment::train_s2d(&job, args.quiet)?;
            print_s2d(&r, &args.report);
        }
        Command::Eval(Eval::S2d {
            model,
            pairs,
            report,
            folds,
        }) => {
            let r = experiment::eval_s2d(&model, &pairs, folds, &report)?;
            print_s2d(&r, &report);
        }
        Command::Eval(Eval::Aim {
            model,
            data,
            report,
            bones,
        }) => {
            let r = commands::eval_aim(&model, &data, bones.as_deref())?;
            sinew_host::atomic::write(&report, serde_json::to_string_pretty(&r)?.as_bytes())?;
            println!(
                "{}: mean {:.3} mm, median {:.3} mm, p95 {:.3} mm, max {:.3} mm",
                model.display(),
                r.mean_error_mm,
                r.median_error_mm,
                r.p95_error_mm,
                r.max_error_mm
            );
        }
        Command::Bake {
            checkpoint,
            out,
            template,
            playback_only,
            q16,
        } => {
            commands::bake(&checkpoint, &out, template.as_deref(), playback_only, q16)?;
            println!("{}", sinew_host::inspect::inspect(&out)?);
        }
        Command::Play { model, poses, out } => {
            let n = commands::play(&model, &poses, &out, None)?;
            println!("{n} frames written to {}", out.display());
        }
        Command::Inspect { file, json } => {
            let report = sinew_host::inspect::inspect(&file)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                print!("{report}");
            }
        }
        Command::Bones(Bones::Fit {
            data,
            templates,
            out,
        }) => {
            let templates = match templates {
                Some(t) => t,
                None => commands::default_bone_templates()?,
            };
            let report = commands::bones_fit(&data, &templates, &out)?;
            println!("{}", serde_json::to_string_pretty(&report)?);
            eprintln!("bones written to {}", out.display());
        }
        Command::Replay(Replay::Record {
            model,
            poses,
            out,
            mode,
        }) => {
            let n = commands::replay_record(&model, &poses, &out, mode)?;
            println!("{n} frames ({mode}) recorded to {}", out.display());
        }
        Command::Replay(Replay::Verify { model, replay }) => {
            let v = commands::replay_verify(&model, &replay)?;
            for f in &v.frames {
                println!("{f}");
            }
            if v.mode != sinew_core::replay::Mode::F32 {
                let d = commands::replay_deviation(&model, &replay)?;
                println!(
                    "{} mode vs f32: positions max {:.6} mm, mean {:.6} mm; unit normals max {:.2e}, mean {:.2e} apart",
                    v.mode, d.max_mm, d.mean_mm, d.max_normal_diff, d.mean_normal_diff
                );
            }
            match v.first_mismatch {
                None => println!(
                    "{}: {} frames ({}) bit-identical",
                    replay.display(),
                    v.frames.len(),
                    v.mode
                ),
                Some(f) => anyhow::bail!(
                    "{}: frame {f} differs from the recording ({} of {} frames differ)",
                    replay.display(),
                    v.frames.iter().filter(|c| !c.ok()).count(),
                    v.frames.len()
                ),
            }
        }
        Command::S2d(S2d::Hierarchy {
            template,
            out,
            factors,
            spiral_lengths,
        }) => {
            let config = Config {
                factors,
                spiral_lengths,
            };
            let h = commands::s2d_hierarchy(&template, &out, &config)?;
            let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
            let lens: Vec<usize> = h.levels.iter().map(|l| l.spiral_len).collect();
            println!(
                "{}: vertices per level {sizes:?}, spiral lengths {lens:?}",
                out.display()
            );
        }
        Command::S2d(S2d::Neutralize { model, input, out }) => {
            sinew_host::s2d::apply::neutralize(&model, &input, &out)?;
            println!("neutral face written to {}", out.display());
        }
        Command::S2d(S2d::Transfer {
            model,
            source_neutral,
            source,
            target,
            out,
        }) => {
            let frames = sinew_host::s2d::apply::mesh_files(&source)?;
            let n =
                sinew_host::s2d::apply::transfer(&model, &source_neutral, &frames, &target, &out)?;
            println!("{n} frames written to {}", out.display());
        }
        Command::Data(Data::S2dPairs {
            data,
            out,
            seed,
            identities,
            pairs,
            max_shapes,
            decimate,
            expressions,
        }) => {
            let seed = seed
                .or_else(|| std::env::var("SINEW_SEED").ok()?.parse().ok())
                .unwrap_or(PairsConfig::default().seed);
            let config = PairsConfig {
                seed,
                identities,
                pairs,
                max_shapes,
                expressions,
            };
            config.validate()?;
            eprintln!("seed {seed} (override with --seed or SINEW_SEED)");
            let set = sinew_host::s2d::data::generate_to(&data, &out, &config, decimate)?;
            println!(
                "{}: {} pairs of {} identities over {} expression shapes ({:?}) in {} groups, {} \
                 vertices",
                out.display(),
                set.len(),
                set.neutrals.len(),
                set.manifest.expressions.len(),
                expressions,
                set.manifest.shape_groups.len(),
                set.vertices()
            );
        }
        Command::Edit(Edit::Thickness {
            model,
            mask,
            scale,
            out,
        }) => {
            commands::edit_thickness(&model, &mask, scale, &out)
                .with_context(|| format!("editing {}", model.display()))?;
            println!("edited neutral and picture written to {}", out.display());
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

fn main() -> ExitCode {
    // Before any thread starts: may re-execute this program once (same arguments).
    sinew_host::malloc::keep_freed_memory();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sinew: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
