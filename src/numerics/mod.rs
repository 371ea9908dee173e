//! Small numerical building blocks shared by the models.

pub mod lanes;
pub mod quadrature;
pub mod roots;
pub mod special;
pub mod stats;
pub mod tiled_pairs;

/// Whether the processor has AVX: the pair kernels then take their AVX forms, whose results
/// are the bits of their portable twins.
pub fn has_avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// From this many items on, [`fold_items`] runs on the rayon pool.
const PARALLEL_FOLD_FROM: usize = 4096;

/// `item(0)`, …, `item(n − 1)` merged from `empty`, on the rayon pool from a few thousand items
/// on, so the per-step scans of a large set (run checks, extremes, counts) are not a serial
/// part of its step. The grouping depends on the thread count: `merge` must be order-free
/// (max, min, logical and, integer sums) for the result to be the same at any thread count.
pub fn fold_items<T: Copy + Send + Sync>(
    n: usize,
    empty: T,
    item: impl Fn(usize) -> T + Sync + Send,
    merge: impl Fn(T, T) -> T + Sync + Send,
) -> T {
    use rayon::prelude::*;
    if n >= PARALLEL_FOLD_FROM {
        (0..n)
            .into_par_iter()
            .fold(|| empty, |acc, i| merge(acc, item(i)))
            .reduce(|| empty, &merge)
    } else {
        (0..n).fold(empty, |acc, i| merge(acc, item(i)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_parallel_fold_equals_the_serial_one() {
        let item = |i: usize| ((i * 7919) % 10007) as f64 - 5000.0;
        for n in [0, 1, 100, PARALLEL_FOLD_FROM, 50_000] {
            let serial = (0..n).map(item).fold(f64::NEG_INFINITY, f64::max);
            assert_eq!(fold_items(n, f64::NEG_INFINITY, item, f64::max), serial);
            let count = fold_items(n, 0usize, |i| usize::from(item(i) > 0.0), |a, b| a + b);
            assert_eq!(count, (0..n).filter(|&i| item(i) > 0.0).count());
        }
    }
}
