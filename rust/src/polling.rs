//! Ctrl-C for long calls: the work runs as one job on the pool while the
//! calling thread polls the caller's `stop` (the Python layer's signal check,
//! which only that thread may make) and raises a flag the job reads.

use rayon::ThreadPool;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

/// How often `stop` is polled: the polling thread is not one of the pool's,
/// so polling costs the work nothing but that thread's brief wake.
pub(crate) const STOP_POLL: Duration = Duration::from_millis(10);

/// Runs `job` on one of `pool`'s threads, polling `stop` every [`STOP_POLL`]
/// meanwhile and setting `cancel` at its first `true`; the job is expected to
/// read `cancel` and return early. `None` if the job panicked (the scope
/// re-raises the panic on return). Called from inside `pool`, where waiting
/// for a job of the same pool could wait forever, it runs `job` here instead
/// and polls `stop` once afterwards.
pub(crate) fn run_polling<R: Send>(
    pool: &ThreadPool,
    cancel: &AtomicBool,
    stop: &mut dyn FnMut() -> bool,
    job: impl FnOnce() -> R + Send,
) -> Option<R> {
    if pool.current_thread_index().is_some() {
        let result = job();
        if stop() {
            cancel.store(true, Ordering::Relaxed);
        }
        return Some(result);
    }
    let (sender, results) = mpsc::channel();
    pool.in_place_scope(|scope| {
        scope.spawn(move |_| {
            // A send fails only if this thread stopped waiting, which it does not.
            let _ = sender.send(job());
        });
        loop {
            match results.recv_timeout(STOP_POLL) {
                Ok(result) => return Some(result),
                Err(RecvTimeoutError::Timeout) => {
                    if !cancel.load(Ordering::Relaxed) && stop() {
                        cancel.store(true, Ordering::Relaxed);
                    }
                }
                Err(RecvTimeoutError::Disconnected) => return None,
            }
        }
    })
}
