//! Test support shared by the workspace's integration tests: the robot
//! files in `robots/`, and reference computations written independently of
//! `tension-core`'s own algorithms (different decompositions, a different
//! polygon construction), so that a bug in one is not copied into the check.

use std::{
    path::PathBuf,
    time::{Duration, Instant},
};

use nalgebra::{DMatrix, DVector, SMatrix, SVector, Vector2};
use proptest::{
    prelude::*,
    test_runner::{FileFailurePersistence, RngSeed},
};
use robot_file::RobotFile;
use tension_core::{polygon::FeasiblePolygon, Real, Robot, TensionLimits};

/// A proptest configuration of `cases` cases whose failures are saved beside
/// `source_file` (pass `file!()`) as `<name>.proptest-regressions`, committed
/// and replayed first on every machine. (The default, a folder beside the
/// crate's `lib.rs`, is never found for files under `tests/`.)
///
/// The cases come from a fixed seed, so that the test command checks the
/// same cases on every run; `PROPTEST_RNG_SEED=<n>` (with
/// `CDPR_HOSTILE_SCALE` for more cases) explores others.
pub fn persisted_config(cases: u32, source_file: &'static str) -> ProptestConfig {
    let defaults = ProptestConfig::default();
    let rng_seed = match defaults.rng_seed {
        RngSeed::Random => RngSeed::Fixed(20_261_201),
        chosen => chosen,
    };
    ProptestConfig {
        cases,
        source_file: Some(source_file),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("proptest-regressions"))),
        rng_seed,
        ..defaults
    }
}

/// `base` cases times `CDPR_HOSTILE_SCALE` (default 1): the hostile
/// campaigns run short in the test command and as long as asked for, e.g.
/// `CDPR_HOSTILE_SCALE=100 cargo test --release --test integration hostile_inputs::`.
pub fn campaign_cases(base: u32) -> u32 {
    let scale = std::env::var("CDPR_HOSTILE_SCALE").ok().and_then(|s| s.parse::<u32>().ok()).unwrap_or(1);
    base.saturating_mul(scale.max(1))
}

/// The repository's `robots/` folder, the one source of robot files.
pub fn robots_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("robots")
}

/// `count` poses along a smooth closed path around `centre` at 1 kHz (the
/// benchmarks' path): a Lissajous figure of amplitudes `amp` (m) with the
/// Euler angles swinging by `tilt` (rad).
pub fn smooth_path<T: Real>(
    centre: [f64; 3],
    amp: [f64; 3],
    tilt: [f64; 3],
    count: usize,
) -> Vec<SVector<T, 6>> {
    (0..count)
        .map(|k| {
            let s = 2.0 * std::f64::consts::PI * k as f64 / count as f64;
            SVector::<T, 6>::from_fn(|i, _| {
                T::lit(match i {
                    0 => centre[0] + amp[0] * s.sin(),
                    1 => centre[1] + amp[1] * (2.0 * s).sin(),
                    2 => centre[2] + amp[2] * s.cos(),
                    3 => tilt[0] * s.sin(),
                    4 => -tilt[1] * s.cos(),
                    _ => tilt[2] * s.sin(),
                })
            })
        })
        .collect()
}

/// [`smooth_path`]'s shape (centre, amplitudes, tilts) for suspended-8 in
/// the benchmarks.
pub const SUSPENDED8_PATH: [[f64; 3]; 3] = [[0.0, 0.0, 1.5], [0.6, 0.4, 0.3], [0.05, 0.05, 0.15]];

/// [`smooth_path`]'s shape for IPAnema 1 in the benchmarks.
pub const IPANEMA1_PATH: [[f64; 3]; 3] = [[0.0, 0.0, 1.0], [0.4, 0.25, 0.1], [0.02, 0.02, 0.05]];

/// The benchmarks' timing protocol: the median time per call of `call(k)`
/// over `poses` poses (`k` in `0..poses`) and `rounds` rounds, each call
/// timed on its own.
pub fn median_time_per_call(rounds: usize, poses: usize, call: &mut dyn FnMut(usize)) -> Duration {
    let mut times = Vec::with_capacity(rounds * poses);
    for _ in 0..rounds {
        for k in 0..poses {
            let start = Instant::now();
            call(k);
            times.push(start.elapsed());
        }
    }
    times.sort_unstable();
    times[times.len() / 2]
}

