//! The layer's per-cycle work on the host, for a profiler
//! (`valgrind --tool=callgrind target/release/examples/layer_cost`): eight
//! drive models behind loopback ports ([`LoopbackRig`]), started, then
//! 10 000 cycles of `read` + `set_brakes` + `apply`. Prints how many frames
//! the layer took in per cycle.

use canopen_drives::model::LoopbackRig;
use canopen_drives::{DriveConfig, Timing};
use cdpr_control::{WinchDrives, WinchReading, CABLES};

fn main() {
    let configs: [DriveConfig; CABLES] = core::array::from_fn(|i| DriveConfig {
        bus: (i / 4) as u8,
        node: (i % 4 + 1) as u8,
        rated_torque: 0.8,
        torque_max: 2.5,
    });
    let mut rig = LoopbackRig::new(configs, 800, Timing::DEFAULT);
    assert!(rig.start(500, 1_000_000), "the drive models did not start");
    let mut readings = [WinchReading::default(); CABLES];
    let (mut ok, mut fewest, mut most) = (0, u32::MAX, 0);
    for k in 0..10_000 {
        rig.set_positions(&[if std::env::var_os("STILL").is_some() { 5 } else { k * 7 }; CABLES]);
        let before = rig.layer.counters().received;
        let r = std::hint::black_box(rig.layer.read(&mut readings));
        let taken = rig.layer.counters().received - before;
        (fewest, most) = (fewest.min(taken), most.max(taken));
        let _ = rig.layer.set_brakes(false);
        let _ = rig.layer.apply(&[0.3; CABLES]);
        rig.deliver(1_000_000);
        ok += u32::from(r.is_ok());
    }
    println!("{ok} cycles ok of 10000; frames taken in per cycle: {fewest} to {most}");
}
