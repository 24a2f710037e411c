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
    /// The video's frame rate (default: the performance's). A slower video suits a tracker slower
    /// than real time that reads it as a camera.
    #[arg(long)]
    fps: Option<f32>,
    /// Draw each frame's number in its top-left corner: 16 cells of 8×8 pixels, bit k of the
    /// number (least significant first) white for 1, black for 0 (docs/FIT.md, "Rendering a
    /// performance").
    #[arg(long)]
    stamp: bool,
}

/// `sinew render`.
pub(crate) fn run(args: RenderArgs) -> Result<()> {
    let options = sinew_host::figures::photo::RenderOptions {
        pngs: !args.no_png,
        fps: args.fps,
        stamp: args.stamp,
    };
    let r = sinew_host::figures::photo::render_performance(&args.performance, &args.out, options)?;
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
