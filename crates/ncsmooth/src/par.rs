//! Data parallelism for independent per-item work: `n` items cut into one contiguous chunk
//! per thread (std scoped threads, at most [`MAX_THREADS`]), the results concatenated in
//! order. Each item is computed alone, so the result never depends on the number of
//! threads; below a caller's threshold, or on one core, it is a plain loop.

/// Most threads [`map`] uses.
pub const MAX_THREADS: usize = 4;

/// `(0..n).map(f).collect()`, on up to [`MAX_THREADS`] threads when `n >= min_items` and
/// the machine has more than one core.
pub fn map<T, F>(n: usize, min_items: usize, f: F) -> Vec<T>
where
    T: Send,
    F: Fn(usize) -> T + Sync,
{
    let threads = std::thread::available_parallelism()
        .map_or(1, |c| c.get())
        .min(MAX_THREADS);
    if threads < 2 || n < min_items.max(2) {
        return (0..n).map(f).collect();
    }
    let chunk = n.div_ceil(threads);
    let f = &f;
    std::thread::scope(|scope| {
        let parts: Vec<_> = (0..n)
            .step_by(chunk)
            .map(|lo| scope.spawn(move || (lo..(lo + chunk).min(n)).map(f).collect::<Vec<T>>()))
            .collect();
        let mut out = Vec::with_capacity(n);
        for p in parts {
            out.extend(p.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
        }
        out
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
    }
}
