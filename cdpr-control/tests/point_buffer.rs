//! The trajectory buffer: the interpolation against polynomials evaluated
//! here, its clock (start delay, feed hold when dry), its rules (late,
//! out of order, full, gaps, jumps; restart while free) and a hostile
//! campaign of random pushes and samples.

use cdpr_control::link::JumpLimits;
use cdpr_control::point_buffer::{Played, PointBuffer, DEPTH, MAX_SEGMENT_MS, START_DELAY_CYCLES};
use cdpr_control::protocol::{Rejection, TrajectoryPoint};
use cdpr_control::Setpoint;
use proptest::prelude::*;

/// A cubic per coordinate, `c0 + c1 t + c2 t^2 + c3 t^3` (t in s), with
/// its derivatives: the reference the Hermite must reproduce exactly.
struct Cubic([[f64; 4]; 6]);

impl Cubic {
    fn sample() -> Self {
        Self([
            [0.1, 0.3, -0.2, 0.05],
            [-0.2, -0.1, 0.4, -0.1],
            [1.8, 0.2, 0.1, -0.03],
            [0.01, 0.05, -0.02, 0.01],
            [-0.02, 0.02, 0.03, -0.01],
            [0.05, -0.04, 0.01, 0.02],
        ])
    }
    fn at(&self, t: f64) -> ([f64; 6], [f64; 6], [f64; 6]) {
        let mut p = [0.0; 6];
        let mut v = [0.0; 6];
        let mut a = [0.0; 6];
        for (i, c) in self.0.iter().enumerate() {
            p[i] = c[0] + c[1] * t + c[2] * t * t + c[3] * t * t * t;
            v[i] = c[1] + 2.0 * c[2] * t + 3.0 * c[3] * t * t;
            a[i] = 2.0 * c[2] + 6.0 * c[3] * t;
        }
        (p, v, a)
    }
    fn point(&self, time_ms: u32) -> TrajectoryPoint {
        let (p, v, _) = self.at(f64::from(time_ms) * 1e-3);
        TrajectoryPoint { time_ms, pose: p.map(|x| x as f32), velocity: v.map(|x| x as f32) }
    }
}

/// The setpoint a sample played (none for a refused stream).
fn setpoint(p: Played) -> Option<Setpoint> {
    match p {
        Played::Setpoint(s) => Some(s),
        Played::Refused => None,
    }
}

fn at_rest(time_ms: u32, x: f32) -> TrajectoryPoint {
    TrajectoryPoint { time_ms, pose: [x, 0.0, 1.8, 0.0, 0.0, 0.0], velocity: [0.0; 6] }
}

#[test]
fn the_hermite_reproduces_a_cubic_with_its_derivatives() {
    let cubic = Cubic::sample();
    let mut buffer = PointBuffer::new();
    // Points every 10 ms from t = 0, the first arriving at cycle 100.
    for k in 0..20 {
        buffer.push(&cubic.point(10 * k), 100, true, Some(&JumpLimits::DEFAULT)).unwrap();
    }
    let mut reached = 0;
    for now in 100..100 + START_DELAY_CYCLES + 190 {
        let sample = buffer.sample(now).and_then(setpoint);
        if now < 100 + START_DELAY_CYCLES {
            assert!(sample.is_none(), "cycle {now}");
            continue;
        }
        let s = sample.unwrap();
        let t_ms = now - 100 - START_DELAY_CYCLES;
        assert_eq!(s.seq, t_ms);
        // The points carry f32: near 1.8 m a pose is rounded by 1.2e-7 m,
        // which the second derivative over 10 ms scales to about 7e-3 m/s^2.
        let (p, v, a) = cubic.at(f64::from(t_ms) * 1e-3);
        for i in 0..6 {
            assert!(
                (f64::from(s.pose[i]) - p[i]).abs() < 2e-6,
                "t {t_ms} ms, {i}: {} vs {}",
                s.pose[i],
                p[i]
            );
            assert!(
                (f64::from(s.velocity[i]) - v[i]).abs() < 5e-5,
                "t {t_ms}, {i}: v {} vs {}",
                s.velocity[i],
                v[i]
            );
            assert!(
                (f64::from(s.acceleration[i]) - a[i]).abs() < 1e-2,
                "t {t_ms}, {i}: a {} vs {}",
                s.acceleration[i],
                a[i]
            );
        }
        reached += 1;
    }
    assert_eq!(reached, 190);
}