/// `count` poses uniform over a box of the frame (`centre +- half_size` for
/// the position, `+- half_size[3]` rad for each angle), far outside the
/// workspace included, in a fixed order from `seed` (a 64-bit LCG: no
/// smoothness for a warm start to use).
pub fn frame_poses(centre: [f64; 3], half_size: [f64; 4], count: usize, seed: u64) -> Vec<SVector<f64, 6>> {
    let mut state = seed;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..count)
        .map(|_| {
            SVector::from_fn(|i, _| match i {
                0..=2 => centre[i] + half_size[i] * uniform(),
                _ => half_size[3] * uniform(),
            })
        })
        .collect()
}

/// Loads `robots/<name>.toml` as an `N x M` robot.
pub fn shipped_robot<T: Real, const N: usize, const M: usize>(name: &str) -> Robot<T, N, M> {
    let path = robots_dir().join(format!("{name}.toml"));
    RobotFile::load(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_robot()
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Orthonormal null-space basis of `w` from the symmetric eigen-decomposition
/// of `W^T W` (eigenvectors of the `M - N` smallest eigenvalues): a
/// different algorithm from the Householder QR in `tension-core`.
pub fn reference_null_space<const N: usize, const M: usize>(w: &SMatrix<f64, N, M>) -> DMatrix<f64> {
    let wtw = DMatrix::from_fn(M, M, |i, j| w.column(i).dot(&w.column(j)));
    let eig = wtw.symmetric_eigen();
    let mut order: Vec<usize> = (0..M).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].partial_cmp(&eig.eigenvalues[b]).unwrap());
    let r = M - N;
    DMatrix::from_fn(M, r, |i, k| eig.eigenvectors[(i, order[k])])
}

/// Minimum-norm solution `W^T (W W^T)^-1 f` by LU of `W W^T`.
pub fn reference_particular<const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    f: &SVector<f64, N>,
) -> DVector<f64> {
    let wd = DMatrix::from_fn(N, M, |i, j| w[(i, j)]);
    let wwt = &wd * wd.transpose();
    let y = wwt.lu().solve(&DVector::from_fn(N, |i, _| f[i])).expect("W W^T singular");
    wd.transpose() * y
}

/// The feasible polygon in null-space coordinates built by clipping a large
/// square with each half-plane in turn (Sutherland-Hodgman), with its area
/// and centroid by triangulation from the first vertex: independent of the
/// vertex walk and of the pairwise-intersection enumeration.
pub struct ClippedPolygon {
    /// Vertices, in order.
    pub vertices: Vec<[f64; 2]>,
    /// Area.
    pub area: f64,
    /// Centroid.
    pub centroid: [f64; 2],
}

/// Clips the square `|x|, |y| <= radius` by `lo_k <= rows_k . p <= hi_k`.
pub fn clip_polygon(rows: &[[f64; 2]], lo: &[f64], hi: &[f64], radius: f64) -> ClippedPolygon {
    let mut poly = vec![[-radius, -radius], [radius, -radius], [radius, radius], [-radius, radius]];
    for (k, n) in rows.iter().enumerate() {
        // n . p <= hi  and  -n . p <= -lo
        for (a, c) in [([n[0], n[1]], hi[k]), ([-n[0], -n[1]], -lo[k])] {
            let inside = |p: &[f64; 2]| a[0] * p[0] + a[1] * p[1] <= c;
            let mut out = Vec::new();
            for i in 0..poly.len() {
                let p = poly[i];
                let q = poly[(i + 1) % poly.len()];
                let (pin, qin) = (inside(&p), inside(&q));
                if pin {
                    out.push(p);
                }
                if pin != qin {
                    let fp = a[0] * p[0] + a[1] * p[1] - c;
                    let fq = a[0] * q[0] + a[1] * q[1] - c;
                    let s = fp / (fp - fq);
                    out.push([p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])]);
                }
            }
            poly = out;
            if poly.is_empty() {
                return ClippedPolygon { vertices: poly, area: 0.0, centroid: [f64::NAN; 2] };
            }
        }
    }
    // Triangle fan from the first vertex.
    let o = poly[0];
    let (mut area, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for i in 1..poly.len().saturating_sub(1) {
        let (b, c) = (poly[i], poly[i + 1]);
        let tri = 0.5 * ((b[0] - o[0]) * (c[1] - o[1]) - (c[0] - o[0]) * (b[1] - o[1]));
        area += tri;
        cx += tri * (o[0] + b[0] + c[0]) / 3.0;
        cy += tri * (o[1] + b[1] + c[1]) / 3.0;
    }
    let centroid = if area > 0.0 { [cx / area, cy / area] } else { [f64::NAN; 2] };
    ClippedPolygon { vertices: poly, area, centroid }
}

