//! `sinew rig inspect`, and the rig options every command that reads a rig shares.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use sinew_host::io::units::Unit;
use sinew_host::rig::Axis;

#[derive(Debug, Subcommand)]
pub(crate) enum RigCommand {
    /// What Sinew understands of a rig: units, axes, vertex counts, shapes, the ARKit binding,
    /// the 68 landmarks (found by registering the built-in face template), the symmetry plane
    /// and the jaw hinge, as JSON; with --pictures, the neutral from the front and the side with
    /// the landmarks drawn (landmarks.png).
    Inspect {
        /// The rig: a .glb/.gltf file or a folder with neutral.obj and shapes/NAME.obj.
        rig: PathBuf,
        #[command(flatten)]
        read: super::args::RigReadArgs,
        /// The report (JSON).
        #[arg(long)]
        report: PathBuf,
        /// A folder for the pictures.
        #[arg(long)]
        pictures: Option<PathBuf>,
        /// The landmarks' true places (a JSON list of 68 [x, y, z] in the rig's own frame, as
        /// `sinew data rig` writes them): the report gains each landmark's error.
        #[arg(long)]
        truth: Option<PathBuf>,
    },
}

/// `sinew rig`.
pub(crate) fn run(cmd: RigCommand) -> Result<()> {
    match cmd {
        RigCommand::Inspect {
            rig,
            read,
            report,
            pictures,
            truth,
        } => {
            let opened = read.open(&rig)?;
            let truth = match truth {
                Some(path) => {
                    let text = std::fs::read_to_string(&path)
                        .with_context(|| format!("{}: cannot read", path.display()))?;
                    let list: Vec<[f64; 3]> = serde_json::from_str(&text).with_context(|| {
                        format!("{}: not a JSON list of [x, y, z] positions", path.display())
                    })?;
                    if list.len() != 68 {
                        bail!("{}: {} positions, 68 needed", path.display(), list.len());
                    }
                    Some(list)
                }
                None => None,
            };
            let r = sinew_host::rig::inspect::inspect(
                &opened,
                truth.as_deref(),
                &report,
                pictures.as_deref(),
            )?;
            println!(
                "{}: {} vertices ({} welded), {} shapes, {} of ARKit's 52 bound, units {}; report \
                 in {}",
                rig.display(),
                r.vertex_count,
                r.welded_vertex_count,
                r.shapes.len(),
                r.arkit.bound.len(),
                r.units,
                report.display()
            );
            if let Some(e) = &r.landmark_error_mm {
                println!(
                    "landmark error: mean {:.2} mm, median {:.2} mm, max {:.2} mm",
                    e.mean, e.median, e.max
                );
            }
        }
    }
    Ok(())
}

/// `sinew data rig`: a sample rig from ICT-FaceKit, as a `.glb` (OUT ends in .glb) or an OBJ
/// folder, with its landmarks' true places beside it.
#[derive(Debug, Args)]
pub(crate) struct SampleRigArgs {
    /// ICT-FaceKit folder.
    #[arg(long)]
    data: PathBuf,
    /// The rig: a .glb file, or a folder for neutral.obj and shapes/.
    #[arg(long)]
    out: PathBuf,
    /// Vertices of the re-meshed face (the kit's face region has 9,409).
    #[arg(long, default_value_t = 6000)]
    vertices: usize,
    #[command(flatten)]
    identity: super::args::IdentityArg,
    /// glTF: place the head in a scene (turned 30 degrees, standing 1.6 m up, off the origin)
    /// by its node transform.
    #[arg(long)]
    scene: bool,
    /// OBJ folder: the unit to write in.
    #[arg(long, default_value = "cm")]
    units: Unit,
    /// OBJ folder: the up axis to write with.
    #[arg(long, default_value = "+y", allow_hyphen_values = true)]
    up: Axis,
    /// OBJ folder: the forward axis to write with.
    #[arg(long, default_value = "+z", allow_hyphen_values = true)]
    forward: Axis,
}

pub(crate) fn sample_rig(args: SampleRigArgs) -> Result<()> {
    use sinew_host::rig::sample::{Placement, from_kit};
    let glb = args
        .out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let placement = if glb && args.scene {
        Placement::scene(30.0, [0.25, 1.6, -0.4])
    } else if glb {
        Placement {
            units: Unit::Metre,
            seam: true,
            ..Placement::kit()
        }
    } else {
        Placement {
            units: args.units,
            up: args.up,
            forward: args.forward,
            seam: true,
            ..Placement::kit()
        }
    };
    let sample = from_kit(
        &args.data,
        &args.identity.weights,
        args.vertices,
        &placement,
    )?;
    let truth = if glb {
        sample.file.write_glb(&args.out)?;
        args.out.with_extension("landmarks.json")
    } else {
        sample.file.write_obj_folder(&args.out)?;
        args.out.join("landmarks.json")
    };
    sinew_host::io::atomic::write(&truth, &serde_json::to_vec_pretty(&sample.landmarks)?)?;
    println!(
        "{}: {} vertices, {} shapes; true landmarks in {}",
        args.out.display(),
        sample.file.vertex_count(),
        sample.file.shape_names.len(),
        truth.display()
    );
    Ok(())
}
