//! Ctrl-C during training, for every training: one handler per process. The first Ctrl-C asks
//! the running training to stop after its current step (it saves a checkpoint and says how to
//! resume); a second one ends the process at once, so that Ctrl-C outside a training step
//! (evaluation, baking) is not swallowed.

use std::path::{Path, PathBuf};
use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

use indicatif::ProgressBar;

use super::checkpoint::CheckpointError;

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the handler (once per process; later calls do nothing). If another handler was
/// registered first, it keeps Ctrl-C and training just runs on.
pub fn watch_ctrl_c() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            if INTERRUPTED.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    });
}

/// Asks the running training to stop after its current step, as Ctrl-C does. A request made
/// while no training runs stops the next one after its first step.
pub fn request_stop() {
    INTERRUPTED.store(true, Ordering::SeqCst);
}

/// Whether a stop was asked for since the last call; clears the request.
pub fn take_stop_request() -> bool {
    INTERRUPTED.swap(false, Ordering::SeqCst)
}

/// How [`train_in_pieces`] runs: to `steps` steps, a checkpoint in `dir` every `every` steps.
#[derive(Clone, Copy, Debug)]
pub struct Pieces<'a> {
    /// Steps the run ends at.
    pub steps: usize,
    /// Steps between checkpoints.
    pub every: usize,
    /// No progress bar.
    pub quiet: bool,
    /// The checkpoint folder (named in the error of an interrupted run).
    pub dir: &'a Path,
}

/// Why [`train_in_pieces`] stopped before the end.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PiecesError {
    /// A checkpoint could not be written.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// A stop was asked for (Ctrl-C); the checkpoint after the last step is written.
    #[error(
        "interrupted after {steps} steps; checkpoint in {}: continue with --resume {}",
        dir.display(),
        dir.display()
    )]
    Interrupted {
        /// Steps done.
        steps: usize,
        /// The checkpoint folder.
        dir: PathBuf,
    },
}

/// Runs a step-counted training from the steps `done(&run)` to `pieces.steps`, `pieces.every`
/// steps at a time, with a progress bar: `advance(run, until, bar, stop)` runs steps until
/// `until` or until `stop()` says so after a step, then `save` writes the checkpoint. Once
/// `stop_requested` (in the CLI, [`take_stop_request`], Ctrl-C's) has said yes the loop ends
/// after that checkpoint with [`PiecesError::Interrupted`], which says how to resume.
///
/// # Errors
/// The checkpoint's, or [`PiecesError::Interrupted`].
pub fn train_in_pieces<R>(
    mut run: R,
    pieces: &Pieces<'_>,
    done: impl Fn(&R) -> usize,
    mut stop_requested: impl FnMut() -> bool,
    mut advance: impl FnMut(R, usize, &ProgressBar, &mut dyn FnMut() -> bool) -> R,
    mut save: impl FnMut(&R) -> Result<(), CheckpointError>,
) -> Result<R, PiecesError> {
    watch_ctrl_c();
    let bar = super::progress::bar(pieces.steps as u64, pieces.quiet);
    bar.set_position(done(&run) as u64);
    let mut stopped = false;
    while done(&run) < pieces.steps {
        let until = done(&run)
            .saturating_add(pieces.every.max(1))
            .min(pieces.steps);
        run = advance(run, until, &bar, &mut || {
            stopped = stop_requested();
            stopped
        });
        save(&run)?;
        if stopped {
            bar.abandon();
            return Err(PiecesError::Interrupted {
                steps: done(&run),
                dir: pieces.dir.to_owned(),
            });
        }
    }
    bar.finish();
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run of `n` steps done, advanced one step at a time.
    fn advance(n: usize, until: usize, _: &ProgressBar, stop: &mut dyn FnMut() -> bool) -> usize {
        let mut n = n;
        while n < until {
            n += 1;
            if stop() {
                break;
            }
        }
        n
    }

    #[test]
    fn a_run_is_saved_after_every_piece_and_after_the_step_a_stop_was_asked_at() {
        let dir = Path::new("run.ckpt");
        let pieces = Pieces {
            steps: 10,
            every: 4,
            quiet: true,
            dir,
        };
        let mut saved = Vec::new();
        let run = train_in_pieces(
            2,
            &pieces,
            |&n| n,
            || false,
            advance,
            |&n| {
                saved.push(n);
                Ok(())
            },
        );
        assert_eq!(run.unwrap(), 10);
        assert_eq!(saved, [6, 10]);

        // A stop asked for during the 5th step: saved there, and the error says how to resume.
        let mut saved = Vec::new();
        let mut calls = 0;
        let stop = || {
            calls += 1;
            calls == 5
        };
        let err = train_in_pieces(
            0,
            &pieces,
            |&n| n,
            stop,
            advance,
            |&n| {
                saved.push(n);
                Ok(())
            },
        )
        .unwrap_err();
        assert_eq!(saved, [4, 5]);
        assert!(matches!(&err, PiecesError::Interrupted { steps: 5, dir: d } if d == dir));
        assert!(err.to_string().contains("--resume run.ckpt"), "{err}");

        // A finished run runs no step and writes nothing.
        let mut saved = Vec::new();
        let run = train_in_pieces(
            10,
            &pieces,
            |&n| n,
            || true,
            advance,
            |&n| {
                saved.push(n);
                Ok(())
            },
        );
        assert_eq!(run.unwrap(), 10);
        assert!(saved.is_empty());
    }
}
