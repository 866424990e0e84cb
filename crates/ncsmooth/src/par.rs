//! Data parallelism for independent per-item work, and the one setting of how many
//! threads ncsmooth uses ([`set_threads`]).
//!
//! [`map`] cuts `n` items into contiguous chunks that the threads take in turn (std scoped
//! threads), the results concatenated in order. Each item is computed alone, so the result
//! never depends on the number of threads; below a caller's threshold, or with one thread,
//! it is a plain loop. [`join`] runs two independent pieces of work side by side. The
//! planner computes its grid on a second thread when there are two
//! (`feed::lookahead::plan_stream`), with the same result. The setpoint pipeline
//! (`interp::execute_streamed`: reading, planning, interpolating and writing as stages)
//! runs its stages on threads of their own whatever the setting: they hand data along
//! bounded queues, so they are concurrent by construction, not for speed.

use std::sync::atomic::{AtomicUsize, Ordering};

/// Most threads [`map`] uses by default; [`set_threads`] may ask for more.
pub const MAX_THREADS: usize = 4;

/// The setting of [`set_threads`]; 0 for the default.
static THREADS: AtomicUsize = AtomicUsize::new(0);

/// Sets the most threads ncsmooth's parallel work uses, for the whole process: 1 runs it
/// all on the calling thread (the pipeline's stages aside, see the module doc); 0
/// restores the default, the machine's cores up to `MAX_THREADS` (4). Results never depend
/// on it.
pub fn set_threads(n: usize) {
    THREADS.store(n, Ordering::Relaxed);
}

/// The threads ncsmooth's parallel work may use (see [`set_threads`]), at least 1.
pub fn threads() -> usize {
    match THREADS.load(Ordering::Relaxed) {
        0 => std::thread::available_parallelism()
            .map_or(1, |c| c.get())
            .min(MAX_THREADS),
        n => n,
    }
}

/// Chunks per thread [`map`] cuts its items into: the threads take the next chunk as they
/// finish one, so items of uneven cost (a run of thousands of points beside runs of ten)
/// still keep every thread busy to the end.
pub(crate) const CHUNKS_PER_THREAD: usize = 16;

/// `(0..n).map(f).collect()`, on up to [`threads`] threads when `n >= min_items`.
pub fn map<T, F>(n: usize, min_items: usize, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> T + Sync,
{
    let threads = threads();
    if threads < 2 || n < min_items.max(2) {
        return (0..n).map(f).collect();
    }
    let chunk = n.div_ceil(threads * CHUNKS_PER_THREAD);
    let chunks = n.div_ceil(chunk);
    let next = AtomicUsize::new(0);
    let (f, next) = (&f, &next);
    let work = move || {
        let mut done: Vec<(usize, Vec<T>)> = Vec::new();
        loop {
            let k = next.fetch_add(1, Ordering::Relaxed);
            if k >= chunks {
                return done;
            }
            let lo = k * chunk;
            done.push((k, (lo..(lo + chunk).min(n)).map(f).collect()));
        }
    };
    let mut parts: Vec<(usize, Vec<T>)> = std::thread::scope(|scope| {
        let spawned: Vec<_> = (1..threads).map(|_| scope.spawn(work)).collect();
        let mut parts = work();
        for h in spawned {
            parts.extend(h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
        }
        parts
    });
    parts.sort_unstable_by_key(|p| p.0);
    let mut out = Vec::with_capacity(n);
    for (_, p) in parts {
        out.extend(p);
    }
    out
}

/// `(a(), b())`: `a` on a second thread while the calling thread runs `b` when
/// [`threads`] allows two, else one after the other; for two independent pieces of work
/// (an index built while a program is written, a check beside another).
pub fn join<A, B>(a: impl FnOnce() -> A + Send, b: impl FnOnce() -> B) -> (A, B)
where
    A: Send,
{
    if threads() < 2 {
        let ra = a();
        return (ra, b());
    }
    std::thread::scope(|scope| {
        let spawned = scope.spawn(a);
        let rb = b();
        let ra = spawned
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        (ra, rb)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_as_a_loop_in_order() {
        for n in [0, 1, 2, 3, 7, 1000, 4099] {
            let want: Vec<usize> = (0..n).map(|i| i * i + 1).collect();
            assert_eq!(map(n, 1, |i| i * i + 1), want, "n = {n}");
            assert_eq!(map(n, usize::MAX, |i| i * i + 1), want, "n = {n}");
        }
        // The setting changes the threads, never the result (other tests may run while
        // it is set: they see the same results).
        set_threads(3);
        assert_eq!(threads(), 3);
        assert_eq!(
            map(1000, 1, |i| i * 7),
            (0..1000).map(|i| i * 7).collect::<Vec<_>>()
        );
        set_threads(0);
        assert!((1..=MAX_THREADS).contains(&threads()));
    }
}
