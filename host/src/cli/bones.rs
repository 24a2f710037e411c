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
    /// Register the template skull and jaw to an ICT-FaceKit neutral (similarity from landmarks
    /// offset by soft-tissue thickness, then ICP); writes skull.obj, jaw.obj, fit.json, bones.png.
    Fit {
        /// ICT-FaceKit folder.
        #[arg(long)]
        data: PathBuf,
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
            templates,
            identity,
            out,
        } => {
            let templates = sinew_host::anatomy::fit::bone_templates(&templates.path)?;
            let report =
                sinew_host::anatomy::fit::bones_fit(&data, &identity.weights, &templates, &out)?;
            println!("{}", serde_json::to_string_pretty(&report)?);
            eprintln!("bones written to {}", out.display());
        }
    }
    Ok(())
}
