//! Hostile robot files: every number of every shipped robot file replaced,
//! one at a time, by values a careless or hostile file holds (NaN,
//! infinities, values past `f32`'s range, subnormals, signed zeros,
//! negatives, integers past their types, text, booleans, nothing), and
//! files with far too many cables. Each must give a one-line error that
//! says where, or a robot whose every number is finite and which
//! `tension-core` either builds and evaluates without a panic or refuses
//! with a typed error, in `f64` and `f32`.

use std::path::PathBuf;

use nalgebra::SVector;
use robot_file::RobotFile;
use tension_core::Real;

/// The replacements tried for each number.
const HOSTILE: [&str; 22] = [
    "nan",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e39",
    "-1e39",
    "5e-324",
    "1e-30",
    "0",
    "-0.0",
    "-1",
    "1e20",
    "3.5",
    "128",
    "-129",
    "4294967296",
    "9223372036854775807",
    "\"7\"",
    "true",
    "[]",
    "",
];

fn robots_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../robots")
}

/// The byte ranges of the numbers on the value side of `key = value`
/// lines (not comments, not table headers).
fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let code = line.split('#').next().unwrap_or("");
        if let Some(eq) = code.find('=') {
            let bytes = code.as_bytes();
            let mut i = eq + 1;
            while i < bytes.len() {
                let starts = bytes[i].is_ascii_digit() || bytes[i] == b'-' || bytes[i] == b'+';
                if starts {
                    let mut j = i + 1;
                    while j < bytes.len() && (bytes[j].is_ascii_alphanumeric() || b".+-_".contains(&bytes[j]))
                    {
                        j += 1;
                    }
                    if code[i..j].parse::<f64>().is_ok() {
                        spans.push((offset + i, offset + j));
                    }
                    i = j;
                } else {
                    i += 1;
                }
            }
        }
        offset += line.len();
    }
    spans
}

/// What happened to the cases.
#[derive(Debug, Default)]
struct Tally {
    cases: usize,
    refused: usize,
    accepted: usize,
    robots_built: usize,
    robots_refused: usize,
    poses_evaluated: usize,
    poses_refused: usize,
}

/// Every number of an accepted file is finite.
fn assert_finite(file: &RobotFile, case: &str) {
    let mut all: Vec<f64> = vec![file.mass];
    all.extend(file.com);
    all.extend(file.gravity);
    all.extend(file.inertia.iter().flatten());
    all.extend(file.winch.iter().flatten());
    all.extend(file.drives.rated_torque);
    for c in &file.cables {
        all.extend(c.anchor);
        all.extend(c.attach);
        all.extend([c.t_min, c.t_max]);
    }
    assert!(all.iter().all(|v| v.is_finite()), "{case}: an accepted file holds a non-finite number");
    assert!(file.encoder.counts_per_revolution > 0, "{case}");
    assert!(file.encoder.signs.iter().all(|&s| s == 1 || s == -1), "{case}");
    assert!(file.drives.node_ids.iter().all(|&n| (1..=127).contains(&n)), "{case}");
    assert!(file.drives.buses.iter().all(|&b| b == 1 || b == 2), "{case}");
}

/// The file as a robot in `T`: built or refused with a typed error; when
/// built, its wrench problem at a few poses is finite or refused.
fn exercise<T: Real, const N: usize, const M: usize>(file: &RobotFile, case: &str, tally: &mut Tally) {
    let robot = match file.to_robot::<T, N, M>() {
        Ok(r) => r,
        Err(e) => {
            let message = e.to_string();
            assert!(!message.is_empty() && !message.contains('\n'), "{case}: {message:?}");
            tally.robots_refused += 1;
            return;
        }
    };
    tally.robots_built += 1;
    for lift in [0.0, 0.5, 1.5, 1e30] {
        let mut pose = SVector::<T, N>::zeros();
        pose[N - 1] = T::lit(0.01);
        pose[if N == 6 { 2 } else { 1 }] = T::lit(lift);
        match robot.wrench_problem(&pose, &SVector::zeros(), None) {
            Ok((w, f)) => {
                let finite = w.iter().chain(f.iter()).all(|v| v.is_finite());
                assert!(finite, "{case}: a wrench problem that is not finite at lift {lift}");
                tally.poses_evaluated += 1;
            }
            Err(_) => tally.poses_refused += 1,
        }
    }
}

/// [`exercise`] in `f64` and in `f32`.
fn in_both<const N: usize, const M: usize>(file: &RobotFile, case: &str, tally: &mut Tally) {
    exercise::<f64, N, M>(file, case, tally);
    exercise::<f32, N, M>(file, case, tally);
}

