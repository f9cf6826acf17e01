//! The layer's per-cycle work on the host, for a profiler
//! (`valgrind --tool=callgrind target/release/examples/layer_cost`): eight
//! drive models behind loopback ports, started, then 10 000 cycles of
//! `read` + `set_brakes` + `apply`.

use canopen_drives::cia402::DriveState;
use canopen_drives::model::{LoopbackPort, Ring, SimDrive};
use canopen_drives::{CanDrives, DriveConfig, Timing};
use cdpr_control::{WinchDrives, WinchReading, CABLES};

fn main() {
    let configs: [DriveConfig; CABLES] = core::array::from_fn(|i| DriveConfig {
        bus: (i / 4) as u8,
        node: (i % 4 + 1) as u8,
        rated_torque: 0.8,
        torque_max: 2.5,
    });
    let mut models: [SimDrive; CABLES] = core::array::from_fn(|i| SimDrive::new(configs[i].node, 800));
    for m in models.iter_mut() {
        m.power_on(0, &mut Ring::new());
    }
    let mut layer = CanDrives::new(LoopbackPort::new(), LoopbackPort::new(), configs, Timing::DEFAULT);
    let mut readings = [WinchReading::default(); CABLES];
    let mut t = 0u64;
    let mut cycle = |layer: &mut CanDrives<LoopbackPort, LoopbackPort>,
                     models: &mut [SimDrive; CABLES],
                     timed: bool| {
        let r =
            if timed { std::hint::black_box(layer.read(&mut readings)) } else { layer.read(&mut readings) };
        let _ = layer.set_brakes(false);
        let _ = layer.apply(&[0.3; CABLES]);
        t += 1_000_000;
        let (p1, p2) = layer.ports();
        let (m1, m2) = models.split_at_mut(4);
        p1.deliver(m1, t);
        p2.deliver(m2, t);
        r
    };
    for _ in 0..500 {
        if cycle(&mut layer, &mut models, false).is_ok()
            && models.iter().all(|m| m.state() == DriveState::OperationEnabled)
        {
            break;
        }
    }
    let mut ok = 0;
    for k in 0..10_000 {
        for m in models.iter_mut() {
            m.set_position(k * 7);
        }
        ok += u32::from(cycle(&mut layer, &mut models, true).is_ok());
    }
    println!("{ok} cycles ok of 10000");
}
