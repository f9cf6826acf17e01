//! Pott's closed form (2009) and improved closed form (2013) against an
//! independent implementation on dynamic matrices with an SVD pseudo-inverse,
//! and their claims: every answer is feasible, the improved form succeeds
//! wherever the plain one does, `infeasible` only when the pose is.

use cdpr_integration_tests::random_problem;
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use proptest::prelude::*;
use tension_core::{solve, Error, Method, PreviousCycle, TensionLimits};

fn pinv_solve(w: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    w.clone().svd(true, true).solve(b, 1e-12).expect("svd")
}

/// Pott 2013, Sect. 2, written again from the paper on `DMatrix`: returns
/// the tensions, or `None` where the method gives up.
fn reference_improved<const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    f: &SVector<f64, N>,
    lo: f64,
    hi: f64,
) -> Option<DVector<f64>> {
    let mut fixed: Vec<Option<f64>> = vec![None; M];
    loop {
        let free: Vec<usize> = (0..M).filter(|&i| fixed[i].is_none()).collect();
        if free.len() < N {
            return None;
        }
        let wf = DMatrix::from_fn(N, free.len(), |r, c| w[(r, free[c])]);
        let mut rhs = DVector::from_fn(N, |r, _| f[r]);
        for i in 0..M {
            if let Some(v) = fixed[i] {
                for r in 0..N {
                    rhs[r] -= w[(r, i)] * v;
                }
            }
        }
        let middle = DVector::from_element(free.len(), 0.5 * (lo + hi));
        let tf = &middle + pinv_solve(&wf, &(&rhs - &wf * &middle));
        let mut t = DVector::zeros(M);
        for (c, &i) in free.iter().enumerate() {
            t[i] = tf[c];
        }
        for i in 0..M {
            if let Some(v) = fixed[i] {
                t[i] = v;
            }
        }
        let worst = free
            .iter()
            .map(|&i| (i, (t[i] - hi).max(lo - t[i])))
            .filter(|&(_, e)| e > 0.0)
            .max_by(|a, b| a.1.partial_cmp(&b.1).unwrap());
        match worst {
            None => return Some(t),
            Some((i, _)) => {
                if free.len() == N {
                    return None;
                }
                fixed[i] = Some(if t[i] > hi { hi } else { lo });
            }
        }
    }
}

