//! Work spread over the machine's cores, results in the input's order.

/// `f(i, &xs[i])` for every element, on one worker thread per core (at
/// most one per element), each taking the next unclaimed element; the
/// results in the order of `xs`, whatever order the workers finished in,
/// so anything combined from them afterwards does not depend on the
/// threads. Elements are claimed in index order: put the longest first.
///
/// # Panics
///
/// When `f` panics: that panic is raised again on the calling thread.
pub fn map_in_order<T: Sync, U: Send>(xs: &[T], f: impl Fn(usize, &T) -> U + Sync) -> Vec<U> {
    let workers = std::thread::available_parallelism()
        .map_or(1, std::num::NonZero::get)
        .min(xs.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let parts: Vec<Vec<(usize, U)>> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut v = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(x) = xs.get(i) else { break };
                        v.push((i, f(i, x)));
                    }
                    v
                })
            })
            .collect();
        hs.into_iter()
            .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    let mut out: Vec<(usize, U)> = parts.into_iter().flatten().collect();
    out.sort_by_key(|r| r.0);
    out.into_iter().map(|(_, u)| u).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Squares of 0..1000 (a closed form), in order, from however many
    /// threads; and an empty input maps to nothing.
    #[test]
    fn results_come_back_in_the_inputs_order() {
        let xs: Vec<u64> = (0..1000).collect();
        let ys = map_in_order(&xs, |i, &x| (i, x * x));
        for (k, &(i, y)) in ys.iter().enumerate() {
            assert_eq!((i, y), (k, (k * k) as u64));
        }
        assert!(map_in_order(&[] as &[u8], |_, &x| x).is_empty());
    }
}
