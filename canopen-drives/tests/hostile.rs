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

/// `cases` cases from a fixed seed, so that the test command checks the
/// same ones on every run (`PROPTEST_RNG_SEED=<n>` explores others, and
/// `CDPR_HOSTILE_SCALE=<k>` runs k times as many). From a random seed the
/// start-up campaign below met its defect in about one run in seven of
/// 96 cases; each found case is kept as a test of its own (`tests/layer.rs`).
fn campaign_config(cases: u32) -> ProptestConfig {
    let scale = std::env::var("CDPR_HOSTILE_SCALE").ok().and_then(|s| s.parse::<u32>().ok()).unwrap_or(1);
    let rng_seed = match ProptestConfig::default().rng_seed {
        proptest::test_runner::RngSeed::Random => proptest::test_runner::RngSeed::Fixed(20_261_207),
        chosen => chosen,
    };
    ProptestConfig {
        cases: cases.saturating_mul(scale.max(1)),
        rng_seed,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

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

/// 512 cases of 10-20 cycles with up to 12 random frames each.
#[test]
fn random_frames_change_nothing_off_the_drives_channels() {
    let config = campaign_config(512);
    let cases = config.cases;
    let mut runner = proptest::test_runner::TestRunner::new(config);
    let bursts = proptest::collection::vec(proptest::collection::vec(frame(), 0..12), 10..20);
    runner.run(&bursts, campaign).unwrap();
    let reached = REACHED.load(Ordering::Relaxed);
    println!("hostile frames: {reached} cases reached the asserts, {} ended in a fault of a drive sent something on its channels", FAULTED.load(Ordering::Relaxed));
    assert!(reached >= cases, "{reached} of {cases} cases reached the asserts");
}

static STARTUP_REACHED: AtomicU32 = AtomicU32::new(0);
static STARTUP_REFUSED: AtomicU32 = AtomicU32::new(0);

/// A frame on one of CAN1's drives' channels, or anywhere: SDO answers
/// that name a configuration object (a download's answer, an upload's, an
/// abort), boot-ups and other heartbeats, positions, statuswords,
/// emergencies, random frames.
fn startup_frame() -> impl Strategy<Value = (u16, Vec<u8>)> {
    let steps = canopen_drives::config::configuration(&configs()[0], &Timing::DEFAULT);
    let objects: Vec<(u16, u8)> = steps.iter().map(|s| s.object()).collect();
    let node = 1u16..=4;
    // Mostly drive 1's, mostly a download's answer: the answer the board
    // waits for, with the multiplexer of any step.
    let sdo_node = prop_oneof![3 => Just(1u16), 1 => 2u16..=4];
    let command = prop_oneof![4 => Just(0x60u8), 1 => Just(0x43u8), 1 => Just(0x4Bu8), 1 => Just(0x80u8), 1 => Just(0x30u8)];
    prop_oneof![
        3 => (sdo_node, proptest::sample::select(objects), command, any::<u32>())
            .prop_map(|(n, (index, sub), command, data)| {
                let [i0, i1] = index.to_le_bytes();
                let mut bytes = vec![command, i0, i1, sub];
                bytes.extend(data.to_le_bytes());
                (0x580 + n, bytes)
            }),
        1 => (node.clone(), proptest::sample::select(vec![0x00u8, 0x04, 0x05, 0x7F, 0x85])).prop_map(|(n, s)| (0x700 + n, vec![s])),
        1 => (node.clone(), proptest::sample::select(vec![0x080u16, 0x180, 0x280]), proptest::collection::vec(any::<u8>(), 0..=8))
            .prop_map(|(n, f, data)| (f + n, data)),
        1 => frame(),
    ]
}

/// Hostile frames during start-up, while the board configures its drives
/// by SDO, and drive 1 refusing the torque mode in half the cases: no
/// panic, no drive left half started; a drive that comes up was
/// configured as the board asked (its mode of operation, max torque and
/// heartbeat are the configuration's); drive 1 refusing the torque mode
/// never comes up; CAN2's drives, which saw no frame, come up; a fault
/// names a drive that was sent something on one of its channels (or
/// drive 1 refusing the mode). Before the layer compared an answer's
/// multiplexer with the object asked, an answer for the step before
/// completed the pending write: drive 1's abort of the torque mode was
/// then dropped and it ran in its default mode.
#[test]
fn hostile_frames_at_start_up_never_start_a_drive_the_board_did_not_configure() {
    let config = campaign_config(2000);
    let cases = config.cases;
    let mut runner = proptest::test_runner::TestRunner::new(config);
    let bursts = proptest::collection::vec(proptest::collection::vec(startup_frame(), 0..4), 5..40);
    runner
        .run(&(bursts, any::<bool>()), |(bursts, refuses)| {
            let (mut rig, mut layer) = SimRig::new(configs(), Timing::DEFAULT, None);
            rig.drive(0).faults.no_torque_mode = refuses;
            let inject = layer.ports().0.inject.clone();
            let mut readings = [WinchReading::default(); CABLES];
            let mut touched = [false; CABLES];
            for k in 0..400 {
                if let Some(burst) = bursts.get(k) {
                    for (id, data) in burst {
                        if let Some(d) = channel_of(*id) {
                            touched[d] = true;
                        }
                        inject.borrow_mut().push_back(SimFrame::standard(*id, data).unwrap());
                    }
                }
                rig.before_step();
                let r = layer.read(&mut readings);
                layer.set_brakes(true).unwrap();
                let w = layer.apply(&[0.0; CABLES]);
                rig.advance(1_000_000);
                if let Err(CanDrivesError::Fault(f)) = r.and(w) {
                    let d = usize::from(f.drive);
                    prop_assert!(touched[d] || (d == 0 && refuses), "{f:?} untouched");
                }
            }
            let timing = Timing::DEFAULT;
            for i in 0..CABLES {
                let node = layer.node(i).unwrap();
                if node.ready() {
                    let drive = rig.drive(i);
                    prop_assert_eq!(drive.mode(), 10, "drive {} up in mode {}", i, drive.mode());
                    prop_assert_eq!(drive.max_torque(), configs()[i].max_torque_permille());
                    prop_assert_eq!(drive.heartbeat_ms(), timing.heartbeat_ms);
                } else {
                    prop_assert!(
                        node.fault().is_some(),
                        "drive {i} neither up nor faulted: {:?}",
                        node.stage()
                    );
                }
            }
            prop_assert!(!(refuses && layer.node(0).unwrap().ready()), "drive 1 up without the torque mode");
            for i in 4..CABLES {
                prop_assert!(layer.node(i).unwrap().ready(), "CAN2's drive {i} not up");
            }
            if refuses {
                STARTUP_REFUSED.fetch_add(1, Ordering::Relaxed);
            }
            STARTUP_REACHED.fetch_add(1, Ordering::Relaxed);
            Ok(())
        })
        .unwrap();
    let reached = STARTUP_REACHED.load(Ordering::Relaxed);
    println!(
        "hostile frames at start-up: {reached} cases reached the asserts ({} with drive 1 refusing the torque mode)",
        STARTUP_REFUSED.load(Ordering::Relaxed)
    );
    assert!(reached >= cases, "{reached} of {cases} cases reached the asserts");
}
