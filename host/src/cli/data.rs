//! `sinew data …`: the data sets and built-in files the commands start from (S2D pairs,
//! synthetic performances, an identity's neutral, the demo face, the face template, a sample rig,
//! labelled motions): the arguments, and the hand-over to the module that makes each.

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use sinew_host::performance::{PerformanceConfig, generate};
use sinew_host::s2d::data::{Expressions, PairsConfig};

#[derive(Debug, Subcommand)]
pub(crate) enum Data {
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
        /// Seed.
        #[arg(long, env = "SINEW_SEED", default_value_t = PairsConfig::default().seed)]
        seed: u64,
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
    /// A synthetic facial performance on an ICT-FaceKit actor for fitting: smooth seeded
    /// trajectories of all 53 expression weights, the jaw and the head; one OBJ per frame,
    /// performance.json with the ground truth, the camera and 68 projected landmarks.
    Performance(PerformanceArgs),
    /// The ICT-FaceKit face region of an identity as OBJ, optionally on a baked actor's vertices
    /// and triangles: the template to bake another identity's actor on in correspondence with it
    /// (for `sinew retarget`).
    Neutral(NeutralArgs),
    /// The face `sinew demo` trains on: the ICT-FaceKit face region decimated to about 1,500
    /// vertices with its 20 default shapes and the bone constraints AIM trains on, as compact
    /// gzipped JSON (the repository's copy is host/data/demo-face.json.gz).
    DemoFace {
        /// ICT-FaceKit folder.
        #[arg(long)]
        data: PathBuf,
        #[command(flatten)]
        templates: super::args::TemplatesArg,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
    },
    /// The face template that finds a rig's landmarks (`sinew rig inspect`): the ICT-FaceKit
    /// face region decimated to 2,500 vertices with its 68 landmarks and the fitted jaw hinge,
    /// as gzipped JSON (the repository's copy is host/data/face-template.json.gz).
    FaceTemplate {
        /// ICT-FaceKit folder.
        #[arg(long)]
        data: PathBuf,
        #[command(flatten)]
        templates: super::args::TemplatesArg,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
    },
    /// A sample blendshape rig from ICT-FaceKit to try `--rig` with: the face region re-meshed,
    /// with all 53 expression shapes, a UV seam, as .glb (metres) or an OBJ folder, and its
    /// landmarks' true places beside it.
    Rig(super::rig::SampleRigArgs),
    /// Synthetic labelled landmark motions for Motion3DGAN: CoMA's 12 expression classes played
    /// from neutral to apex on ICT-FaceKit identities (identity-specific deltas), with random
    /// intensity, timing, easing and noise; the first sequence of each identity and class is the
    /// test set.
    Motions(super::motion::MotionsArgs),
}

