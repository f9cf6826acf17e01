//! The cold search for a first vertex (`FeasiblePolygon::first_vertex`,
//! Lamaury & Gouttefarde 2013, Eq. 8) finds a vertex exactly when the
//! exhaustive pair search does (`FeasiblePolygon::brute_force`, Mikelsons et
//! al. 2008), at the feasibility border, where the tolerances decide: random
//! polygons of eight cables (some rows parallel or nearly parallel to
//! another, as on IPAnema 1)
//! shifted by bisection to where the exhaustive verdict flips, then checked
//! at and around that shift, in `f32` and `f64`. At the same shifts, the
//! walk's fallback (the pairs of the lines the clipping does not prove
//! empty, `FeasiblePolygon::brute_force_among`) finds the same vertices, in
//! the same order, with the same outcome, as the pairs of all lines. The
//! search with any cable's lines clipped first
//! (`FeasiblePolygon::first_vertex_from`, as after a lost warm start)
//! gives the same verdict.

use cdpr_integration_tests::{eight_cable_polygon, shifted_polygon, EightCablePolygon};
use proptest::{prelude::*, test_runner::TestRunner};
use std::sync::atomic::{AtomicUsize, Ordering};
use tension_core::{
    polygon::{FeasiblePolygon, VertexList},
    Real,
};

const M: usize = 8;

type Case = EightCablePolygon;

fn case() -> impl Strategy<Value = Case> {
    eight_cable_polygon()
}

fn polygon<T: Real>(c: &Case, tau: f64) -> Option<FeasiblePolygon<T, M>> {
    shifted_polygon(c, tau)
}

fn exhaustive<T: Real>(c: &Case, tau: f64) -> Option<bool> {
    polygon::<T>(c, tau).map(|p| p.brute_force().is_ok())
}

/// Checks the cold search against the exhaustive one at the shifts around
/// the border; the number of shifts checked.
fn check_border<T: Real>(c: &Case) -> Result<usize, TestCaseError> {
    // Feasible unshifted (the offsets' origin is inside); the first
    // doubling of the shift that is not.
    if exhaustive::<T>(c, 0.0) != Some(true) {
        return Ok(0);
    }
    let Some(mut b) = (0..12).map(|k| f64::from(1 << k)).find(|&tau| exhaustive::<T>(c, tau) == Some(false))
    else {
        return Ok(0);
    };
    let mut a = 0.0;
    for _ in 0..80 {
        let mid = 0.5 * (a + b);
        match exhaustive::<T>(c, mid) {
            Some(true) => a = mid,
            Some(false) => b = mid,
            None => return Ok(0),
        }
    }
    let mut checked = 0;
    for i in -8..=8 {
        let tau = a + (b - a) * i as f64 + 1e-7 * (1.0 + a.abs()) * i as f64;
        let Some(p) = polygon::<T>(c, tau) else { continue };
        let exists = p.brute_force().is_ok();
        prop_assert_eq!(p.first_vertex().is_some(), exists, "shift {} (border between {} and {})", tau, a, b);
        // Whichever cable's lines are clipped first (a lost warm start's
        // cutting cable, and one out of range: the first), the same verdict.
        for first in 0..=M + 1 {
            prop_assert_eq!(
                p.first_vertex_from(first).is_some(),
                exists,
                "shift {}, cable {} first",
                tau,
                first
            );
        }
        let (mut all, mut among) = (VertexList::new(), VertexList::new());
        let by_all = p.brute_force_into(&mut all);
        let by_open = p.brute_force_among(p.lines_not_proven_empty(), &mut among);
        prop_assert_eq!(by_all, by_open, "shift {}", tau);
        prop_assert_eq!(all.len(), among.len(), "shift {}", tau);
        for (u, v) in all.iter().zip(among.iter()) {
            prop_assert_eq!(u, v, "shift {}", tau);
        }
        checked += 1;
    }
    Ok(checked)
}

fn run<T: Real>(cases: u32) {
    let checked = AtomicUsize::new(0);
    let mut runner = TestRunner::new(cdpr_integration_tests::persisted_config(cases, file!()));
    runner
        .run(&case(), |c| {
            checked.fetch_add(check_border::<T>(&c)?, Ordering::Relaxed);
            Ok(())
        })
        .unwrap();
    let n = checked.into_inner();
    assert!(n >= cases as usize * 8, "only {n} border polygons reached the comparison");
}

#[test]
fn cold_search_agrees_with_the_exhaustive_search_at_the_border_f64() {
    run::<f64>(400);
}

#[test]
fn cold_search_agrees_with_the_exhaustive_search_at_the_border_f32() {
    run::<f32>(400);
}
