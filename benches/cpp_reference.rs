//! Our `f64` solver calls on IPAnema 1, timed for the comparison with the C++
//! reference, WireLib (Pott, part of WireX), which is built and timed outside
//! the repository by `benches/cpp_reference/` (see its README.md).
//!
//! Run the comparison with `benches/cpp_reference/compare.sh WIREX_DIR`: it
//! builds both, dumps the poses, then runs this bench and WireLib's harness
//! alternately and prints one table.
//!
//! This bench alone (`cargo bench --bench cpp_reference`):
//! * with `CDPR_CPP_REFERENCE_POSES=FILE`, first writes what the C++ harness
//!   needs (the format is below): the robot's anchors, attachments and
//!   tension limits, the 1000 poses of the smooth 1 kHz path of
//!   `native_flags` for IPAnema 1 with the wrench `f` each pose needs
//!   (`Robot::wrench_problem`: gravity on the platform, `W t = f`), our
//!   wrench matrix `W` of each pose and our tensions of each pose for the
//!   methods the two libraries share, for the harness's correctness check;
//!   with `CDPR_CPP_REFERENCE_DUMP_ONLY` set too it stops there;
//! * then times the kinematics (`W` and `f` of a pose) and the methods, each
//!   the median time per call over the 1000 poses x 20 rounds, each call
//!   timed (the protocol of `native_flags`), and prints one line per call:
//!   `name<TAB>median ns`; the first line, `timer (empty call)`, is what the
//!   timing costs (two clock reads), included in every other line.
//!
//! The file is plain text, one record per line, the first word its kind,
//! numbers in Rust's shortest round-trip notation:
//! * `cable i ax ay az bx by bz t_min t_max`: anchor `a_i` (base frame),
//!   attachment `b_i` (platform frame), limits;
//! * `pose k x y z rx ry rz f1 .. f6`: the pose (conventions: `R = Rx Ry Rz`)
//!   and the wrench the cables must produce, `W t = f`;
//! * `matrix k w11 w12 .. w68`: our `W` at pose `k`, row by row;
//! * `tensions METHOD k STATUS [t1 .. t8]`: our tensions at pose `k`
//!   (`STATUS` is `ok` or the error's status word, the tensions only with
//!   `ok`); the barycenter solved cold.

use std::{fmt::Write as _, hint::black_box, time::Duration};

use cdpr_integration_tests::{median_time_per_call, shipped_robot, smooth_path, IPANEMA1_PATH};
use nalgebra::{SMatrix, SVector};
use tension_core::{Method, Robot, TensionSolver};

/// Where to write the poses for the C++ harness.
const POSES_FILE: &str = "CDPR_CPP_REFERENCE_POSES";

/// Set: only write the poses file.
const DUMP_ONLY: &str = "CDPR_CPP_REFERENCE_DUMP_ONLY";

/// Poses on the path, and rounds over them for each median.
const POSES: usize = 1000;
const ROUNDS: usize = 20;

/// IPAnema 1's path in `native_flags`: centre, amplitudes, tilts.
const PATH: [[f64; 3]; 3] = IPANEMA1_PATH;

/// The methods timed, warm (the solver's carried state) or cold.
const METHODS: [(Method, bool); 6] = [
    (Method::Barycenter, true),
    (Method::Barycenter, false),
    (Method::ClosedForm, true),
    (Method::ImprovedClosedForm, true),
    (Method::Puncture, true),
    (Method::ImprovedPuncture, true),
];

/// The methods whose tensions the C++ harness compares with its own.
const CHECKED: [Method; 5] = [
    Method::ClosedForm,
    Method::ImprovedClosedForm,
    Method::Puncture,
    Method::ImprovedPuncture,
    Method::Barycenter,
];

type PoseProblem = (SMatrix<f64, 6, 8>, SVector<f64, 6>);

/// Appends the numbers to `line`, each after a space.
fn push_numbers<'a>(line: &mut String, numbers: impl IntoIterator<Item = &'a f64>) {
    for x in numbers {
        write!(line, " {x:e}").expect("write to a string");
    }
}

/// The poses file's text (format in the header).
fn poses_file(robot: &Robot<f64, 6, 8>, path: &[SVector<f64, 6>], problems: &[PoseProblem]) -> String {
    let mut text =
        String::from("# cdpr cpp_reference: IPAnema 1 (robots/ipanema1.toml), the native_flags path\n");
    let limits = robot.limits();
    for (i, (a, b)) in robot.anchors().iter().zip(robot.attachments()).enumerate() {
        text += &format!("cable {i}");
        push_numbers(&mut text, a.iter().chain(b.iter()).chain([&limits.min()[i], &limits.max()[i]]));
        text.push('\n');
    }
    for (k, (pose, (w, f))) in path.iter().zip(problems).enumerate() {
        text += &format!("pose {k}");
        push_numbers(&mut text, pose.iter().chain(f.iter()));
        text += &format!("\nmatrix {k}");
        push_numbers(&mut text, w.transpose().iter());
        text.push('\n');
    }
    for method in CHECKED {
        let mut solver = TensionSolver::<f64, 8>::new(method);
        for (k, (w, f)) in problems.iter().enumerate() {
            solver.reset();
            text += &format!("tensions {} {k}", method.name());
            match solver.solve(w, f, limits) {
                Ok(solution) => {
                    text += " ok";
                    push_numbers(&mut text, solution.tensions.iter());
                }
                Err(e) => text += &format!(" {}", e.status()),
            }
            text.push('\n');
        }
    }
    text
}

/// Median time per call of `call(k)` over the poses, `ROUNDS` rounds
/// (`native_flags`' protocol).
fn median(mut call: impl FnMut(usize)) -> Duration {
    median_time_per_call(ROUNDS, POSES, &mut call)
}

fn main() {
    let robot: Robot<f64, 6, 8> = shipped_robot("ipanema1");
    let path = smooth_path::<f64>(PATH[0], PATH[1], PATH[2], POSES);
    let zero = SVector::<f64, 6>::zeros();
    let problems: Vec<PoseProblem> =
        path.iter().map(|p| robot.wrench_problem(p, &zero, None).expect("path pose")).collect();

    if let Some(file) = std::env::var_os(POSES_FILE) {
        std::fs::write(&file, poses_file(&robot, &path, &problems))
            .unwrap_or_else(|e| panic!("{}: {e}", file.to_string_lossy()));
        eprintln!("wrote {}", file.to_string_lossy());
        if std::env::var_os(DUMP_ONLY).is_some() {
            return;
        }
    }

    // What the timing itself costs (two clock reads), in every row below.
    let timer = median(|k| {
        black_box(k);
    });
    println!("timer (empty call)\t{}", timer.as_nanos());
    let kinematics = median(|k| {
        black_box(robot.wrench_problem(black_box(&path[k]), &zero, None).ok());
    });
    println!("kinematics\t{}", kinematics.as_nanos());
    let limits = *robot.limits();
    for (method, warm) in METHODS {
        let mut solver = TensionSolver::<f64, 8>::new(method);
        let time = median(|k| {
            if !warm {
                solver.reset();
            }
            let (w, f) = &problems[k];
            black_box(solver.solve(black_box(w), black_box(f), &limits).ok());
        });
        let name = if method.warm_starts() {
            format!("{} ({})", method.name(), if warm { "warm" } else { "cold" })
        } else {
            method.name().to_string()
        };
        println!("{name}\t{}", time.as_nanos());
    }
}
