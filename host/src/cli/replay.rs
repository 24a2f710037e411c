//! `sinew replay record|verify`: the arguments, and the hand-over to [`sinew_host::replay`].

use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;

#[derive(Debug, Subcommand)]
pub(crate) enum Replay {
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

/// `sinew replay`.
pub(crate) fn run(cmd: Replay) -> Result<()> {
    match cmd {
        Replay::Record {
            model,
            poses,
            out,
            mode,
        } => {
            let n = sinew_host::replay::replay_record(&model, &poses, &out, mode)?;
            println!("{n} frames ({mode}) recorded to {}", out.display());
        }
        Replay::Verify { model, replay } => {
            let v = sinew_host::replay::replay_verify(&model, &replay)?;
            for f in &v.frames {
                println!("{f}");
            }
            if v.mode != sinew_core::replay::Mode::F32 {
                let d = sinew_host::replay::replay_deviation(&model, &replay)?;
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
    }
    Ok(())
}