/// `sinew data`.
pub(crate) fn run(cmd: Data) -> Result<()> {
    match cmd {
        Data::S2dPairs {
            data,
            out,
            seed,
            identities,
            pairs,
            max_shapes,
            decimate,
            expressions,
        } => {
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
        Data::Performance(args) => performance(args)?,
        Data::Neutral(args) => neutral(args)?,
        Data::DemoFace {
            data,
            templates,
            out,
        } => {
            let set = sinew_host::aim::demo_face::write(&data, &templates.path, &out)?;
            println!(
                "{}: {} vertices, {} shapes, {:.0} % of the vertices constrained",
                out.display(),
                set.vertices(),
                set.shapes.len(),
                100.0 * set.constrained_fraction()
            );
        }
        Data::FaceTemplate {
            data,
            templates,
            out,
        } => {
            let t = sinew_host::aim::face_template::write(&data, &templates.path, &out)?;
            println!(
                "{}: {} vertices, {} triangles, 68 landmarks",
                out.display(),
                t.positions.len(),
                t.triangles.len()
            );
        }
        Data::Rig(args) => super::rig::sample_rig(args)?,
        Data::Motions(args) => super::motion::motions(args)?,
    }
    Ok(())
}

/// `sinew data performance`.
#[derive(Debug, Args)]
pub(crate) struct PerformanceArgs {
    /// ICT-FaceKit folder.
    #[arg(long)]
    data: PathBuf,
    /// Output folder (one OBJ per frame and performance.json).
    #[arg(long)]
    out: PathBuf,
    /// Seed of the trajectories and the noise.
    #[arg(long, env = "SINEW_SEED", default_value_t = PerformanceConfig::default().seed)]
    seed: u64,
    /// Number of frames (30 per second).
    #[arg(long, default_value_t = PerformanceConfig::default().frames)]
    frames: usize,
    /// Gaussian noise on every coordinate, standard deviation in mm.
    #[arg(long, default_value_t = 0.0)]
    noise_mm: f32,
    /// Gaussian noise on every landmark pixel coordinate of the 2D tracks (a landmark
    /// detector's error), standard deviation in pixels.
    #[arg(long, default_value_t = 0.0)]
    landmark_noise_px: f32,
    /// A baked AIM actor made on the kit: the meshes take its topology (every template vertex
    /// must be a vertex of the kit's face region), and the jaw moves rigidly about its pivot with
    /// its skinning weights. Without it: the full face region, the jaw through the kit's jaw
    /// shapes only.
    #[arg(long)]
    actor: Option<PathBuf>,
    /// Frames at rest, looking at the camera, before the performance eases in over half a second
    /// (what `sinew drive --calibrate-frames` takes as the face at rest).
    #[arg(long, default_value_t = 0)]
    rest_frames: usize,
    /// A tracker's convention on the 2D track, drawn from this seed: smooth offsets of the 68
    /// landmarks from the landmark vertices (largest on the contour, lips and brows). The meshes
    /// stay the truth.
    #[arg(long)]
    convention: Option<u64>,
    /// The convention's amplitude on the contour, mm (the brows and lips three quarters of it,
    /// the nose and eyes a tenth).
    #[arg(long, default_value_t = PerformanceConfig::default().convention_mm)]
    convention_mm: f32,
    /// Tracker failures on the 2D track after the frames at rest, in turn: a face read smaller
    /// for 4–10 frames, one found elsewhere for 1–3, one frame scattered, no face for 1–5
    /// (`success` 0); listed in performance.json's `failures`.
    #[arg(long, default_value_t = 0)]
    failures: usize,
}

/// `sinew data performance`.
pub(crate) fn performance(args: PerformanceArgs) -> Result<()> {
    let config = PerformanceConfig {
        seed: args.seed,
        frames: args.frames,
        noise_mm: args.noise_mm,
        landmark_noise_px: args.landmark_noise_px,
        rest_frames: args.rest_frames,
        convention: args.convention,
        convention_mm: args.convention_mm,
        failures: args.failures,
        ..PerformanceConfig::default()
    };
    config.validate()?;
    eprintln!("seed {} (override with --seed or SINEW_SEED)", config.seed);
    let m = generate(&args.data, args.actor.as_deref(), &config, &args.out)?;
    println!(
        "{}: synthetic performance, {} frames of {} vertices over {} expression shapes, 68 \
         landmarks in a {}×{} image",
        args.out.display(),
        m.frames,
        m.vertices,
        m.expressions.len(),
        m.camera.width,
        m.camera.height
    );
    Ok(())
}

/// `sinew data neutral`.
#[derive(Debug, Args)]
pub(crate) struct NeutralArgs {
    /// ICT-FaceKit folder.
    #[arg(long)]
    data: PathBuf,
    #[command(flatten)]
    identity: super::args::IdentityArg,
    /// A baked AIM actor made on the kit's generic neutral (e.g. tests/data/aim-ict.sinew): the
    /// face takes its vertices and triangles. Without it: the whole face region.
    #[arg(long)]
    like: Option<PathBuf>,
    /// Output OBJ.
    #[arg(long)]
    out: PathBuf,
}

/// `sinew data neutral`.
pub(crate) fn neutral(args: NeutralArgs) -> Result<()> {
    let mesh = sinew_host::performance::write_neutral(
        &args.data,
        &args.identity.weights,
        args.like.as_deref(),
        &args.out,
    )?;
    println!(
        "{}: {} vertices, {} polygons",
        args.out.display(),
        mesh.positions.len(),
        mesh.polygons.len()
    );
    Ok(())
}
