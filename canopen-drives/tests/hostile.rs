//! Hostile frames on the board's bus while the drives operate: random
//! identifiers, lengths and bytes slipped in ahead of the drives' own.
//! Nothing panics or stops the cycle; a frame on no drive's channel
//! changes nothing; a fault names a drive that was sent something on one
//! of its channels. The campaign counts the cases that reached the
//! asserts.

use std::sync::atomic::{AtomicU32, Ordering};

use canopen_drives::cia402::DriveState;
use canopen_drives::sim::{SimFrame, SimRig};
use canopen_drives::{CanDrivesError, DriveConfig, Timing};
use cdpr_control::{WinchDrives, WinchReading, CABLES};
use proptest::prelude::*;

static REACHED: AtomicU32 = AtomicU32::new(0);
static FAULTED: AtomicU32 = AtomicU32::new(0);

fn configs() -> [DriveConfig; CABLES] {
    core::array::from_fn(|i| DriveConfig {
        bus: (i / 4) as u8,
        node: (i % 4 + 1) as u8,
        rated_torque: 0.64,
        torque_max: 2.5,
    })
}

/// The drive (cable) of CAN1 whose channels `id` is: EMCY, TPDO1, TPDO2,
/// SDO answer, heartbeat of nodes 1-4.
fn channel_of(id: u16) -> Option<usize> {
    let node = usize::from(id & 0x7F);
    let function = id & 0x780;
    (matches!(function, 0x080 | 0x180 | 0x280 | 0x580 | 0x700) && (1..=4).contains(&node)).then(|| node - 1)
}

fn frame() -> impl Strategy<Value = (u16, Vec<u8>)> {
    (0u16..0x800, proptest::collection::vec(any::<u8>(), 0..=8))
}

fn campaign(bursts: Vec<Vec<(u16, Vec<u8>)>>) -> Result<(), TestCaseError> {
    let (mut rig, mut layer) = SimRig::new(configs(), Timing::DEFAULT, None);
    let mut readings = [WinchReading::default(); CABLES];
    let cycle = |rig: &mut SimRig,
                 layer: &mut canopen_drives::sim::SimCanDrives,
                 brakes: bool,
                 readings: &mut [WinchReading; CABLES]| {
        rig.before_step();
        let r = layer.read(readings);
        layer.set_brakes(brakes).unwrap();
        let w = layer.apply(&[0.1; CABLES]);
        rig.advance(1_000_000);
        r.and(w)
    };
    let mut up = false;
    for _ in 0..200 {
        if cycle(&mut rig, &mut layer, false, &mut readings).is_ok()
            && (0..CABLES).all(|i| rig.drive(i).state() == DriveState::OperationEnabled)
        {
            up = true;
            break;
        }
    }
    prop_assert!(up);
    let inject = layer.ports().0.inject.clone();
    let mut touched = [false; CABLES];
    for burst in &bursts {
        for (id, data) in burst {
            if let Some(d) = channel_of(*id) {
                touched[d] = true;
            }
            inject.borrow_mut().push_back(SimFrame::standard(*id, data).unwrap());
        }
        match cycle(&mut rig, &mut layer, false, &mut readings) {
            Ok(()) => {}
            Err(CanDrivesError::Fault(f)) => {
                FAULTED.fetch_add(1, Ordering::Relaxed);
                prop_assert!(touched[usize::from(f.drive)], "{f:?} with no frame on its channels");
                break;
            }
            // A reading not ready (a statusword slipped in that is not
            // "switched on" or "operation enabled") only for a drive
            // that was sent one.
            Err(CanDrivesError::NotReady { drive, .. }) => {
                prop_assert!(touched[usize::from(drive)], "drive {drive} not ready untouched");
            }
            Err(e) => prop_assert!(false, "{e:?}"),
        }
    }
    // The CAN2 drives never saw a frame: they run on.
    for i in 4..CABLES {
        prop_assert!(layer.node(i).unwrap().ready());
    }
    REACHED.fetch_add(1, Ordering::Relaxed);
    Ok(())
}

/// 64 cases of 10-20 cycles with up to 12 random frames each.
#[test]
fn random_frames_change_nothing_off_the_drives_channels() {
    let cases = 64;
    let mut runner =
        proptest::test_runner::TestRunner::new(ProptestConfig { cases, ..ProptestConfig::default() });
    let bursts = proptest::collection::vec(proptest::collection::vec(frame(), 0..12), 10..20);
    runner.run(&bursts, campaign).unwrap();
    let reached = REACHED.load(Ordering::Relaxed);
    println!("hostile frames: {reached} cases reached the asserts, {} ended in a fault of a drive sent something on its channels", FAULTED.load(Ordering::Relaxed));
    assert!(reached >= cases, "{reached} of {cases} cases reached the asserts");
}
