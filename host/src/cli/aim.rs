//! `sinew demo`, `train aim`, `eval aim`, `bake`, `play` and `edit`: the arguments, and the
//! hand-over to [`sinew_host::aim`].

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use sinew_host::aim::AimConfig;
use sinew_host::aim::config::{JawInit, Schedule};
use sinew_host::aim::prior::Prior;
use sinew_host::aim::run::Outputs;
use sinew_host::aim::target::{Ending, Target};
use sinew_host::training::backend::Backend;

/// `sinew demo`.
#[derive(Debug, Args)]
pub(crate) struct DemoArgs {
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
}

/// `sinew bake`.
#[derive(Debug, Args)]
pub(crate) struct BakeArgs {
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
}

/// `sinew play`.
#[derive(Debug, Args)]
pub(crate) struct PlayArgs {
    /// The baked actor.
    #[arg(long)]
    model: PathBuf,
    /// Pose file: {"frames": [{"head": [9], "jaw": [9], "weights": [M]}, ...]}.
    #[arg(long, required_unless_present_any = ["arkit", "performance"], conflicts_with_all = ["arkit", "performance"])]
    poses: Option<PathBuf>,
    /// Live Link Face capture (CSV): each ARKit channel drives the actor's shape of that name
    /// (`_L`/`_R` for Left/Right); the mapping and the channels the actor cannot play go to
    /// OUT/arkit.json.
    #[arg(long, conflicts_with = "performance")]
    arkit: Option<PathBuf>,
    /// A fitted performance (`sinew fit --out FIT.sinew`) of this actor, local coefficients
    /// evaluated per vertex by the core.
    #[arg(long)]
    performance: Option<PathBuf>,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
}

/// `sinew eval aim`.
#[derive(Debug, Args)]
pub(crate) struct EvalAim {
    /// The baked actor.
    #[arg(long)]
    model: PathBuf,
    /// ICT-FaceKit folder.
    #[arg(long, required_unless_present = "rig", conflicts_with = "rig")]
    data: Option<PathBuf>,
    /// A blendshape rig instead of the kit (.glb/.gltf, or a folder with neutral.obj and
    /// shapes/NAME.obj), as the actor was trained on it.
    #[arg(long)]
    rig: Option<PathBuf>,
    #[command(flatten)]
    rig_read: super::args::RigReadArgs,
    /// Output JSON report.
    #[arg(long)]
    report: PathBuf,
    /// Bones folder (as for `train aim`), for the constraint statistics.
    #[arg(long)]
    bones: Option<PathBuf>,
    #[command(flatten)]
    templates: super::args::TemplatesArg,
    #[command(flatten)]
    identity: super::args::IdentityArg,
}

