//! Scalar root finding for monotone functions.

/// Finds t with f(t) = 0 for a function that is non-decreasing, given f(lo) < 0 ≤ f(hi):
/// bisection to a relative width `rel_tol` (robust for piecewise-interpolated data).
pub fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64, rel_tol: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= rel_tol * hi.abs() {
            break;
        }
    }
    0.5 * (lo + hi)
}
