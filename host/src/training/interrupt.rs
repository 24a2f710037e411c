//! Ctrl-C during training, for AIM and S2D alike: one handler per process. The first Ctrl-C asks
//! the running training to stop after its current step (it saves a checkpoint and says how to
//! resume); a second one ends the process at once, so that Ctrl-C outside a training step
//! (evaluation, baking) is not swallowed.

use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

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
