//! The firmware's robot constants against `robots/suspended-8.toml`
//! (read by `robot-file`, the same reader the host tools use).

use cdpr_control::robot::suspended8;
use robot_file::RobotFile;

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-6 * (1.0 + b.abs())
}

fn close_all<'a>(a: impl IntoIterator<Item = &'a f32>, b: impl IntoIterator<Item = &'a f32>) -> bool {
    let (a, b): (Vec<f32>, Vec<f32>) = (a.into_iter().copied().collect(), b.into_iter().copied().collect());
    a.len() == b.len() && a.iter().zip(&b).all(|(x, y)| close(*x, *y))
}

#[test]
fn constants_match_the_shipped_robot_file() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../robots/suspended-8.toml");
    let file = RobotFile::load(path).expect("robot file");
    let from_file = file.to_robot::<f32, 6, 8>().expect("6 x 8 robot");
    let consts = suspended8().expect("constants form a valid robot");

    assert_eq!(consts.kind(), from_file.kind());
    for i in 0..8 {
        assert!(close_all(consts.anchors()[i].iter(), from_file.anchors()[i].iter()), "anchor {i}");
        assert!(close_all(consts.attachments()[i].iter(), from_file.attachments()[i].iter()), "attach {i}");
    }
    assert!(close_all(consts.limits().min().iter(), from_file.limits().min().iter()));
    assert!(close_all(consts.limits().max().iter(), from_file.limits().max().iter()));
    let (p, q) = (consts.platform(), from_file.platform());
    assert!(close(p.mass, q.mass));
    assert!(close_all(p.com.iter(), q.com.iter()));
    assert!(close_all(p.gravity.iter(), q.gravity.iter()));
    assert!(close_all(p.inertia.iter(), q.inertia.iter()));
    let (w, v) = (consts.winch().expect("winch"), from_file.winch().expect("winch in file"));
    assert!(close_all(
        [w.drum_radius, w.gear_ratio, w.efficiency, w.torque_max].iter(),
        [v.drum_radius, v.gear_ratio, v.efficiency, v.torque_max].iter()
    ));
}
