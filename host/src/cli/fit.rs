//! `sinew fit`, `sinew eval fit` and `sinew retarget`: the arguments, and the hand-over to
//! [`sinew_host::fit`].

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use sinew_host::driver::commands::driven_starts;
use sinew_host::fit::aim::{Coefficients, Constrain, FitConfig, Mode, Start};
use sinew_host::fit::commands::{DrivenStarts, eval_fit, fit_command, retarget_command};
use sinew_host::fit::retarget::SourceFit;
use sinew_host::training::backend::Backend;

/// `sinew fit` and `sinew eval fit`'s shared options.
#[derive(Debug, Args)]
pub(crate) struct FitOptions {
    /// Adam steps per fit (the paper: 10,000).
    #[arg(long, default_value_t = FitConfig::default().iterations)]
    iterations: usize,
    /// Template points constrained per step (every frame at once).
    #[arg(long, default_value_t = FitConfig::default().points)]
    points: usize,
    /// Frame code size f.
    #[arg(long, default_value_t = FitConfig::default().code)]
    code: usize,
    /// Hidden width of F_T and F_W.
    #[arg(long, default_value_t = FitConfig::default().hidden)]
    hidden: usize,
    /// Adam's learning rate (the paper: 1e-3).
    #[arg(long, default_value_t = FitConfig::default().lr)]
    lr: f64,
    /// Adam's learning rate at the last step, decaying exponentially from --lr (equal to --lr:
    /// constant).
    #[arg(long, default_value_t = FitConfig::default().lr_final)]
    lr_final: f64,
    /// ω0 of a sine first layer of a local F_W (0: all GELU, the paper's; default: 30 for 3d
    /// fits to all vertices or a fraction, 0 for the landmarks and 2d).
    #[arg(long)]
    fw_omega0: Option<f32>,
    /// Where each frame's head starts: rigid (the rigid alignment of the actor's neutral to the
    /// frame; a 2d fit starts at the identity), identity, or driver (`sinew fit` only: where the
    /// landmark driver given with --driver puts the head and jaw).
    #[arg(long, value_enum, default_value_t = FitConfig::default().start)]
    start: Start,
    /// λ_3D of eq. 20, on squared millimetres (the paper gives no value).
    #[arg(long, default_value_t = FitConfig::default().lambda_3d)]
    lambda_3d: f64,
    /// λ_W of eq. 22 (the paper: 0.75).
    #[arg(long, default_value_t = FitConfig::default().lambda_w)]
    lambda_w: f64,
    /// Seed of the fit's initial weights and point draws.
    #[arg(long, env = "SINEW_SEED", default_value_t = FitConfig::default().seed)]
    seed: u64,
    /// burn backend.
    #[arg(long, value_enum, default_value_t = Backend::default())]
    backend: Backend,
}

impl FitOptions {
    fn config(&self, coefficients: Coefficients) -> FitConfig {
        FitConfig {
            iterations: self.iterations,
            points: self.points,
            code: self.code,
            hidden: self.hidden,
            lr: self.lr,
            lr_final: self.lr_final,
            lambda_3d: self.lambda_3d,
            fw_omega0: self.fw_omega0,
            start: self.start,
            lambda_w: self.lambda_w,
            seed: self.seed,
            coefficients,
            ..FitConfig::default()
        }
    }
}

/// `sinew fit`.
#[derive(Debug, Args)]
pub(crate) struct FitArgs {
    /// The baked AIM actor.
    #[arg(long)]
    model: PathBuf,
    /// The performance folder (`sinew data performance`).
    #[arg(long)]
    target: PathBuf,
    /// Output FIT.sinew: the fit baked for playback (`sinew play --performance`, `sinew view`,
    /// sinew-core); the core's playback of it goes to FIT.meshes/ beside it.
    #[arg(long)]
    out: PathBuf,
    /// Report JSON (errors, timing, loss history).
    #[arg(long)]
    report: PathBuf,
    /// One coefficient vector per frame (the paper's "(G)") instead of per template point.
    #[arg(long)]
    global: bool,
    /// Fit the meshes (3d, eq. 20) or the 68 landmark tracks through the performance's camera
    /// (2d, eq. 21).
    #[arg(long, value_enum, default_value_t = Mode::ThreeD)]
    mode: Mode,
    /// Vertices constraining a 3d fit: all, landmarks (the 68), or a fraction in (0, 1] drawn
    /// once with the seed (AIM Fig. 7).
    #[arg(long, default_value = "all")]
    constrain: Constrain,
    /// Continue the fit saved in this checkpoint folder (FIT.ckpt/, written every 200 steps and
    /// on Ctrl-C) with the same settings; --iterations may be raised.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// With --start driver: the landmark driver (`sinew train driver`) whose answer for the
    /// performance's track the fit refines.
    #[arg(long)]
    driver: Option<PathBuf>,
    #[command(flatten)]
    options: FitOptions,
}

/// `sinew retarget`.
#[derive(Debug, Args)]
pub(crate) struct RetargetArgs {
    /// The baked AIM actor whose performance is retargeted.
    #[arg(long)]
    source: PathBuf,
    /// The baked AIM actor that plays it: in vertex correspondence with the source, or of any
    /// other topology (matched through the built-in face template); its shapes play the
    /// source's of the same names.
    #[arg(long)]
    target: PathBuf,
    /// A performance folder of the source (`sinew data performance`) to fit the source to
    /// first (into OUT/source.sinew).
    #[arg(long, conflicts_with = "fit", required_unless_present = "fit")]
    performance: Option<PathBuf>,
    /// A fit of the source baked before (`sinew fit --out`), instead of --performance.
    #[arg(long)]
    fit: Option<PathBuf>,
    /// Output folder: target.sinew, jaw.sinew, soft.sinew, one OBJ per frame of each in
    /// target/, jaw/, soft/, strip.png and report.json.
    #[arg(long)]
    out: PathBuf,
    /// Frames in strip.png, 0-based and comma separated (default: four spread over the
    /// performance).
    #[arg(long, value_delimiter = ',')]
    frames: Option<Vec<usize>>,
    /// Fit one coefficient vector per frame (the paper's "(G)") instead of per template point.
    #[arg(long)]
    global: bool,
    #[command(flatten)]
    options: FitOptions,
}

