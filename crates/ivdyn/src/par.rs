//! A few independent tasks on the machine's cores, results in order.
//!
//! The diagnosis has a handful of independent pieces of work at several places (the
//! differentiation cutoffs it compares, the joints of its Gram sums, the effects it scores):
//! each runs exactly as it would alone, so the results do not depend on the thread count
//! (bit for bit). Contiguous chunks, one per thread (at most `threads`, and at most
//! [`available`]), on scoped threads; a panic in a task is resumed on the caller. The caller
//! decides whether the work is worth threads (`threads` 1: the calling thread alone).

use std::sync::OnceLock;

/// `std::thread::available_parallelism()` (read once: it parses cgroup files, ~50 us).
pub fn available() -> usize {
    static AVAIL: OnceLock<usize> = OnceLock::new();
    *AVAIL.get_or_init(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1))
}

/// `f` of each contiguous chunk of `items`, one chunk per thread (at most `threads` and
/// [`available`]), in order.
pub fn map_chunks<T: Sync, R: Send>(threads: usize, items: &[T], f: impl Fn(&[T]) -> R + Sync) -> Vec<R> {
    let threads = threads.min(available()).min(items.len());
    if threads <= 1 {
        return vec![f(items)];
    }
    let per = items.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = items.chunks(per).map(|c| scope.spawn(|| f(c))).collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))).collect()
    })
}

/// `f` of every item, on [`map_chunks`]' threads, in order.
pub fn map<T: Sync, R: Send>(threads: usize, items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    map_chunks(threads, items, |c| c.iter().map(&f).collect::<Vec<R>>()).into_iter().flatten().collect()
}

/// `f(i, &mut items[i])` for every item, on [`map_chunks`]' threads (contiguous chunks).
pub fn for_each_mut<T: Send>(threads: usize, items: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
    let threads = threads.min(available()).min(items.len());
    if threads <= 1 {
        items.iter_mut().enumerate().for_each(|(i, x)| f(i, x));
        return;
    }
    let per = items.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks_mut(per)
            .enumerate()
            .map(|(c, chunk)| {
                let f = &f;
                scope.spawn(move || chunk.iter_mut().enumerate().for_each(|(i, x)| f(c * per + i, x)))
            })
            .collect();
        for h in handles {
            h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
        }
    });
}

#[cfg(test)]
mod tests {
    #[test]
    fn results_are_in_order_and_complete() {
        for threads in [1, 2, 5] {
            for n in [0usize, 1, 2, 3, 7, 100] {
                let items: Vec<usize> = (0..n).collect();
                let squares: Vec<usize> = items.iter().map(|i| i * i).collect();
                assert_eq!(super::map(threads, &items, |&i| i * i), squares);
                let chunks = super::map_chunks(threads, &items, |c| c.to_vec());
                assert_eq!(chunks.concat(), items);
                assert!(chunks.len() <= threads.min(super::available()).max(1));
                let mut v = vec![0usize; n];
                super::for_each_mut(threads, &mut v, |i, x| *x = 3 * i);
                assert_eq!(v, items.iter().map(|i| 3 * i).collect::<Vec<_>>());
            }
        }
    }
}