#[test]
fn position_and_velocity_are_continuous_at_the_points() {
    // Points with unrelated velocities (not one polynomial): the samples
    // just before, at and after each point agree to first order.
    let mut buffer = PointBuffer::new();
    let mut points = Vec::new();
    for k in 0..10u32 {
        let x = 0.01 * (k as f32).sin();
        let v = 0.3 * (k as f32 * 1.7).cos();
        let p = TrajectoryPoint {
            time_ms: 8 * k,
            pose: [x, 0.0, 1.8, 0.0, 0.0, 0.0],
            velocity: [v, 0.0, 0.0, 0.0, 0.0, 0.0],
        };
        points.push(p);
        buffer.push(&p, 0, false, None).unwrap();
    }
    let mut samples = Vec::new();
    for now in START_DELAY_CYCLES..START_DELAY_CYCLES + 73 {
        samples.push(buffer.sample(now).and_then(setpoint).unwrap());
    }
    let a_max = samples.iter().map(|s| s.acceleration[0].abs()).fold(0.0f32, f32::max);
    assert!(a_max > 1.0, "the test's points are not a smooth curve: {a_max}");
    for p in &points[1..9] {
        let k = p.time_ms as usize;
        // At the point: the point itself.
        assert!((samples[k].pose[0] - p.pose[0]).abs() < 1e-6);
        assert!((samples[k].velocity[0] - p.velocity[0]).abs() < 1e-4);
        // Either side: the position moves by v * 1 ms to within Taylor's
        // remainder, |a| (1 ms)^2 / 2, with |a| bounded by twice the
        // largest sampled acceleration (linear in each segment).
        for j in [k - 1, k + 1] {
            let moved = samples[j].pose[0] - samples[k].pose[0];
            let expected = p.velocity[0] * 1e-3 * (j as f32 - k as f32);
            let remainder = 0.5 * 2.0 * a_max * 1e-6 + 1e-7;
            assert!((moved - expected).abs() <= remainder, "{k}: {moved} vs {expected} (+- {remainder})");
        }
    }
}

#[test]
fn the_first_point_plays_after_the_start_delay_and_counts_as_filled() {
    let mut buffer = PointBuffer::new();
    buffer.push(&at_rest(5000, 0.1), 7, true, None).unwrap();
    buffer.push(&at_rest(5010, 0.1), 8, true, None).unwrap();
    assert_eq!(buffer.fill(8), 2);
    assert_eq!(buffer.lead_ms(8), 10 + START_DELAY_CYCLES - 1);
    assert!(buffer.sample(7 + START_DELAY_CYCLES - 1).and_then(setpoint).is_none());
    let s = buffer.sample(7 + START_DELAY_CYCLES).and_then(setpoint).unwrap();
    assert_eq!(s.seq, 5000);
    assert_eq!(buffer.fill(7 + START_DELAY_CYCLES), 1);
}

#[test]
fn while_bound_late_duplicate_gapped_and_jumping_points_are_rejected() {
    let limits = JumpLimits::DEFAULT;
    let mut buffer = PointBuffer::new();
    buffer.push(&at_rest(100, 0.1), 0, true, Some(&limits)).unwrap();
    buffer.push(&at_rest(110, 0.1), 0, true, Some(&limits)).unwrap();
    assert_eq!(buffer.push(&at_rest(110, 0.1), 0, true, Some(&limits)), Err(Rejection::Late));
    assert_eq!(buffer.push(&at_rest(105, 0.1), 0, true, Some(&limits)), Err(Rejection::Late));
    assert_eq!(
        buffer.push(&at_rest(110 + MAX_SEGMENT_MS + 1, 0.1), 0, true, Some(&limits)),
        Err(Rejection::BufferFull)
    );
    // 60 mm at rest in 10 ms: a jump (the tolerance is 50 mm).
    assert_eq!(buffer.push(&at_rest(120, 0.16), 0, true, Some(&limits)), Err(Rejection::Jump));
    // Nothing changed: the next good point continues the stream.
    assert_eq!(buffer.fill(0), 2);
    buffer.push(&at_rest(120, 0.12), 0, true, Some(&limits)).unwrap();
    assert_eq!(buffer.fill(0), 3);
    // In the past of the clock: the clock is at 100 + 40 = 140 > 130.
    let now = START_DELAY_CYCLES + 40;
    assert!(buffer.sample(now).and_then(setpoint).is_none(), "dry: the clock waits at 120");
    assert_eq!(buffer.push(&at_rest(119, 0.12), now, true, Some(&limits)), Err(Rejection::Late));
}