/// `sinew retarget`.
pub(crate) fn retarget(args: RetargetArgs) -> Result<()> {
    let input = match (args.performance, args.fit) {
        (_, Some(fit)) => SourceFit::Baked(fit),
        (Some(performance), None) => {
            let c = if args.global {
                Coefficients::Global
            } else {
                Coefficients::Local
            };
            let config = args.options.config(c);
            eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
            sinew_host::training::interrupt::watch_ctrl_c();
            SourceFit::Fit {
                performance,
                config,
                backend: args.options.backend,
            }
        }
        (None, None) => anyhow::bail!("give --performance PERF_DIR or --fit FIT.sinew"),
    };
    let r = retarget_command(
        &args.source,
        &args.target,
        &input,
        &args.out,
        args.frames.as_deref(),
    )?;
    println!(
        "{}: {} frames of {} played on {}, {:.3} s per frame{}",
        args.out.display(),
        r.frames,
        args.source.display(),
        args.target.display(),
        r.seconds_per_frame,
        match (r.fit_seconds_per_frame, r.fit_mean_error_mm) {
            (Some(s), Some(e)) => format!(" (fit: {e:.3} mm, {s:.2} s per frame)"),
            _ => String::new(),
        }
    );
    if r.correspondence == "template" {
        println!("the actors' topologies differ: matched through the built-in face template");
    }
    if !r.shapes_at_rest.is_empty() {
        println!(
            "{} has no source shape of the name of {}: at rest",
            args.target.display(),
            r.shapes_at_rest.join(", ")
        );
    }
    Ok(())
}

/// `sinew eval fit`.
#[derive(Debug, Args)]
pub(crate) struct EvalFitArgs {
    /// The baked AIM actor.
    #[arg(long)]
    model: PathBuf,
    /// The performance folder (`sinew data performance`).
    #[arg(long)]
    target: PathBuf,
    /// Report JSON: frames, and mean_error_mm and seconds_per_frame of gbs, pbs, aim_global and
    /// aim_local.
    #[arg(long)]
    report: PathBuf,
    /// Also fit to 10 % of the vertices, to the 68 landmarks and to the 2D landmark tracks
    /// (aim_local_10pct, aim_local_landmarks, aim_local_2d; AIM Fig. 7).
    #[arg(long)]
    constraints: bool,
    /// Write heatmap_FFFFF.png into this folder for the first, middle and last frames: GBS, PBS,
    /// AIM (G) and AIM side by side, each vertex coloured by its error (0–1 mm).
    #[arg(long)]
    heatmaps: Option<PathBuf>,
    #[command(flatten)]
    options: FitOptions,
}

/// `sinew fit`.
pub(crate) fn fit(args: FitArgs) -> Result<()> {
    let c = if args.global {
        Coefficients::Global
    } else {
        Coefficients::Local
    };
    let config = FitConfig {
        mode: args.mode,
        constrain: args.constrain,
        ..args.options.config(c)
    };
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    // The driver runs only for a driver start (`fit_command` refuses a driver start without it).
    let driven = match &args.driver {
        Some(driver) if config.start == Start::Driver => {
            let (driver_hash, starts) = driven_starts(&args.model, driver, &args.target)?;
            Some(DrivenStarts {
                driver: driver.clone(),
                driver_hash,
                starts,
            })
        }
        Some(driver) => bail!(
            "{}: a driver is only read with --start driver",
            driver.display()
        ),
        None => None,
    };
    sinew_host::training::interrupt::watch_ctrl_c();
    let r = fit_command(
        &args.model,
        &args.target,
        &args.out,
        &args.report,
        &config,
        args.resume.as_deref(),
        driven,
        args.options.backend,
    )?;
    println!(
        "{}: {} frames, mean error {:.3} mm, reprojection {:.2} px, worst edge change {:.1} % \
         (the performance's own: {:.1} %), {:.2} s per frame",
        args.out.display(),
        r.frames,
        r.fit.mean_error_mm,
        r.fit.reprojection_px,
        100.0 * r.fit.worst_edge_change,
        100.0 * r.fit.target_worst_edge_change,
        r.fit.seconds_per_frame
    );
    Ok(())
}

/// `sinew eval fit`.
pub(crate) fn eval(args: EvalFitArgs) -> Result<()> {
    let config = args.options.config(Coefficients::Local);
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let r = eval_fit(
        &args.model,
        &args.target,
        &args.report,
        &config,
        args.constraints,
        args.heatmaps.as_deref(),
        args.options.backend,
    )?;
    println!(
        "{} frames; mean error (mm), seconds per frame, reprojection (px), worst edge change:",
        r.frames
    );
    for (name, m) in &r.methods {
        let px = m.reprojection_px.map_or("-".into(), |p| format!("{p:.2}"));
        let edge = m
            .worst_edge_change
            .map_or("-".into(), |e| format!("{:.1} %", 100.0 * e));
        println!(
            "  {name:<20} {:.3}  {:.3}  {px}  {edge}",
            m.mean_error_mm, m.seconds_per_frame
        );
    }
    println!(
        "  the performance's own worst edge change: {:.1} %",
        100.0 * r.target_worst_edge_change
    );
    Ok(())
}