/// The feasible polygon of `W t = f` within `limits` (`M = N + 2`) in the
/// reference's coordinates: `t = tp + z lambda` (eigen-decomposition null
/// space, SVD particular solution), half-planes `lo_k <= rows_k . lambda <=
/// hi_k`, clipped inside a fixed square that holds the whole polygon
/// (`|t| <= |t_max|`; the automatic square of [`clip_polygon_auto`] grows to
/// 1e15 on an empty polygon, where rounding leaves slivers).
pub struct ReferencePolygon<const M: usize> {
    /// Null-space basis, `M x 2`.
    pub z: DMatrix<f64>,
    /// Minimum-norm particular solution.
    pub tp: DVector<f64>,
    /// Rows of `z`.
    pub rows: Vec<[f64; 2]>,
    /// `t_min - tp`.
    pub lo: Vec<f64>,
    /// `t_max - tp`.
    pub hi: Vec<f64>,
    /// Vertices of the clipped polygon, in order (empty when infeasible).
    pub vertices: Vec<[f64; 2]>,
    /// Its area.
    pub area: f64,
    /// Its centroid (NaN when the area is not positive).
    pub centroid: [f64; 2],
}

impl<const M: usize> ReferencePolygon<M> {
    /// The polygon of `W t = f` within `limits`.
    pub fn new<const N: usize>(
        w: &SMatrix<f64, N, M>,
        f: &SVector<f64, N>,
        limits: &TensionLimits<f64, M>,
    ) -> Self {
        assert_eq!(M, N + 2);
        let z = reference_null_space(w);
        let tp = reference_particular(w, f);
        let rows: Vec<[f64; 2]> = (0..M).map(|k| [z[(k, 0)], z[(k, 1)]]).collect();
        let lo: Vec<f64> = (0..M).map(|k| limits.min()[k] - tp[k]).collect();
        let hi: Vec<f64> = (0..M).map(|k| limits.max()[k] - tp[k]).collect();
        let radius = 4.0 * (limits.max().norm() + tp.norm());
        let poly = clip_polygon(&rows, &lo, &hi, radius);
        Self { z, tp, rows, lo, hi, vertices: poly.vertices, area: poly.area, centroid: poly.centroid }
    }

    /// The tensions at null-space coordinates `p`.
    pub fn tensions(&self, p: [f64; 2]) -> SVector<f64, M> {
        SVector::from_fn(|k, _| self.tp[k] + self.z[(k, 0)] * p[0] + self.z[(k, 1)] * p[1])
    }

    /// Area relative to the square of the tension scale, to skip
    /// near-degenerate cases in comparisons.
    pub fn relative_area(&self, limits: &TensionLimits<f64, M>) -> f64 {
        self.area / (limits.scale() * limits.scale())
    }
}

/// The reference barycenter of `W t = f` within `limits` (`M = N + 2`):
/// `None` when the clipped polygon is empty. Also returns the polygon's area
/// relative to the square of the tension scale (to skip near-degenerate
/// cases in comparisons).
pub fn reference_barycenter<const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    f: &SVector<f64, N>,
    limits: &TensionLimits<f64, M>,
) -> Option<(SVector<f64, M>, f64)> {
    let poly = ReferencePolygon::new(w, f, limits);
    if poly.vertices.is_empty() || poly.area.is_nan() || poly.area <= 0.0 {
        return None;
    }
    Some((poly.tensions(poly.centroid), poly.relative_area(limits)))
}