#[test]
fn while_free_a_point_that_does_not_continue_starts_a_new_stream() {
    let mut buffer = PointBuffer::new();
    buffer.push(&at_rest(100, 0.1), 0, false, None).unwrap();
    buffer.push(&at_rest(110, 0.1), 0, false, None).unwrap();
    // Renumbered from 0 at cycle 50: a new stream, playing 20 cycles later.
    buffer.push(&at_rest(0, 0.3), 50, false, None).unwrap();
    assert_eq!(buffer.fill(50), 1);
    assert!(buffer.sample(50 + START_DELAY_CYCLES - 1).and_then(setpoint).is_none());
    let s = buffer.sample(50 + START_DELAY_CYCLES).and_then(setpoint).unwrap();
    assert_eq!((s.seq, s.pose[0]), (0, 0.3));
}

#[test]
fn a_full_buffer_rejects_until_points_are_played() {
    let mut buffer = PointBuffer::new();
    for k in 0..DEPTH as u32 {
        buffer.push(&at_rest(10 * k, 0.1), 0, true, None).unwrap();
    }
    assert_eq!(buffer.push(&at_rest(10 * DEPTH as u32, 0.1), 0, true, None), Err(Rejection::BufferFull));
    // Two segments played: room for two more.
    let now = START_DELAY_CYCLES + 20;
    assert!(buffer.sample(now).and_then(setpoint).is_some());
    buffer.push(&at_rest(10 * DEPTH as u32, 0.1), now, true, None).unwrap();
    buffer.push(&at_rest(10 * DEPTH as u32 + 10, 0.1), now, true, None).unwrap();
    assert_eq!(
        buffer.push(&at_rest(10 * DEPTH as u32 + 20, 0.1), now, true, None),
        Err(Rejection::BufferFull)
    );
}

#[test]
fn a_dry_buffer_waits_at_its_last_point_and_resumes_from_it() {
    let mut buffer = PointBuffer::new();
    let moving = |t: u32, x: f32| TrajectoryPoint {
        time_ms: t,
        pose: [x, 0.0, 1.8, 0.0, 0.0, 0.0],
        velocity: [0.1, 0.0, 0.0, 0.0, 0.0, 0.0],
    };
    buffer.push(&moving(0, 0.0), 0, true, None).unwrap();
    buffer.push(&moving(10, 0.001), 0, true, None).unwrap();
    let start = START_DELAY_CYCLES;
    for now in start..=start + 10 {
        assert!(buffer.sample(now).and_then(setpoint).is_some());
    }
    // 30 cycles without points: nothing new, the clock waits at 10 ms.
    for now in start + 11..start + 41 {
        assert!(buffer.sample(now).and_then(setpoint).is_none());
        assert_eq!((buffer.fill(now), buffer.lead_ms(now)), (0, 0));
    }
    // The next point continues from 10 ms: the first sample after it is
    // 1 ms along the new segment, not 31.
    buffer.push(&moving(20, 0.002), start + 41, true, None).unwrap();
    let s = buffer.sample(start + 42).and_then(setpoint).unwrap();
    assert_eq!(s.seq, 11);
    assert!((s.pose[0] - 0.0011).abs() < 1e-6, "{}", s.pose[0]);
}

#[test]
fn a_refused_point_plays_as_bad_where_the_buffer_runs_dry() {
    let mut buffer = PointBuffer::new();
    buffer.push(&at_rest(0, 0.1), 0, true, None).unwrap();
    buffer.push(&at_rest(10, 0.1), 0, true, None).unwrap();
    buffer.refuse();
    // The good points still play; then Refused instead of nothing.
    for now in START_DELAY_CYCLES..=START_DELAY_CYCLES + 10 {
        assert!(matches!(buffer.sample(now), Some(Played::Setpoint(_))), "{now}");
    }
    assert_eq!(buffer.sample(START_DELAY_CYCLES + 11), Some(Played::Refused));
    // A good point clears the mark and the stream goes on.
    buffer.push(&at_rest(20, 0.1), START_DELAY_CYCLES + 12, true, None).unwrap();
    assert!(matches!(buffer.sample(START_DELAY_CYCLES + 13), Some(Played::Setpoint(_))));
    // Without a stream there is nothing to mark.
    let mut empty = PointBuffer::new();
    empty.refuse();
    assert_eq!(empty.sample(0), None);
}

