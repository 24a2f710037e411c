//! `sinew bones fit`: the arguments, and the hand-over to [`sinew_host::anatomy::fit`].

use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};

/// Where the template bones are (a folder holding `artisynth-jaw/` and `skull-odedstein/`): the
/// real-data folder.
#[derive(Debug, Args)]
pub(crate) struct TemplatesArg {
    /// Folder with the template bones (artisynth-jaw/, skull-odedstein/).
    #[arg(
        long = "templates",
        env = "SINEW_DATA",
        default_value = "../shared/data"
    )]
    pub(crate) path: PathBuf,
}

/// Which ICT-FaceKit identity an actor is: the generic neutral plus these multiples of the
/// kit's identity modes.
#[derive(Debug, Args)]
pub(crate) struct IdentityArg {
    /// Identity weights in standard deviations of the kit's first identity modes, comma
    /// separated (e.g. `1.5,-1,0.8`); none: the generic neutral.
    #[arg(
        long = "identity",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub(crate) weights: Vec<f32>,
}

#[derive(Debug, Subcommand)]
pub(crate) enum Bones {
    /// Register the template skull and jaw to an ICT-FaceKit neutral or a rig's (similarity from landmarks
    /// offset by soft-tissue thickness, then ICP); writes skull.obj, jaw.obj, fit.json, bones.png.
    Fit {
        /// ICT-FaceKit folder.
        #[arg(long, required_unless_present = "rig", conflicts_with = "rig")]
        data: Option<PathBuf>,
        /// A blendshape rig instead of the kit (.glb/.gltf, or an OBJ folder): the bones are
        /// placed by its landmarks and written in Sinew's face frame.
        #[arg(long)]
        rig: Option<PathBuf>,
        #[command(flatten)]
        rig_read: super::rig::RigReadArgs,
        #[command(flatten)]
        templates: TemplatesArg,
        #[command(flatten)]
        identity: IdentityArg,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
}

/// `sinew bones`.
pub(crate) fn run(cmd: Bones) -> Result<()> {
    match cmd {
        Bones::Fit {
            data,
            rig,
            rig_read,
            templates,
            identity,
            out,
        } => {
            let report = match (&rig, &data) {
                (Some(path), _) => sinew_host::aim::commands::bones_fit_rig(
                    &rig_read.open(path)?,
                    &templates.path,
                    &out,
                )?,
                (None, Some(data)) => {
                    let templates = sinew_host::anatomy::fit::bone_templates(&templates.path)?;
                    sinew_host::anatomy::fit::bones_fit(data, &identity.weights, &templates, &out)?
                }
                (None, None) => anyhow::bail!("give --data or --rig"),
            };
            println!("{}", serde_json::to_string_pretty(&report)?);
            eprintln!("bones written to {}", out.display());
        }
    }
    Ok(())
}