/// Residual of the analytic centre's optimality conditions (Di Paola et al.
/// 2024, Eq. 15) with unit weights and no extra constraint: the multipliers
/// `mu` by least squares (SVD), then `|grad phi + W^T mu|` scaled by the
/// half-range of the limits, and `|W t - f|` relative to `|f|`.
pub fn analytic_centre_residual<const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    f: &SVector<f64, N>,
    limits: &TensionLimits<f64, M>,
    t: &SVector<f64, M>,
) -> (f64, f64) {
    let grad = DVector::from_fn(M, |i, _| -1.0 / (t[i] - limits.min()[i]) + 1.0 / (limits.max()[i] - t[i]));
    stationarity_residual(w, &grad, limits, t, f)
}

/// `|grad + W^T mu|` (least-squares `mu`) times the smallest half-range, and
/// the relative equality residual.
pub fn stationarity_residual<const N: usize, const M: usize>(
    w: &SMatrix<f64, N, M>,
    grad: &DVector<f64>,
    limits: &TensionLimits<f64, M>,
    t: &SVector<f64, M>,
    f: &SVector<f64, N>,
) -> (f64, f64) {
    let wt = DMatrix::from_fn(M, N, |i, j| w[(j, i)]);
    let svd = wt.clone().svd(true, true);
    let mu = svd.solve(&(-grad), 1e-14).expect("svd solve");
    let stationarity = (grad + &wt * mu).norm();
    let half = (0..M).map(|i| 0.5 * (limits.max()[i] - limits.min()[i])).fold(f64::INFINITY, f64::min);
    let eq = (w * t - f).norm() / (1.0 + f.norm());
    (stationarity * half, eq)
}

/// [`clip_polygon`] with the smallest square (from 10 upwards, by factors of
/// 10) that holds the polygon without touching it, so that the square
/// neither cuts the polygon nor costs precision. An empty result is only
/// final at the largest square: a small one may miss a polygon far away.
pub fn clip_polygon_auto(rows: &[[f64; 2]], lo: &[f64], hi: &[f64]) -> ClippedPolygon {
    let mut radius = 10.0;
    loop {
        let poly = clip_polygon(rows, lo, hi, radius);
        let touches = poly.vertices.iter().any(|p| p[0].abs().max(p[1].abs()) >= 0.999 * radius);
        if (!poly.vertices.is_empty() && !touches) || radius >= 1e15 {
            return poly;
        }
        radius *= 10.0;
    }
}

/// Random problems for the property tests: an `N x M` wrench matrix with
/// entries in `[-1, 1]`, uniform limits `t_min in [0, 20)`, width in
/// `[1, 500)`, and `f = W t0 + push * width * offset` for a `t0` inside the
/// box: feasible when `push` is 0 (half the cases), feasible or not when it
/// is drawn from `[0, push_max)`.
pub fn random_problem<const N: usize, const M: usize>(
    push_max: f64,
) -> impl Strategy<Value = (SMatrix<f64, N, M>, SVector<f64, N>, TensionLimits<f64, M>)> {
    (
        prop::collection::vec(-1.0f64..1.0, N * M),
        prop::collection::vec(0.0f64..1.0, M),
        prop::collection::vec(-1.0f64..1.0, N),
        prop_oneof![Just(0.0), 0.0f64..push_max],
        0.0f64..20.0,
        1.0f64..500.0,
    )
        .prop_map(|(entries, inside, offset, push, t_min, width)| {
            let w = SMatrix::from_fn(|i, j| entries[i * M + j]);
            let limits = TensionLimits::uniform(t_min, t_min + width).unwrap();
            let t0 = SVector::<f64, M>::from_fn(|i, _| t_min + width * inside[i]);
            let f = w * t0 + SVector::<f64, N>::from_fn(|i, _| offset[i] * push * width);
            (w, f, limits)
        })
}