#[derive(Debug, Clone)]
enum Op {
    Push { dt: i32, x: f32, v: f32, bound: bool },
    Sample { cycles: u32 },
    Clear,
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        6 => (-20i32..300, -1.0f32..1.0, -5.0f32..5.0, any::<bool>()).prop_map(|(dt, x, v, bound)| Op::Push { dt, x, v, bound }),
        6 => (0u32..40).prop_map(|cycles| Op::Sample { cycles }),
        1 => Just(Op::Clear),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    /// Random pushes (times forwards, backwards, far ahead; bound or
    /// free), samples and clears, from a clock near the u32 wrap: nothing
    /// panics, the fill never exceeds the depth, every sample is finite
    /// and its time never runs backwards within a stream, and a sample's
    /// pose lies within the bound the Hermite basis allows.
    #[test]
    fn hostile_sequences_keep_the_buffer_sound(ops in proptest::collection::vec(op(), 1..120), start in any::<u32>()) {
        let mut buffer = PointBuffer::new();
        let mut now = start;
        let mut time = 0u32;
        let mut last_seq: Option<u32> = None;
        for op in ops {
            match op {
                Op::Push { dt, x, v, bound } => {
                    time = time.wrapping_add(dt as u32);
                    let p = TrajectoryPoint { time_ms: time, pose: [x, 0.0, 1.8, 0.0, 0.0, 0.0], velocity: [v, 0.0, 0.0, 0.0, 0.0, 0.0] };
                    let continues = dt > 0 && dt as u32 <= MAX_SEGMENT_MS;
                    let restarts = !buffer.active() || !(bound || continues);
                    if buffer.push(&p, now, bound, None).is_ok() && restarts {
                        last_seq = None;
                    }
                }
                Op::Sample { cycles } => {
                    now = now.wrapping_add(cycles);
                    if let Some(s) = buffer.sample(now).and_then(setpoint) {
                        prop_assert!(s.pose.iter().chain(s.velocity.iter()).chain(s.acceleration.iter()).all(|x| x.is_finite()));
                        // h00 + h01 = 1 (both >= 0), |h10|, |h11| <= 4/27: with
                        // |x| <= 1, |v| <= 5 m/s, h <= 0.25 s, |p| <= 1 + 2 (4/27) 5 0.25.
                        prop_assert!(s.pose[0].abs() <= 1.0 + 2.0 * 4.0 / 27.0 * 5.0 * 0.25 + 1e-3, "{}", s.pose[0]);
                        if let Some(prev) = last_seq {
                            prop_assert!((s.seq.wrapping_sub(prev) as i32) >= 0, "{prev} -> {}", s.seq);
                        }
                        last_seq = Some(s.seq);
                    }
                }
                Op::Clear => {
                    buffer.clear();
                    last_seq = None;
                }
            }
            prop_assert!(buffer.fill(now) <= DEPTH);
        }
    }
}

#[test]
fn the_hostile_campaign_reaches_its_asserts() {
    // The same generator, counted: most cases push and sample something.
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let (mut with_samples, cases) = (0, 200);
    for _ in 0..cases {
        let ops = proptest::collection::vec(op(), 1..120).new_tree(&mut runner).unwrap().current();
        let mut buffer = PointBuffer::new();
        let (mut now, mut time, mut got) = (0u32, 0u32, 0);
        for op in ops {
            match op {
                Op::Push { dt, x, v, bound } => {
                    time = time.wrapping_add(dt as u32);
                    let p = TrajectoryPoint {
                        time_ms: time,
                        pose: [x, 0.0, 1.8, 0.0, 0.0, 0.0],
                        velocity: [v, 0.0, 0.0, 0.0, 0.0, 0.0],
                    };
                    let _ = buffer.push(&p, now, bound, None);
                }
                Op::Sample { cycles } => {
                    now = now.wrapping_add(cycles);
                    got += usize::from(buffer.sample(now).and_then(setpoint).is_some());
                }
                Op::Clear => buffer.clear(),
            }
        }
        with_samples += usize::from(got > 0);
    }
    assert!(with_samples > cases / 2, "{with_samples} of {cases} cases sampled a setpoint");
}