fn check<const N: usize, const M: usize>(
    w: SMatrix<f64, N, M>,
    f: SVector<f64, N>,
    lo: f64,
    hi: f64,
) -> Result<(), TestCaseError> {
    let limits = TensionLimits::uniform(lo, hi).unwrap();
    let scale = hi;
    let wd = DMatrix::from_fn(N, M, |r, c| w[(r, c)]);
    let middle = DVector::from_element(M, 0.5 * (lo + hi));
    let fd = DVector::from_fn(N, |r, _| f[r]);
    let plain = &middle + pinv_solve(&wd, &(&fd - &wd * &middle));
    let plain_ok = plain.iter().all(|&t| t >= lo && t <= hi);
    let cf = solve(Method::ClosedForm, &w, &f, &limits, &PreviousCycle::NONE);
    match &cf {
        Ok(sol) => {
            prop_assert!(plain_ok || plain.iter().all(|&t| t >= lo - 1e-9 * scale && t <= hi + 1e-9 * scale));
            for i in 0..M {
                prop_assert!((sol.tensions[i] - plain[i]).abs() < 1e-9 * scale);
            }
        }
        Err(Error::Infeasible) => {
            // Certified by Eq. 3: the closest point is outside the circumscribed sphere.
            let radius = 0.5 * (hi - lo) * (M as f64).sqrt();
            prop_assert!((&plain - &middle).norm() > radius * (1.0 - 1e-9));
        }
        Err(Error::MethodFailed) => {
            prop_assert!(!plain.iter().all(|&t| t >= lo + 1e-9 * scale && t <= hi - 1e-9 * scale))
        }
        Err(e) => prop_assert!(false, "closed form: {e:?}"),
    }
    let icf = solve(Method::ImprovedClosedForm, &w, &f, &limits, &PreviousCycle::NONE);
    let reference = reference_improved(&w, &f, lo, hi);
    match (&icf, &reference) {
        (Ok(sol), Some(r)) => {
            prop_assert!((w * sol.tensions - f).amax() < 1e-9 * (1.0 + f.amax()));
            for i in 0..M {
                prop_assert!(sol.tensions[i] >= lo && sol.tensions[i] <= hi);
                prop_assert!((sol.tensions[i] - r[i]).abs() < 1e-7 * scale, "{:?} vs {r:?}", sol.tensions);
            }
        }
        (Err(Error::Infeasible) | Err(Error::MethodFailed), None) => {}
        (Err(Error::Infeasible), Some(_)) => {
            prop_assert!(false, "infeasible but the reference solved it")
        }
        other => {
            // Only a knife-edge difference in the fixing order may disagree.
            prop_assert!(false, "disagreement: {other:?}");
        }
    }
    // Where the plain form works, the improved one gives the same answer.
    if let Ok(sol) = &cf {
        let improved = icf.as_ref().expect("improved fails where plain works");
        prop_assert!((improved.tensions - sol.tensions).amax() < 1e-9 * scale);
    }
    // Infeasible is never claimed for a feasible pose (checked with the barycenter, r = 2).
    if M == N + 2 && matches!(icf, Err(Error::Infeasible)) {
        if let Ok(b) = solve(Method::Barycenter, &w, &f, &limits, &PreviousCycle::NONE) {
            prop_assert!(b.robustness < 1e-9 * scale);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(cdpr_integration_tests::persisted_config(500, file!()))]

    #[test]
    fn closed_forms_6x8((w, f, limits) in random_problem::<6, 8>(2.0)) { check(w, f, limits.min()[0], limits.max()[0])?; }

    #[test]
    fn closed_forms_6x10((w, f, limits) in random_problem::<6, 10>(2.0)) { check(w, f, limits.min()[0], limits.max()[0])?; }

    #[test]
    fn closed_forms_3x5((w, f, limits) in random_problem::<3, 5>(2.0)) { check(w, f, limits.min()[0], limits.max()[0])?; }

    #[test]
    fn closed_forms_2x4((w, f, limits) in random_problem::<2, 4>(2.0)) { check(w, f, limits.min()[0], limits.max()[0])?; }
}

#[test]
fn improved_form_extends_the_plain_one_near_the_border() {
    // Pott 2013, Fig. 2: near the border the plain form fails where the
    // improved one succeeds. A 2 x 4 case worked out by hand: W = [1 1 1 1; 1 -1 2 -2]
    // with limits [1, 10] and f = (36, 0): t_m = 5.5, W t_m = (22, 0),
    // correction W^+ (14, 0) = 3.5 (1,1,1,1) -> t = 9 each: feasible.
    let w = SMatrix::<f64, 2, 4>::new(1.0, 1.0, 1.0, 1.0, 1.0, -1.0, 2.0, -2.0);
    let limits = TensionLimits::uniform(1.0, 10.0).unwrap();
    let f = SVector::<f64, 2>::new(36.0, 0.0);
    let sol = solve(Method::ClosedForm, &w, &f, &limits, &PreviousCycle::NONE).unwrap();
    assert!((sol.tensions - SVector::<f64, 4>::repeat(9.0)).amax() < 1e-12);
    // f = (24, 22): W t_m = (22, 0), correction W^+ (2, 22) = 0.5 (1,1,1,1) + 2.2 (1,-1,2,-2)
    // -> (8.2, 3.8, 10.4, 1.6): cable 3 above 10. Fixing it at 10 leaves
    // W' = [1 1 1; 1 -1 -2], f' = (14, 2); from 5.5 the residual is (-2.5, 13),
    // W' W'^T = [3 -2; -2 6], y = [6 2; 2 3] / 14 (-2.5, 13) = (11/14, 34/14).
    let f = SVector::<f64, 2>::new(24.0, 22.0);
    assert_eq!(
        solve(Method::ClosedForm, &w, &f, &limits, &PreviousCycle::NONE).unwrap_err(),
        Error::MethodFailed
    );
    let sol = solve(Method::ImprovedClosedForm, &w, &f, &limits, &PreviousCycle::NONE).unwrap();
    assert_eq!(sol.tensions[2], 10.0);
    assert_eq!(sol.diagnostics.fixed_cables, 1);
    let (y0, y1) = (11.0 / 14.0, 34.0 / 14.0);
    let expected = [5.5 + y0 + y1, 5.5 + y0 - y1, 10.0, 5.5 + y0 - 2.0 * y1];
    for i in 0..4 {
        assert!((sol.tensions[i] - expected[i]).abs() < 1e-12, "{:?} vs {expected:?}", sol.tensions);
    }
}