/// One sample of a trajectory: pose and its first two time derivatives.
pub struct Sample<const N: usize> {
    /// Pose.
    pub pose: SVector<f64, N>,
    /// Its time derivative.
    pub velocity: SVector<f64, N>,
    /// Its second time derivative.
    pub acceleration: SVector<f64, N>,
}

/// Through `waypoints` at 1 kHz with `tension_core::trajectory::time_law`,
/// each segment timed so that its peak speed (35/16 of the mean for this
/// time law) is 0.9 m/s or rad/s.
pub fn trajectory<const N: usize>(waypoints: &[SVector<f64, N>]) -> Vec<Sample<N>> {
    let mut out = Vec::new();
    for pair in waypoints.windows(2) {
        let delta = pair[1] - pair[0];
        let seconds = (delta.amax() * 35.0 / 16.0 / 0.9).max(0.1);
        let steps = (seconds * 1000.0).ceil() as usize;
        for k in 0..steps {
            let (s, ds, dds) = tension_core::trajectory::time_law(k as f64 / steps as f64);
            out.push(Sample {
                pose: pair[0] + delta * s,
                velocity: delta * (ds / seconds),
                acceleration: delta * (dds / (seconds * seconds)),
            });
        }
    }
    out
}

/// Eight cables' null-space rows, their limits' offsets (the origin inside
/// every cable's limits) and a direction in which the offsets move.
pub type EightCablePolygon = ([[f64; 2]; 8], [f64; 8], [f64; 8], [f64; 8]);

/// Random [`EightCablePolygon`]s: one row in four nearly parallel to the one
/// before it (at 1e-2 to 1e-9 rad), one in four a twin of it (the same
/// direction and norm, limits and shift within 1e-6 of its: IPAnema 1's
/// symmetric poses).
pub fn eight_cable_polygon() -> impl Strategy<Value = EightCablePolygon> {
    (
        prop::array::uniform8((0.0..std::f64::consts::TAU, 0.05..3.0f64, 0u8..4, 2.0..9.0f64)),
        prop::array::uniform8((1.0..20.0f64, 1.0..20.0f64)),
        prop::array::uniform8(-1.0..1.0f64),
    )
        .prop_map(|(rows, limits, shift)| {
            let mut r = [[0.0; 2]; 8];
            // The offsets' origin inside every cable's limits: feasible
            // before the shift.
            let mut lower = limits.map(|(below, _)| -below);
            let mut upper = limits.map(|(_, above)| above);
            let mut v = shift;
            let mut previous = 0.0;
            for (i, &(angle, norm, twin, decades)) in rows.iter().enumerate() {
                let a = match twin {
                    0 if i > 0 => previous + 10f64.powf(-decades),
                    1 if i > 0 => previous,
                    _ => angle,
                };
                let n = if twin == 1 && i > 0 { rows[i - 1].1 } else { norm };
                if twin == 1 && i > 0 {
                    let tiny = 1e-6 * (angle - 3.0);
                    lower[i] = lower[i - 1] + tiny;
                    upper[i] = upper[i - 1] + tiny;
                    v[i] = v[i - 1] + tiny;
                }
                r[i] = [n * a.cos(), n * a.sin()];
                previous = a;
            }
            (r, lower, upper, v)
        })
}

/// The case's polygon with its limits' offsets moved by `tau` times its
/// direction (`None` when `FeasiblePolygon::new` refuses it).
pub fn shifted_polygon<T: Real>(c: &EightCablePolygon, tau: f64) -> Option<FeasiblePolygon<T, 8>> {
    let rows = c.0.map(|r| Vector2::new(T::lit(r[0]), T::lit(r[1])));
    let lower: [T; 8] = core::array::from_fn(|i| T::lit(c.1[i] + tau * c.3[i]));
    let upper: [T; 8] = core::array::from_fn(|i| T::lit(c.2[i] + tau * c.3[i]));
    FeasiblePolygon::new(rows, lower, upper).ok()
}
