//! `Waypoints::new` and sampling on hostile parts: every set of times,
//! poses and extras is either refused with a one-line bad-input error or
//! sampled without a panic, at any time (NaN, infinities, before the first
//! waypoint, after the last), each sample's pose between the two waypoints
//! of its segment; sample counts beyond `MAX_SAMPLES` are refused before
//! anything is allocated (a long span used to abort the process asking for
//! petabytes).

use cdpr::trajectory::{Waypoints, MAX_SAMPLES};
use proptest::prelude::*;
use proptest::test_runner::TestRunner;

/// Numbers a file or a caller may hand over.
fn number() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -10.0f64..10.0,
        1 => Just(0.0),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(f64::MAX),
        1 => Just(-f64::MAX),
        1 => Just(f64::MIN_POSITIVE),
        1 => Just(1e13),
    ]
}

/// Times of `n` waypoints: mostly increasing (so that many sets are
/// accepted), sometimes anything.
fn times(n: usize) -> impl Strategy<Value = Vec<f64>> {
    prop_oneof![
        3 => prop::collection::vec(0.001f64..5.0, n).prop_map(|steps| {
            let mut t = -1.0;
            steps.iter().map(|s| { t += s; t }).collect()
        }),
        1 => prop::collection::vec(number(), n),
    ]
}

/// `n` rows of `width` values, mostly moderate; now and then a row too
/// many, too few or of another length.
fn rows(n: usize, width: usize) -> impl Strategy<Value = Vec<Vec<f64>>> {
    let value = prop_oneof![40 => -3.0f64..3.0, 1 => number()];
    (prop::collection::vec(prop::collection::vec(value, width), n), 0..12usize).prop_map(
        |(mut rows, damage)| {
            match damage {
                0 => drop(rows.pop()),
                1 => rows.push(vec![0.0; rows.first().map_or(1, |r| r.len())]),
                2 => {
                    if let Some(r) = rows.last_mut() {
                        r.push(1.0)
                    }
                }
                _ => {}
            }
            rows
        },
    )
}

/// Times, poses and extras, as `Waypoints::new` takes them.
type Parts = (Vec<f64>, Vec<Vec<f64>>, Option<Vec<Vec<f64>>>);

/// A set of parts for 0 to 5 waypoints.
fn parts() -> impl Strategy<Value = Parts> {
    (prop_oneof![1 => 0..2usize, 6 => 2..6usize], 1..4usize, 1..3usize)
        .prop_flat_map(|(n, width, extra)| (times(n), rows(n, width), prop::option::of(rows(n, extra))))
}

#[derive(Debug, Default)]
struct Counts {
    refused: usize,
    accepted: usize,
    samples: usize,
    sampled_times: usize,
}

#[test]
fn hostile_waypoints_are_refused_or_sampled_within_their_segments() {
    let mut runner = TestRunner::new(cdpr_integration_tests::persisted_config(1024, file!()));
    let counts = std::cell::RefCell::new(Counts::default());
    let strategy = (
        parts(),
        prop::collection::vec(number(), 1..6),
        prop_oneof![Just(10.0), Just(1e9), Just(f64::NAN), Just(-1.0), 0.5f64..100.0],
    );
    runner
        .run(&strategy, |((times, poses, extras), at, rate)| {
            let mut c = counts.borrow_mut();
            let w = match Waypoints::new(times.clone(), poses.clone(), extras.clone()) {
                Err(e) => {
                    prop_assert!(e.bad_input && !e.message.is_empty() && !e.message.contains('\n'), "{e:?}");
                    c.refused += 1;
                    return Ok(());
                }
                Ok(w) => w,
            };
            c.accepted += 1;
            // What `new` promised.
            prop_assert!(times.len() >= 2 && times.windows(2).all(|p| p[0] < p[1]));
            prop_assert!(times.iter().all(|t| t.is_finite()));
            prop_assert_eq!(poses.len(), times.len());
            prop_assert_eq!(w.times(), &times[..]);
            for t in at.iter().copied().chain(times.iter().copied()) {
                let s = w.sample(t);
                c.samples += 1;
                prop_assert_eq!(s.pose.len(), poses[0].len());
                prop_assert_eq!(s.extra.is_some(), extras.is_some());
                if !t.is_finite() || s.pose.iter().any(|p| !p.is_finite()) {
                    continue;
                }
                // Between the two waypoints of its segment, coordinate by
                // coordinate (rounding aside).
                let k = w.segment(t);
                for (i, p) in s.pose.iter().enumerate() {
                    let (a, b) = (poses[k][i], poses[k + 1][i]);
                    let slack = 1e-12 * (a.abs() + b.abs());
                    prop_assert!(
                        *p >= a.min(b) - slack && *p <= a.max(b) + slack,
                        "{p} outside [{a}, {b}] at {t}"
                    );
                }
            }
            match w.sample_times(rate) {
                Ok(samples) => {
                    c.sampled_times += 1;
                    prop_assert!(samples.len() >= 2 && samples.len() <= MAX_SAMPLES + 1);
                    prop_assert_eq!(samples[0], w.start());
                    prop_assert_eq!(*samples.last().unwrap(), w.end());
                }
                Err(e) => prop_assert!(
                    e.bad_input && e.message.contains("--rate") || e.message.contains("samples"),
                    "{e:?}"
                ),
            }
            Ok(())
        })
        .unwrap();
    let c = counts.into_inner();
    println!("{c:?}");
    // Both outcomes reached their asserts.
    assert!(c.refused >= 100 && c.accepted >= 100 && c.sampled_times >= 50, "{c:?}");
}

/// The spans that used to abort `cdpr profiles` / `cdpr stream` (the
/// sample vector sized before any check), and a rate of zero.
#[test]
fn long_spans_and_bad_rates_are_refused_before_allocating() {
    let w = Waypoints::new(vec![0.0, 1e13], vec![vec![0.0; 6], vec![0.1; 6]], None).unwrap();
    for rate in [1.0, 1000.0, 1e300, f64::MAX] {
        let e = w.sample_times(rate).unwrap_err();
        assert!(e.bad_input && e.message.contains("samples"), "{rate}: {e:?}");
        // Readable: the span and the rate in a few digits (`{:.0}` wrote
        // 301 digits for a rate of 1e300).
        assert!(e.message.starts_with("1e13 s at ") && e.message.len() < 90, "{rate}: {e:?}");
    }
    let short = Waypoints::new(vec![0.0, 1e6], vec![vec![0.0; 6], vec![0.1; 6]], None).unwrap();
    let e = short.sample_times(1000.0).unwrap_err();
    assert!(e.message.starts_with("1000000 s at 1000 Hz is more than 2000000 samples"), "{e:?}");
    for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = w.sample_times(rate).unwrap_err();
        assert!(e.bad_input && e.message.starts_with("--rate"), "{rate}: {e:?}");
    }
    // Just within: MAX_SAMPLES intervals.
    let w = Waypoints::new(vec![0.0, MAX_SAMPLES as f64 / 1000.0], vec![vec![0.0], vec![1.0]], None).unwrap();
    assert_eq!(w.sample_times(1000.0).unwrap().len(), MAX_SAMPLES + 1);
    assert!(w.sample_times(1000.5).is_err());
}