#[derive(Debug, Args)]
pub(crate) struct TrainAim {
    /// ICT-FaceKit folder.
    #[arg(long, required_unless_present = "rig", conflicts_with = "rig")]
    data: Option<PathBuf>,
    /// A blendshape rig instead of the kit: a .glb/.gltf head with morph targets, or a folder
    /// with neutral.obj and shapes/NAME.obj (see docs/RIGS.md). Learns every shape it has
    /// unless --shapes picks.
    #[arg(long)]
    rig: Option<PathBuf>,
    #[command(flatten)]
    rig_read: super::args::RigReadArgs,
    /// With --rig: the shapes to learn, comma separated (default: all of the rig's).
    #[arg(long, value_delimiter = ',', requires = "rig")]
    shapes: Vec<String>,
    /// Output baked model (.sinew); its checkpoints go to MODEL.ckpt/.
    #[arg(long)]
    out: PathBuf,
    /// Output JSON report.
    #[arg(long)]
    report: PathBuf,
    /// Optimisation steps (overrides the configuration): the schedule's length, and the most
    /// the run takes when it aims for an accuracy (`--steps` is the same).
    #[arg(long, visible_alias = "steps")]
    iterations: Option<usize>,
    #[command(flatten)]
    target: TargetArgs,
    /// JSON configuration file (fields of AimConfig; missing ones take their defaults).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Continue from this checkpoint folder.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Start from this actor's networks instead of the built-in prior: any actor baked with its
    /// networks (not --playback-only), such as an earlier training of the same or another face,
    /// with the run's network sizes (docs/AIM.md, "Starting from a prior").
    #[arg(long, conflicts_with_all = ["resume", "no_prior"])]
    prior: Option<PathBuf>,
    /// Start from random weights, not from the built-in prior.
    #[arg(long, conflicts_with = "resume")]
    no_prior: bool,
    /// Folder with skull.obj and jaw.obj aligned to the neutral (from `sinew bones fit`);
    /// without it the bones are fitted now from the template bones (--templates).
    #[arg(long)]
    bones: Option<PathBuf>,
    #[command(flatten)]
    templates: super::args::TemplatesArg,
    #[command(flatten)]
    identity: super::args::IdentityArg,
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
    #[arg(long, env = "SINEW_SEED")]
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
pub(crate) enum Edit {
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

/// The accuracy `train aim` stops at (docs/AIM.md, "Training to an accuracy").
#[derive(Debug, Args)]
pub(crate) struct TargetArgs {
    /// Stop once the mean per-vertex error over the training shapes is at most this (mm).
    #[arg(long, allow_negative_numbers = true, default_value_t = Target::default().mean_mm)]
    target_mean: f64,
    /// ... and its 95th percentile at most this (mm).
    #[arg(long, allow_negative_numbers = true, default_value_t = Target::default().p95_mm)]
    target_p95: f64,
    /// ... and jawOpen's learned jaw moved by at most this since the last check (degrees).
    #[arg(long, allow_negative_numbers = true, default_value_t = Target::default().jaw_settle_degrees)]
    target_jaw_settle: f64,
    /// ... and jawOpen's learned jaw turns by at least this (degrees; 0: no least opening).
    #[arg(long, allow_negative_numbers = true, default_value_t = Target::default().jaw_degrees)]
    target_jaw_degrees: f64,
    /// Steps between two accuracy checks.
    #[arg(long, default_value_t = Target::default().every)]
    check_every: usize,
    /// Run every step, without accuracy checks.
    #[arg(long, conflicts_with_all = ["target_mean", "target_p95", "target_jaw_settle", "target_jaw_degrees", "check_every"])]
    no_target: bool,
}

impl TargetArgs {
    /// The target asked for, checked (`None` with `--no-target`).
    fn target(&self) -> Result<Option<Target>> {
        if self.no_target {
            return Ok(None);
        }
        let target = Target {
            mean_mm: self.target_mean,
            p95_mm: self.target_p95,
            jaw_settle_degrees: self.target_jaw_settle,
            jaw_degrees: self.target_jaw_degrees,
            every: self.check_every,
        };
        target.validate()?;
        Ok(Some(target))
    }
}

/// The jaw options of `train aim` and `demo`.
#[derive(Debug, Args)]
pub(crate) struct JawArgs {
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

/// The configuration of `train aim`: the file's (or the default), then each flag given (a flag
/// or its environment variable beats the file).
fn config_for(args: &TrainAim) -> Result<AimConfig> {
    let mut config = match &args.config {
        Some(p) => sinew_host::aim::config::read_config(p)?,
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
    config.validate()?;
    Ok(config)
}

/// `sinew demo`.
pub(crate) fn demo(args: DemoArgs) -> Result<()> {
    let mut config = AimConfig::demo();
    if let Some(n) = args.iterations {
        config.iterations = n;
    }
    args.jaw.apply(&mut config);
    let report = sinew_host::aim::demo::demo(&args.out, &config, args.quiet)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    eprintln!("demo written to {}", args.out.display());
    Ok(())
}

/// `sinew train aim`.
pub(crate) fn train(args: TrainAim) -> Result<()> {
    let mut config = config_for(&args)?;
    let target = args.target.target()?;
    // Read before any work, so that a file that cannot start the run stops it at once.
    let chosen = args.prior.as_deref().map(Prior::read).transpose()?;
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let (set, said) = match (&args.rig, &args.data) {
        (Some(path), _) => {
            let rig = args.rig_read.open(path)?;
            sinew_host::aim::commands::rig_training_set(
                &rig,
                &args.shapes,
                args.bones.as_deref(),
                &args.templates.path,
                &config,
            )?
        }
        (None, Some(data)) => sinew_host::aim::commands::ict_training_set(
            data,
            &args.identity.weights,
            args.bones.as_deref(),
            &args.templates.path,
            &config,
        )?,
        (None, None) => bail!("give --data or --rig"),
    };
    eprintln!(
        "{said}; {:.1}% of {} vertices constrained",
        100.0 * set.constrained_fraction(),
        set.vertices()
    );
    let prior = match chosen {
        Some(p) => Some(p),
        None if args.no_prior || args.resume.is_some() => None,
        // The built-in prior starts every run it fits (sizes, units, a shape in common).
        None => Some(Prior::builtin()?).filter(|p| p.fits(&config, &set.names, set.units.name())),
    };
    if args.config.is_none() {
        // A run from a prior takes its own rate and shorter schedule; a resumed one keeps the
        // rate and schedule it began with.
        let resumed = match &args.resume {
            Some(dir) if prior.is_none() => Some(sinew_host::aim::train::read_state(dir)?.config),
            _ => None,
        };
        sinew_host::aim::prior::run_defaults(
            &mut config,
            args.lr.is_some(),
            args.iterations.is_some(),
            prior.is_some(),
            resumed.as_ref(),
        );
        config.validate()?;
    }
    if let Some(p) = &prior {
        eprintln!(
            "starting from {} ({} of {} shapes known) at learning rate {:e}{}",
            p.path().display(),
            p.shared(&set.names),
            set.names.len() - 1,
            config.lr,
            if args.prior.is_none() {
                "; --no-prior starts from random weights"
            } else {
                ""
            }
        );
    }
    let outputs = Outputs {
        model: args.out.clone(),
        report: args.report.clone(),
        pictures: args.pictures.clone(),
    };
    let report = sinew_host::aim::commands::train_aim(
        &set,
        &config,
        args.backend,
        &outputs,
        sinew_host::aim::commands::TrainAimRun {
            resume: args.resume.as_deref(),
            quiet: args.quiet,
            target,
            prior,
        },
    )?;
    match (&report.ended, report.missed.is_empty()) {
        (Some(Ending::Target), _) => eprintln!(
            "the target was met at step {} of at most {}",
            report.iterations, config.iterations
        ),
        (Some(Ending::AlreadyMet), _) => eprintln!(
            "the checkpoint at step {} already meets the target: no step taken",
            report.iterations
        ),
        (Some(Ending::Steps), false) => eprintln!(
            "all {} steps ran without meeting the target: {}",
            report.iterations,
            report.missed.join("; ")
        ),
        _ => {}
    }
    println!(
        "{}: mean {:.3} mm, p95 {:.3} mm, max {:.3} mm over {} shapes in {:.0} s",
        args.out.display(),
        report.mean_error_mm,
        report.p95_error_mm,
        report.max_error_mm,
        report.shapes,
        report.seconds
    );
    Ok(())
}

/// `sinew eval aim`.
pub(crate) fn eval(args: EvalAim) -> Result<()> {
    let EvalAim {
        model,
        data,
        rig,
        rig_read,
        report,
        bones,
        templates,
        identity,
    } = args;
    let r = match (&rig, &data) {
        (Some(path), _) => sinew_host::aim::commands::eval_aim_rig(
            &model,
            &rig_read.open(path)?,
            bones.as_deref(),
            &templates.path,
        )?,
        (None, Some(data)) => sinew_host::aim::commands::eval_aim(
            &model,
            data,
            &identity.weights,
            bones.as_deref(),
            &templates.path,
        )?,
        (None, None) => bail!("give --data or --rig"),
    };
    sinew_host::io::atomic::write(&report, serde_json::to_string_pretty(&r)?.as_bytes())?;
    println!(
        "{}: mean {:.3} mm, median {:.3} mm, p95 {:.3} mm, max {:.3} mm",
        model.display(),
        r.mean_error_mm,
        r.median_error_mm,
        r.p95_error_mm,
        r.max_error_mm
    );
    Ok(())
}

/// `sinew bake`.
pub(crate) fn bake(args: BakeArgs) -> Result<()> {
    sinew_host::aim::commands::bake(
        &args.checkpoint,
        &args.out,
        args.template.as_deref(),
        args.playback_only,
        args.q16,
    )?;
    println!("{}", sinew_host::io::inspect::inspect(&args.out)?);
    Ok(())
}

/// `sinew play`.
pub(crate) fn play(args: PlayArgs) -> Result<()> {
    let n = match (&args.poses, &args.arkit, &args.performance) {
        (Some(poses), _, _) => sinew_host::aim::play::play(&args.model, poses, &args.out, None)?,
        (None, None, Some(perf)) => {
            sinew_host::fit::commands::play_performance(&args.model, perf, &args.out)?
        }
        (None, Some(capture), _) => {
            let playback = sinew_host::aim::arkit::play_arkit(&args.model, capture, &args.out)?;
            if !playback.mapping.unplayable.is_empty() {
                eprintln!(
                    "the actor cannot play these capture channels: {}",
                    playback.mapping.unplayable.join(", ")
                );
            }
            playback.frames.len()
        }
        (None, None, None) => anyhow::bail!("give --poses, --arkit or --performance"),
    };
    println!("{n} frames written to {}", args.out.display());
    Ok(())
}

/// `sinew edit`.
pub(crate) fn edit(cmd: Edit) -> Result<()> {
    match cmd {
        Edit::Thickness {
            model,
            mask,
            scale,
            out,
        } => {
            sinew_host::aim::edit::edit_thickness(&model, &mask, scale, &out)
                .with_context(|| format!("editing {}", model.display()))?;
            println!("edited neutral and picture written to {}", out.display());
        }
    }
    Ok(())
}
