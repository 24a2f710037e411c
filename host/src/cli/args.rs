//! The argument groups several commands share: where the template bones are, which ICT-FaceKit
//! identity an actor is, and how to read a studio's rig.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use sinew_host::io::units::Unit;
use sinew_host::rig::{Axis, Rig, RigOptions};

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

/// How to read a rig (glTF or OBJ folder).
#[derive(Debug, Args)]
pub(crate) struct RigReadArgs {
    /// glTF only: the skin mesh's name (default: the mesh with the most morph targets).
    #[arg(long)]
    pub(crate) mesh: Option<String>,
    /// The rig's length unit, mm, cm or m (glTF: metres by the spec; OBJ: guessed from the
    /// head's size, and the guess printed).
    #[arg(long)]
    pub(crate) units: Option<Unit>,
    /// The rig's up axis (+x, -x, +y, -y, +z, -z).
    #[arg(long, default_value = "+y", allow_hyphen_values = true)]
    pub(crate) up: Axis,
    /// The axis the face looks along (default: +z; -z for a VRM 0.x avatar, which faces -z by
    /// its specification).
    #[arg(long, allow_hyphen_values = true)]
    pub(crate) forward: Option<Axis>,
    /// The 68 iBUG landmarks as a JSON list of vertex indices or [x, y, z] positions in the
    /// rig's own frame (default: found by registering the built-in face template).
    #[arg(long)]
    pub(crate) landmarks: Option<PathBuf>,
}

impl RigReadArgs {
    /// Opens the rig and says how its unit was chosen when it was guessed.
    pub(crate) fn open(&self, path: &std::path::Path) -> Result<Rig> {
        let rig = Rig::open(
            path,
            &RigOptions {
                mesh: self.mesh.clone(),
                units: self.units,
                up: self.up,
                forward: self.forward,
                landmarks: self.landmarks.clone(),
            },
        )?;
        if rig.conventions.units_guessed {
            eprintln!(
                "{}: units guessed from the head's size: {} (pass --units to set them)",
                path.display(),
                rig.conventions.units
            );
        }
        Ok(rig)
    }
}
