//! The 7th-degree point-to-point time law of Di Paola et al. 2024 (Eq. 17):
//! `s(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7` on `u in [0, 1]`, rising from 0 to 1
//! with velocity, acceleration and jerk zero at both ends, so that a segment
//! between poses at rest has a continuous d'Alembert wrench.

use crate::Real;

/// `(s(u), s'(u), s''(u))`, with `u` clamped to `[0, 1]` (NaN stays NaN).
pub fn time_law<T: Real>(u: T) -> (T, T, T) {
    let u = if u < T::zero() {
        T::zero()
    } else if u > T::one() {
        T::one()
    } else {
        u
    };
    let c = T::lit;
    let u2 = u * u;
    let u3 = u2 * u;
    let s = u2 * u2 * (c(35.0) - c(84.0) * u + c(70.0) * u2 - c(20.0) * u3);
    let ds = u3 * (c(140.0) - c(420.0) * u + c(420.0) * u2 - c(140.0) * u3);
    let dds = u2 * (c(420.0) - c(1680.0) * u + c(2100.0) * u2 - c(840.0) * u3);
    (s, ds, dds)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ends_at_rest_and_derivatives_match_differences() {
        assert_eq!(time_law(0.0f64), (0.0, 0.0, 0.0));
        assert_eq!(time_law(1.0f64), (1.0, 0.0, 0.0));
        assert_eq!(time_law(-3.0f64), (0.0, 0.0, 0.0));
        assert!((time_law(0.5f64).0 - 0.5).abs() < 1e-12);
        let h = 1e-6;
        for k in 1..20 {
            let u = k as f64 / 20.0;
            let (_, ds, dds) = time_law(u);
            assert!(((time_law(u + h).0 - time_law(u - h).0) / (2.0 * h) - ds).abs() < 1e-6);
            assert!(((time_law(u + h).1 - time_law(u - h).1) / (2.0 * h) - dds).abs() < 1e-5);
        }
        assert!(time_law(f64::NAN).0.is_nan());
    }
}
