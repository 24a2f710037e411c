//! `sinew export gltf`: the arguments, and the hand-over to [`sinew_host::export`].

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand, ValueEnum};
use sinew_host::export::gltf::{Frames, Names, Options};

#[derive(Debug, Subcommand)]
pub(crate) enum Export {
    /// A baked actor as a glTF 2.0 binary (.glb): the skin with normals, the correctives as
    /// named morph targets, a head and jaw skin, and with --poses, --arkit or --performance an
    /// animation.
    Gltf(GltfArgs),
}

/// `sinew export gltf`.
#[derive(Debug, Args)]
pub(crate) struct GltfArgs {
    /// The baked actor.
    #[arg(long)]
    model: PathBuf,
    /// Output .glb file.
    #[arg(long)]
    out: PathBuf,
    /// Pose file to animate (as for `sinew play`).
    #[arg(long, conflicts_with_all = ["arkit", "performance"])]
    poses: Option<PathBuf>,
    /// Live Link Face capture (CSV) to animate, mapped as for `sinew play --arkit`.
    #[arg(long, conflicts_with = "performance")]
    arkit: Option<PathBuf>,
    /// A global fit of this actor (`sinew fit --global --out FIT.sinew`) to animate.
    #[arg(long)]
    performance: Option<PathBuf>,
    /// Frames per second of the animation.
    #[arg(long, default_value_t = 30.0)]
    fps: f32,
    /// Add the anatomy surface (the learned bone points) as a second mesh.
    #[arg(long)]
    bones: bool,
    /// Morph target names: the actor's shape names, or ARKit's spelling (`mouthSmile_L` as
    /// `mouthSmileLeft`, plus one target under ARKit's name for a shape ARKit does not split by
    /// side, such as `browInnerUp`), for engines that bind ARKit's blendshapes by name.
    #[arg(long, value_enum, default_value_t = NameStyle::Actor)]
    names: NameStyle,
    /// The glTF or VRM rig the actor was learned from: its other meshes (eyes, teeth),
    /// materials and textures are carried into the export, so that it replaces the character in
    /// a scene; the report lists what is not carried.
    #[arg(long)]
    rig: Option<PathBuf>,
    /// Compress the geometry and animation with EXT_meshopt_compression for web delivery
    /// (lossless; required, without an uncompressed fallback: three.js and Babylon.js decode
    /// it, Blender does not).
    #[arg(long)]
    compress: bool,
    /// Make the animation loop: key the first frame again one frame after the last, so that a
    /// repeating engine never jumps (the clip lasts frames / fps).
    #[arg(long = "loop")]
    looped: bool,
}

/// `--names`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub(crate) enum NameStyle {
    /// The actor's own shape names.
    Actor,
    /// ARKit's blendshape names.
    Arkit,
}

/// Runs `sinew export …`.
pub(crate) fn run(cmd: Export) -> Result<()> {
    match cmd {
        Export::Gltf(args) => {
            let frames = match (&args.poses, &args.arkit, &args.performance) {
                (Some(p), _, _) => Frames::Poses(p),
                (None, Some(c), _) => Frames::Arkit(c),
                (None, None, Some(f)) => Frames::Performance(f),
                (None, None, None) => Frames::None,
            };
            if args.looped && matches!(frames, Frames::None) {
                anyhow::bail!("--loop needs an animation: give --poses, --arkit or --performance");
            }
            let options = Options {
                fps: args.fps,
                bones: args.bones,
                names: match args.names {
                    NameStyle::Actor => Names::Actor,
                    NameStyle::Arkit => Names::Arkit,
                },
                looped: args.looped,
                compress: args.compress,
            };
            let summary = sinew_host::export::gltf::export(
                &args.model,
                &args.out,
                frames,
                &options,
                args.rig.as_deref(),
            )?;
            if !summary.unplayable.is_empty() {
                eprintln!(
                    "the actor cannot play these capture channels: {}",
                    summary.unplayable.join(", ")
                );
            }
            println!("{}", serde_json::to_string_pretty(&summary)?);
            eprintln!("{} written", args.out.display());
            Ok(())
        }
    }
}
