//! The worker pool the CPU sums of a step or window run on (the soft-sphere contact
//! forces, the grains' porosity): rayon's threads, which wait between calls instead of
//! being spawned per call (one `std::thread::scope` spawn cost 26–36 µs on this
//! repository's two-core VM, 2026-12-01, so 16 of them 0.4–0.5 ms, where handing work to
//! the pool costs about 12 µs whatever the count).
//!
//! A process runs its loop *inside* the pool ([`in_worker_pool`]), so that the thread
//! that calls a parallel sum is one of the pool's and takes a share of it: called from
//! outside, it would wait blocked while the pool's threads worked, and after each sum
//! those threads spin a while before they sleep, beside the caller's serial work — on two
//! cores the DEM's forces then ran 5–10 % slower than with threads spawned per step.
//! The pool has the machine's threads (`std::thread::available_parallelism`), or
//! `RAYON_NUM_THREADS` when that is set.

use std::sync::OnceLock;

static POOL: OnceLock<Result<rayon::ThreadPool, String>> = OnceLock::new();

/// A pool thread's stack: a server's whole loop runs on one, where it ran on the main
/// thread before, whose stack Linux sizes at 8 MiB by default (`ulimit -s`); a spawned
/// thread gets 2 MiB unless told otherwise.
const WORKER_STACK_BYTES: usize = 8 << 20;

/// Runs `f` on a thread of the process's worker pool and returns its result; the
/// parallel sums `f` makes then run on that pool with the calling thread taking part.
/// Where the pool cannot be built (the system refuses threads), `f` runs here and the
/// sums on rayon's global pool, which is what they would do without this.
pub fn in_worker_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    let pool = POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .thread_name(|i| format!("couplet-worker-{i}"))
            .stack_size(WORKER_STACK_BYTES)
            .build()
            .map_err(|e| e.to_string())
    });
    match pool {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    /// `f` runs on a thread of the pool (the caller takes part in its sums) and returns
    /// its value; a parallel sum inside gives the serial sum's value. Reference: the pool
    /// has `rayon::current_num_threads()` threads as seen from inside, at least one, and
    /// the sum of 0..100 000 is 4 999 950 000.
    #[test]
    fn runs_on_a_pool_thread_and_returns_its_value() {
        assert_eq!(
            rayon::current_thread_index(),
            None,
            "the test thread is no worker"
        );
        let (index, threads, sum) = in_worker_pool(|| {
            (
                rayon::current_thread_index(),
                rayon::current_num_threads(),
                (0..100_000u64).into_par_iter().sum::<u64>(),
            )
        });
        assert!(index.is_some(), "f ran outside the pool");
        assert!(threads >= 1);
        assert_eq!(sum, 4_999_950_000);
        // A second call uses the same pool (built once).
        assert_eq!(in_worker_pool(rayon::current_num_threads), threads);
    }
}