/// Parses `text` and checks whatever comes out.
fn check(text: &str, case: &str, tally: &mut Tally) {
    tally.cases += 1;
    match RobotFile::parse(text) {
        Err(e) => {
            let message = e.to_string();
            assert!(message.contains("line "), "{case}: an error that does not say where: {message:?}");
            assert!(!message.contains('\n'), "{case}: a message on more than one line: {message:?}");
            tally.refused += 1;
        }
        Ok(file) => {
            assert_finite(&file, case);
            let _ = (file.identity(), file.canonical_bytes());
            tally.accepted += 1;
            match (file.dof(), file.cables.len()) {
                (6, 8) => in_both::<6, 8>(&file, case, tally),
                (6, 10) => in_both::<6, 10>(&file, case, tally),
                (3, 5) => in_both::<3, 5>(&file, case, tally),
                (2, 4) => in_both::<2, 4>(&file, case, tally),
                shape => panic!("{case}: no shipped robot has shape {shape:?}"),
            }
        }
    }
}

#[test]
fn every_number_of_every_shipped_robot_replaced_by_hostile_values() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(robots_dir())
        .expect("robots/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 6, "the shipped robots: {files:?}");
    let mut tally = Tally::default();
    let mut numbers = 0;
    for path in &files {
        let text = std::fs::read_to_string(path).expect("robot file");
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        // The file itself is a robot.
        check(&text, &name, &mut tally);
        let spans = number_spans(&text);
        assert!(spans.len() >= 20, "{name}: {} numbers found", spans.len());
        numbers += spans.len();
        for &(start, end) in &spans {
            for value in HOSTILE {
                let hostile = format!("{}{value}{}", &text[..start], &text[end..]);
                let line = text[..start].matches('\n').count() + 1;
                let case = format!("{name} line {line}: {:?} -> {value:?}", &text[start..end]);
                check(&hostile, &case, &mut tally);
            }
        }
    }
    println!("{numbers} numbers in {} files: {tally:?}", files.len());
    // Every case reached its asserts, and both outcomes happened.
    assert_eq!(tally.cases, files.len() + numbers * HOSTILE.len());
    assert_eq!(tally.cases, tally.refused + tally.accepted);
    assert!(tally.refused > numbers * 8, "{tally:?}");
    assert!(tally.accepted > numbers * 2, "{tally:?}");
    assert_eq!(tally.robots_built + tally.robots_refused, 2 * tally.accepted);
    assert!(tally.robots_refused > 0 && tally.poses_evaluated > 1000 && tally.poses_refused > 0, "{tally:?}");
}

/// Files with up to far more cables than any robot has: up to 254 (two
/// CAN buses of 127 drives) parsed with every drive at its own address on
/// the default split, more refused at the 255th cable, before the per-cable
/// checks (which compare the drives pairwise). 255 cables used to
/// put a drive at node id 128, 1 000 to wrap the ids past 255.
#[test]
fn a_file_with_very_many_cables_is_answered_promptly() {
    let text = std::fs::read_to_string(robots_dir().join("suspended-8.toml")).expect("robot file");
    let head = &text[..text.find("[[cable]]").expect("cables")];
    // No explicit drive keys: the default split of the cables over the buses.
    let head: String = head.lines().filter(|l| !l.starts_with("node_id") && !l.starts_with("can_bus")).fold(
        String::new(),
        |mut s, l| {
            s.push_str(l);
            s.push('\n');
            s
        },
    );
    let mut answered = 0;
    for cables in [8, 9, 64, 254, 255, 1000, 50_000] {
        let mut file = head.clone();
        for k in 0..cables {
            let x = (k % 100) as f64 * 0.01;
            file.push_str(&format!("[[cable]]\nanchor = [{x}, -1.4, 3.5]\nattach = [0.1, 0.1, 0.1]\n"));
        }
        let result = RobotFile::parse(&file);
        if cables <= 254 {
            let parsed = result.unwrap_or_else(|e| panic!("{cables} cables: {e}"));
            assert_eq!(parsed.cables.len(), cables);
            let (ids, buses) = (&parsed.drives.node_ids, &parsed.drives.buses);
            let mut seen = std::collections::HashSet::new();
            for i in 0..cables {
                assert!(
                    (1..=127).contains(&ids[i]) && (buses[i] == 1 || buses[i] == 2),
                    "{cables}: cable {i}"
                );
                assert!(seen.insert((ids[i], buses[i])), "{cables}: cable {i} shares its drive's address");
            }
        } else {
            // The 255th cable's line: 21 lines of head, three per cable.
            let line = head.lines().count() + 3 * 254 + 1;
            let message = result.expect_err("more drives than the buses address").to_string();
            assert_eq!(
                message,
                format!("line {line}: the file has {cables} cables; at most 254 (a winch drive each, node ids 1..=127 on each of the two CAN buses)")
            );
        }
        answered += 1;
    }
    assert_eq!(answered, 7);
}
