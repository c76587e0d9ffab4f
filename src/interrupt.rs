//! Stopping long work on request. A program that embeds the library (the Python package,
//! on Ctrl-C) raises a process-wide flag with [`request`]; the long loops look at it at
//! coarse steps — the simulator before each batch of samples, every pass of an
//! identification between samples (`pipeline::Input::for_each_sample`) and between
//! methods — and end with [`Interrupted`] within a fraction of a second. The embedding
//! program [`clear`]s the flag once the interrupted call has returned.
//!
//! The flag is the process's, as a signal is: an interrupt stops every call running at the
//! time, on any thread.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// How many samples a long loop handles between two looks at the flag (a few
/// milliseconds of work); passes also update their progress counts at this cadence.
pub const LOOK_EVERY: usize = 1 << 14;

/// Ask every running call to stop.
pub fn request() {
    REQUESTED.store(true, Ordering::Relaxed);
}

/// Let calls run again (after the interrupted ones have returned).
pub fn clear() {
    REQUESTED.store(false, Ordering::Relaxed);
}

/// Whether a stop has been requested.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// The error of work stopped by [`request`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("interrupted on request")]
pub struct Interrupted;

/// `Err(Interrupted)` once a stop has been requested.
pub fn check() -> Result<(), Interrupted> {
    if requested() {
        Err(Interrupted)
    } else {
        Ok(())
    }
}
