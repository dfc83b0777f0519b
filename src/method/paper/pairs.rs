//! Microphone pairs: the paper's `R_ij` for `i < j`, numbered once for every stage.
//!
//! The correlation (eq. 6), the peaks (eq. 7), the consistency search (eq. 8) and the
//! direction (eq. 13) all index pairs the same way.

/// Index of pair `(a, b)`, `a < b`, among `k` microphones, pairs ordered `(0,1), (0,2), ..,
/// (0,k-1), (1,2), ..`.
#[inline]
pub fn pair_index(a: usize, b: usize, k: usize) -> usize {
    debug_assert!(a < b && b < k);
    a * (2 * k - a - 1) / 2 + (b - a - 1)
}

/// Number of pairs among `k` microphones.
#[inline]
pub fn pair_count(k: usize) -> usize {
    k * (k - 1) / 2
}
