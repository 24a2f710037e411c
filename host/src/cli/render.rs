//! `sinew render`: a performance's frames photographed through its camera.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

/// `sinew render`'s options.
#[derive(Debug, Args)]
pub(crate) struct RenderArgs {
    /// A performance folder (from `sinew data performance`).
    performance: PathBuf,
    /// Output folder: frame_00000.png, … and performance.y4m.
    #[arg(long)]
    out: PathBuf,
    /// Only the video, no PNG per frame.
    #[arg(long)]
    no_png: bool,
}

/// `sinew render`.
pub(crate) fn run(args: RenderArgs) -> Result<()> {
    let r =
        sinew_host::figures::photo::render_performance(&args.performance, &args.out, !args.no_png)?;
    println!(
        "{}: {} frames of {}×{} ({}{})",
        args.out.display(),
        r.frames,
        r.size[0],
        r.size[1],
        r.video.display(),
        if r.pictures.is_empty() {
            String::new()
        } else {
            format!(" and {} PNGs", r.pictures.len())
        }
    );
    Ok(())
}
