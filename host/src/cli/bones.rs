//! `sinew bones fit`: the arguments, and the hand-over to [`sinew_host::anatomy::fit`].

use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;

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
        rig_read: super::args::RigReadArgs,
        #[command(flatten)]
        templates: super::args::TemplatesArg,
        #[command(flatten)]
        identity: super::args::IdentityArg,
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
