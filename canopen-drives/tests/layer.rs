//! The drive layer against the simulated CiA 402 drives on simulated
//! 1 Mbit/s buses: start-up, every CiA 402 transition, each fault and
//! timeout, garbage frames, the emergency stop's frames and the timing of
//! a cycle.

use canopen_drives::cia402::DriveState;
use canopen_drives::node::Stage;
use canopen_drives::sim::{Nmt, SimFrame, SimRig};
use canopen_drives::{emergency_frames, CanDrivesError, DriveConfig, RawFrame, Timing};
use cdpr_control::protocol::{DriveFault, DriveFaultCause};
use cdpr_control::{WinchDrives, WinchReading, CABLES};

const CYCLE_NS: u64 = 1_000_000;
const RATED: f32 = 0.64;
const TORQUE_MAX: f32 = 2.5;

fn configs() -> [DriveConfig; CABLES] {
    core::array::from_fn(|i| DriveConfig {
        bus: (i / 4) as u8,
        node: (i % 4 + 1) as u8,
        rated_torque: RATED,
        torque_max: TORQUE_MAX,
    })
}

struct Bench {
    rig: SimRig,
    layer: canopen_drives::sim::SimCanDrives,
    readings: [WinchReading; CABLES],
    brakes: bool,
    torques: [f32; CABLES],
}

impl Bench {
    fn new() -> Self {
        Self::with(None)
    }

    fn with(rated: Option<[u32; CABLES]>) -> Self {
        let (rig, layer) = SimRig::new(configs(), Timing::DEFAULT, rated);
        Self { rig, layer, readings: [WinchReading::default(); CABLES], brakes: true, torques: [0.0; CABLES] }
    }

    /// One control cycle: read, brakes, torques, then the buses run 1 ms.
    fn cycle(&mut self) -> Result<(), CanDrivesError> {
        self.rig.before_step();
        let read = self.layer.read(&mut self.readings);
        self.layer.set_brakes(self.brakes).unwrap();
        let write = self.layer.apply(&self.torques);
        self.rig.advance(CYCLE_NS);
        read.and(write)
    }

    /// Cycles until `done` holds (at most `limit`): how many it took.
    fn until(
        &mut self,
        limit: u32,
        mut done: impl FnMut(&mut Self, &Result<(), CanDrivesError>) -> bool,
    ) -> Option<u32> {
        for k in 1..=limit {
            let r = self.cycle();
            if done(self, &r) {
                return Some(k);
            }
        }
        None
    }

    fn started() -> Self {
        let mut b = Self::new();
        let took = b.until(200, |_, r| r.is_ok()).expect("every drive ready within 200 ms");
        assert!(took < 100, "start-up took {took} cycles");
        b
    }

    fn operating() -> Self {
        let mut b = Self::started();
        b.brakes = false;
        b.until(10, |b, r| {
            r.is_ok() && (0..CABLES).all(|i| b.rig.drive(i).state() == DriveState::OperationEnabled)
        })
        .expect("operation enabled within 10 cycles");
        // The statuswords of the transitions are through: steady cycles.
        for _ in 0..5 {
            b.cycle().unwrap();
        }
        b
    }

    fn fault(&mut self, limit: u32) -> (u32, DriveFault) {
        let mut found = None;
        let took = self.until(limit, |_, r| {
            if let Err(CanDrivesError::Fault(f)) = r {
                found = Some(*f);
                true
            } else {
                false
            }
        });
        (took.expect("a fault"), found.expect("a fault"))
    }
}

#[test]
fn start_up_configures_every_drive_and_then_reads_it() {
    let mut b = Bench::new();
    for i in 0..CABLES {
        b.rig.drive(i).set_position(1000 * i as i32 - 3000);
    }
    // Until then each read names a drive that is not ready.
    let r = b.cycle();
    assert!(matches!(r, Err(CanDrivesError::NotReady { .. })), "{r:?}");
    let took = b.until(200, |_, r| r.is_ok()).expect("ready");
    println!("start-up: {} cycles", took + 1);
    for i in 0..CABLES {
        let d = b.rig.drive(i);
        assert_eq!(d.nmt(), Nmt::Operational, "drive {i}");
        assert_eq!(d.mode(), 10, "cyclic synchronous torque");
        assert_eq!(d.heartbeat_ms(), 100);
        // 2.5 N m of 0.64 N m rated: 3906.25 thousandths, rounded up.
        assert_eq!(d.max_torque(), 3907);
        assert_eq!(d.state(), DriveState::SwitchedOn);
        assert!(d.brake_engaged());
        assert_eq!(b.readings[i].counts, 1000 * i as i32 - 3000);
    }
    assert_eq!(b.layer.counters().garbage, 0);
    assert_eq!(b.layer.counters().unknown, 0);
}

#[test]
fn released_brakes_enable_operation_and_the_torques_reach_the_drives_in_the_cycle() {
    let mut b = Bench::started();
    b.brakes = false;
    b.torques = core::array::from_fn(|i| 0.1 * i as f32 - 0.3);
    // One drive per bus a cycle (`ENABLES_PER_CYCLE`): its controlword goes
    // out before the torques; it is enabled and takes the torque on receipt
    // (RPDO1 type 255), while the bus's drives not yet enabled keep their
    // brakes. Four drives per bus: all enabled in four cycles.
    assert_eq!(canopen_drives::ENABLES_PER_CYCLE, 1);
    for k in 1..=4 {
        b.cycle().unwrap();
        for i in 0..CABLES {
            let d = b.rig.drive(i);
            if i % 4 < k {
                assert_eq!(d.state(), DriveState::OperationEnabled, "drive {i} after {k} cycles");
                assert!(!d.brake_engaged());
                let expected = (b.torques[i] * 1000.0 / RATED).round() as i16;
                assert_eq!(d.target_torque(), expected);
                assert!(
                    (d.torque_nm(b.rig.now_ns) - f64::from(b.torques[i])).abs()
                        <= f64::from(RATED) / 2000.0 + 1e-9
                );
            } else {
                assert_eq!(d.state(), DriveState::SwitchedOn, "drive {i} after {k} cycles");
                assert!(d.brake_engaged());
            }
        }
    }
    b.cycle().unwrap();
    // Brakes engaged: "switched on", no torque.
    b.brakes = true;
    b.cycle().unwrap();
    for i in 0..CABLES {
        let d = b.rig.drive(i);
        assert_eq!(d.state(), DriveState::SwitchedOn);
        assert!(d.brake_engaged());
        assert_eq!(d.torque_nm(b.rig.now_ns + canopen_drives::sim::SimDrive::BRAKE_DELAY_NS), 0.0);
    }
    b.cycle().unwrap();
    assert!(b.layer.ready());
}

#[test]
fn a_torque_beyond_the_limit_or_not_finite_is_not_sent() {
    let c = configs()[0];
    assert_eq!(c.permille(0.64), 1000);
    assert_eq!(c.permille(-0.32), -500);
    assert_eq!(c.permille(99.0), 3907);
    assert_eq!(c.permille(f32::NAN), 0);
    assert_eq!(c.permille(f32::INFINITY), 0);
}

#[test]
fn the_speed_comes_from_two_positions_and_survives_a_missed_one() {
    let mut b = Bench::operating();
    let mut p = 0i32;
    for _ in 0..5 {
        p = p.wrapping_add(50);
        for i in 0..CABLES {
            b.rig.drive(i).set_position(p);
        }
        b.cycle().unwrap();
    }
    // A read has the positions of the SYNC one cycle before.
    assert_eq!(b.readings[0].counts, p - 50);
    assert_eq!(b.readings[0].counts_per_second, 50_000);
    // The positions wrap at 2^31: the difference does not jump.
    for i in 0..CABLES {
        b.rig.drive(i).set_position(i32::MAX - 10);
    }
    b.cycle().unwrap();
    for i in 0..CABLES {
        b.rig.drive(i).set_position((i32::MAX - 10).wrapping_add(30));
    }
    b.cycle().unwrap();
    b.cycle().unwrap();
    assert_eq!(b.readings[3].counts, i32::MIN + 19);
    assert_eq!(b.readings[3].counts_per_second, 30_000);
    // One SYNC without a position (below the limit): the next speed is
    // over the two cycles.
    b.rig.drive(2).faults.no_tpdo = true;
    b.rig.drive(2).set_position((i32::MAX - 10).wrapping_add(130));
    b.cycle().unwrap();
    b.rig.drive(2).faults.no_tpdo = false;
    b.cycle().unwrap();
    b.cycle().unwrap();
    assert_eq!(b.readings[2].counts_per_second, 50_000, "100 counts over 2 ms");
}

#[test]
fn a_drive_that_never_boots_keeps_the_board_out_and_is_named() {
    let mut b = Bench::new();
    // Its power-on boot-up never goes out either.
    b.rig.cut_off(5);
    for _ in 0..300 {
        b.cycle().unwrap_err();
    }
    assert_eq!(b.cycle(), Err(CanDrivesError::NotReady { drive: 5, stage: Stage::WaitBoot }));
    let (took, f) = b.fault(2000);
    assert_eq!(f, DriveFault { drive: 5, cause: DriveFaultCause::NoAnswer, code: 0 });
    assert_eq!(took + 301, Timing::DEFAULT.boot_cycles + 2, "boot-up timeout");
    assert!(b.layer.node(0).unwrap().ready(), "the other drives are up");
    // Powered later: ClearFault restarts it and it comes up.
    b.rig.drive(5).faults.silent = false;
    b.layer.clear_faults();
    b.until(200, |_, r| r.is_ok()).expect("up after the restart");
}

#[test]
fn sdo_timeouts_and_aborts_are_configuration_faults() {
    // No answer: one retry, then NoAnswer with the object's index.
    let mut b = Bench::new();
    b.rig.drive(1).faults.ignore_sdo = true;
    let (took, f) = b.fault(200);
    assert_eq!(f, DriveFault { drive: 1, cause: DriveFaultCause::NoAnswer, code: 0x1017 });
    assert!(took > 2 * Timing::DEFAULT.sdo_cycles && took < 2 * Timing::DEFAULT.sdo_cycles + 10, "{took}");
    // A drive without the torque mode aborts the write of 0x6060.
    let mut b = Bench::new();
    b.rig.drive(6).faults.no_torque_mode = true;
    let (_, f) = b.fault(200);
    assert_eq!(f, DriveFault { drive: 6, cause: DriveFaultCause::Configuration, code: 0x0609_0030 });
    // A rated torque other than the robot file's.
    let mut rated = [640u32; CABLES];
    rated[4] = 1270;
    let mut b = Bench::with(Some(rated));
    let (_, f) = b.fault(200);
    assert_eq!(f, DriveFault { drive: 4, cause: DriveFaultCause::Configuration, code: 0x6076 });
    assert_ne!(b.rig.drive(4).nmt(), Nmt::Operational, "never started");
}

/// An answer that completes the pending request before the drive's own
/// (a stranger on drive 1's SDO channel, or a second drive at its node
/// id) no longer starts a drive the board did not configure: found by the
/// hostile start-up campaign (`tests/hostile.rs`) from a random seed, one
/// run in about seven: an acknowledgement of 0x6060 at cycle 4 completed
/// the torque mode's write, the drive's abort then arrived for a step
/// already done and was dropped, and drive 1 came up in mode 0. Now the
/// drive's second, contradicting answer (an abort of an object already
/// written, a read with another value than the one taken) faults it,
/// with its code; and the configuration reads back the mode the drive
/// runs in (0x6061), which catches a drive that acknowledges the mode
/// and stays in its own. Duplicates of what was taken change nothing.
#[test]
fn a_strangers_answer_ahead_of_the_drives_own_never_starts_a_misconfigured_drive() {
    // A download acknowledgement of (index, sub), sent to the board from
    // drive 1's node every cycle of the start-up, ahead of the drive's
    // own answers.
    let forged_ack = |index: u16, sub: u8| {
        let [i0, i1] = index.to_le_bytes();
        [0x60, i0, i1, sub, 0, 0, 0, 0]
    };
    // An expedited upload's answer of `bytes` bytes (0x4F: 1, 0x43: 4).
    let forged_upload = |index: u16, value: u32, bytes: u8| {
        let [i0, i1] = index.to_le_bytes();
        let [v0, v1, v2, v3] = value.to_le_bytes();
        [0x43 | ((4 - bytes) << 2), i0, i1, 0, v0, v1, v2, v3]
    };
    let run = |b: &mut Bench, forged: [u8; 8]| {
        let inject = b.layer.ports().0.inject.clone();
        for _ in 0..300 {
            inject.borrow_mut().push_back(SimFrame::standard(0x581, &forged).unwrap());
            let _ = b.cycle();
        }
        (b.layer.node(0).unwrap().ready(), b.layer.node(0).unwrap().fault())
    };
    let configuration = |code| Some((DriveFaultCause::Configuration, code));
    let mut cases = 0;
    // The torque mode refused, its acknowledgement forged: the abort
    // that follows faults the drive (it came up in mode 0).
    let mut b = Bench::new();
    b.rig.drive(0).faults.no_torque_mode = true;
    assert_eq!(run(&mut b, forged_ack(0x6060, 0)), (false, configuration(0x0609_0030)));
    assert_eq!(b.rig.drive(0).mode(), 0);
    cases += 1;
    // The max torque (the drive's own torque limit) refused, likewise.
    let mut b = Bench::new();
    b.rig.drive(0).faults.refuse_write = Some((0x6072, 0));
    assert_eq!(run(&mut b, forged_ack(0x6072, 0)), (false, configuration(0x0609_0030)));
    cases += 1;
    // The RPDO timeout (a drive that hears no board quick stops) refused.
    let mut b = Bench::new();
    b.rig.drive(0).faults.refuse_write = Some((0x1400, 5));
    assert_eq!(run(&mut b, forged_ack(0x1400, 5)), (false, configuration(0x0609_0030)));
    cases += 1;
    // The rated torque read: a stranger's right value ahead of the
    // drive's other one (a motor of twice the torque).
    let mut rated = [640u32; CABLES];
    rated[0] = 1280;
    let mut b = Bench::with(Some(rated));
    assert_eq!(run(&mut b, forged_upload(0x6076, 640, 4)), (false, configuration(0x6076)));
    cases += 1;
    // A drive that acknowledges the torque mode and stays in its own: the
    // mode read back.
    let mut b = Bench::new();
    b.rig.drive(0).faults.mode_unapplied = true;
    assert_eq!(run(&mut b, [0; 8]), (false, configuration(0x6061)));
    cases += 1;
    // Duplicates of the drive's own answers: it comes up, configured.
    for forged in [
        forged_ack(0x6060, 0),
        forged_ack(0x6072, 0),
        forged_upload(0x6076, 640, 4),
        forged_upload(0x6061, 10, 1),
    ] {
        let mut b = Bench::new();
        assert_eq!(run(&mut b, forged), (true, None), "{forged:?}");
        assert_eq!(b.rig.drive(0).mode(), 10);
        assert_eq!(b.rig.drive(0).max_torque(), configs()[0].max_torque_permille());
        cases += 1;
    }
    assert_eq!(cases, 9);
}

#[test]
fn an_emcy_mid_operation_faults_and_a_fault_reset_brings_the_drive_back() {
    let mut b = Bench::operating();
    b.rig.drive_sends(3, |d, _, out| d.fail(0x2310, out));
    let (took, f) = b.fault(5);
    assert_eq!(f, DriveFault { drive: 3, cause: DriveFaultCause::Emergency, code: 0x2310 });
    // Raised at a cycle's start: its EMCY is on the bus in that cycle and
    // read at the next one.
    assert_eq!(took, 2);
    assert!(b.rig.drive(3).brake_engaged());
    // Brakes on (the supervisor's Fault), then ClearFault.
    b.brakes = true;
    b.cycle().unwrap_err();
    b.layer.clear_faults();
    b.until(20, |_, r| r.is_ok()).expect("the drive is back after its fault reset");
    assert_eq!(b.rig.drive(3).state(), DriveState::SwitchedOn);
}

#[test]
fn a_statusword_fault_without_emcy_is_a_state_fault() {
    let mut b = Bench::operating();
    {
        let mut out = Vec::new();
        b.rig.drive(0).fail(0x4310, &mut out);
        // The EMCY is lost; the statusword is not.
    }
    let (_, f) = b.fault(5);
    assert_eq!(f.drive, 0);
    assert_eq!(f.cause, DriveFaultCause::StateFault);
    assert_eq!(f.code, u32::from(DriveState::Fault.statusword()));
}

#[test]
fn positions_that_stop_coming_are_a_missing_pdo_after_three_syncs() {
    let mut b = Bench::operating();
    b.rig.drive(7).faults.no_tpdo = true;
    let (took, f) = b.fault(10);
    assert_eq!(f, DriveFault { drive: 7, cause: DriveFaultCause::MissingPdo, code: 3 });
    assert_eq!(took, Timing::DEFAULT.missing_pdo_cycles + 1);
}

#[test]
fn a_drive_dropping_off_the_bus_is_caught_by_its_missing_positions() {
    let mut b = Bench::operating();
    b.rig.drive(2).faults.silent = true;
    let (took, f) = b.fault(10);
    assert_eq!((f.drive, f.cause), (2, DriveFaultCause::MissingPdo));
    assert!(took <= 4, "{took} cycles");
}

#[test]
fn heartbeats_that_stop_or_say_another_state_are_heartbeat_faults() {
    let mut b = Bench::operating();
    b.rig.drive(4).faults.no_heartbeat = true;
    let (took, f) = b.fault(400);
    assert_eq!(f, DriveFault { drive: 4, cause: DriveFaultCause::Heartbeat, code: 0xFFFF });
    assert!((150..=252).contains(&took), "{took}");
    // A drive that resets (its boot-up mid-operation).
    let mut b = Bench::operating();
    b.rig.drive_sends(1, |d, now, out| d.power_on(now, out));
    let (_, f) = b.fault(5);
    assert_eq!((f.drive, f.cause, f.code), (1, DriveFaultCause::Heartbeat, 0));
}

#[test]
fn a_drive_that_leaves_operation_by_itself_or_never_gets_there_is_state_lost() {
    // Stuck: the enable transition times out.
    let mut b = Bench::started();
    b.rig.drive(6).faults.stuck_state = true;
    b.brakes = false;
    let (took, f) = b.fault(100);
    assert_eq!((f.drive, f.cause), (6, DriveFaultCause::StateLost));
    assert_eq!(f.code, u32::from(DriveState::SwitchedOn.statusword()));
    // Drive 6 is the third of its bus to be sent "enable operation" (one a
    // cycle): two cycles later than the first.
    assert_eq!(took, Timing::DEFAULT.transition_cycles + 2 + 2);
    // Enabled, then an NMT "stop" from elsewhere quick stops it (0x6007):
    // "operation enabled" lost.
    let mut b = Bench::operating();
    b.rig.net(1).bus.queue(0, b.rig.now_ns, RawFrame::new(0, &[0x80, 2]));
    let (_, f) = b.fault(5);
    // Node 2 of CAN2 is cable 5; pre-operational heartbeat or lost state,
    // whichever shows first.
    assert_eq!(f.drive, 5);
    assert!(matches!(f.cause, DriveFaultCause::StateLost | DriveFaultCause::MissingPdo), "{f:?}");
}

#[test]
fn a_bus_off_faults_the_drives_of_that_bus() {
    let mut b = Bench::operating();
    b.rig.net(1).bus_off = true;
    let (took, f) = b.fault(3);
    assert_eq!(took, 1);
    assert_eq!(f, DriveFault { drive: 4, cause: DriveFaultCause::BusOff, code: 2 });
    for i in 4..CABLES {
        assert_eq!(b.layer.node(i).unwrap().fault(), Some((DriveFaultCause::BusOff, 2)));
    }
    assert_eq!(b.layer.node(0).unwrap().fault(), None);
}

#[test]
fn garbage_frames_are_counted_and_change_nothing() {
    let mut b = Bench::operating();
    let port = b.layer.ports().0.inject.clone();
    let garbage = [
        SimFrame::standard(0x181, &[1, 2]).unwrap(), // TPDO1, wrong length
        SimFrame::standard(0x281, &[1, 2, 3]).unwrap(), // TPDO2, wrong length
        SimFrame::standard(0x701, &[]).unwrap(),     // heartbeat, no byte
        SimFrame::standard(0x581, &[0x60, 0, 0, 0, 0, 0, 0, 0]).unwrap(), // an SDO answer nobody asked for
        SimFrame::standard(0x081, &[0, 0]).unwrap(), // EMCY, wrong length
        SimFrame::standard(0x18A, &[0, 0, 0, 0]).unwrap(), // node 10: not here
        SimFrame::standard(0x7E5, &[1]).unwrap(),    // LSS: not used
        SimFrame::standard(0x201, &[0, 0]).unwrap(), // an RPDO: the board's own kind
        SimFrame::extended(0x181, &[0, 0, 0, 0]).unwrap(), // extended id
    ];
    for f in garbage {
        port.borrow_mut().push_back(f);
    }
    *b.layer.ports().0.overruns.borrow_mut() = 2;
    // A heartbeat with the toggle bit (node guarding's bit 7) is operational.
    port.borrow_mut().push_back(SimFrame::standard(0x702, &[0x85]).unwrap());
    let before = b.readings;
    b.cycle().unwrap();
    let c = *b.layer.counters();
    assert_eq!(c.garbage, 5, "{c:?}");
    assert_eq!(c.unknown, 4, "{c:?}");
    assert_eq!(c.receive_errors, 2);
    assert_eq!(b.readings, before, "the readings are the drives'");
    for _ in 0..10 {
        b.cycle().unwrap();
    }
}

/// Drive 0's configuration step pending after at least `from` steps, and
/// the object (index, sub-index) it writes or reads.
fn pending_step(b: &mut Bench, from: u8) -> (u8, (u16, u8)) {
    b.until(20, |b, _| matches!(b.layer.node(0).unwrap().stage(), Stage::Configure(s) if s >= from)).unwrap();
    let Stage::Configure(step) = b.layer.node(0).unwrap().stage() else { unreachable!() };
    let steps = canopen_drives::config::configuration(&configs()[0], &Timing::DEFAULT);
    (step, steps[usize::from(step)].object())
}

/// An SDO answer's 8 bytes: command specifier, multiplexer, data.
fn sdo_answer(command: u8, (index, sub): (u16, u8), data: u32) -> SimFrame {
    let [i0, i1] = index.to_le_bytes();
    let [d0, d1, d2, d3] = data.to_le_bytes();
    SimFrame::standard(0x581, &[command, i0, i1, sub, d0, d1, d2, d3]).unwrap()
}

/// Answers on drive 0's SDO channel that name another object than the one
/// asked for: the late answer to the request before (sent again after its
/// timeout, both answers come), an abort of another transfer, a
/// download-segment answer (no multiplexer). Each is dropped as garbage
/// and the request waits for its own answer. Taken (as `canopen-rs`'s
/// client alone takes them), the late answer completed the pending write
/// before the drive answered it, and the drive's own answer, coming when
/// nothing was pending, was dropped: a drive without the torque mode,
/// which aborts the write of its mode of operation (0x6060), was started
/// and run as if in cyclic synchronous torque mode.
#[test]
fn an_sdo_answer_for_another_object_is_dropped_and_the_drives_own_answer_counts() {
    for refuses_torque_mode in [false, true] {
        let mut b = Bench::new();
        b.rig.drive(0).faults.no_torque_mode = refuses_torque_mode;
        let port = b.layer.ports().0.inject.clone();
        let (step, object) = pending_step(&mut b, 2);
        assert_eq!(object, (0x6060, 0), "the mode of operation's write pending");
        let steps = canopen_drives::config::configuration(&configs()[0], &Timing::DEFAULT);
        let before = steps[usize::from(step) - 1].object();
        let garbage = b.layer.counters().garbage;
        port.borrow_mut().push_back(sdo_answer(0x60, before, 0));
        port.borrow_mut().push_back(sdo_answer(0x80, (0x1000, 0), 0x0602_0000));
        port.borrow_mut().push_back(SimFrame::standard(0x581, &[0x30, 0, 0, 0, 0, 0, 0, 0]).unwrap());
        if refuses_torque_mode {
            let (_, f) = b.fault(5);
            assert_eq!(f, DriveFault { drive: 0, cause: DriveFaultCause::Configuration, code: 0x0609_0030 });
            assert_ne!(b.rig.drive(0).nmt(), Nmt::Operational, "never started");
        } else {
            b.until(100, |b, r| r.is_ok() && b.layer.node(0).unwrap().ready()).expect("drive 0 up");
            assert_eq!(b.layer.node(0).unwrap().fault(), None);
            assert_eq!(b.rig.drive(0).mode(), 10);
        }
        assert_eq!(b.layer.counters().garbage - garbage, 3, "{:?}", b.layer.counters());
    }
}

/// An answer that names the pending object but is not the answer to its
/// request (an upload's answer to a download): the transfer is refused,
/// typed; the other drives go on.
#[test]
fn an_sdo_answer_out_of_sequence_at_start_up_is_a_configuration_fault() {
    let mut b = Bench::new();
    let port = b.layer.ports().0.inject.clone();
    let (_, object) = pending_step(&mut b, 2);
    port.borrow_mut().push_back(sdo_answer(0x43, object, 0));
    let (_, f) = b.fault(5);
    assert_eq!((f.drive, f.cause), (0, DriveFaultCause::Configuration), "{f:?}");
    b.until(100, |b, _| b.layer.node(1).unwrap().ready()).expect("drive 1 up");
}

/// An abort of the pending transfer is a configuration fault with its code.
#[test]
fn an_sdo_abort_of_the_pending_write_is_a_configuration_fault_with_its_code() {
    let mut b = Bench::new();
    let port = b.layer.ports().0.inject.clone();
    let (_, object) = pending_step(&mut b, 3);
    port.borrow_mut().push_back(sdo_answer(0x80, object, 0x0609_0030));
    let (_, f) = b.fault(5);
    assert_eq!((f.drive, f.cause, f.code), (0, DriveFaultCause::Configuration, 0x0609_0030), "{f:?}");
}

#[test]
fn the_emergency_frames_quick_stop_then_zero_then_sync_then_nmt() {
    let mut out = [RawFrame::new(0, &[]); 16];
    let n = emergency_frames(&configs(), 1, &mut out);
    assert_eq!(n, 10);
    let ids: Vec<u16> = out[..n].iter().map(|f| f.id).collect();
    assert_eq!(ids, vec![0x301, 0x201, 0x302, 0x202, 0x303, 0x203, 0x304, 0x204, 0x080, 0x000]);
    assert_eq!(out[0].bytes(), &[0x02, 0x00]);
    assert_eq!(out[1].bytes(), &[0, 0]);
    assert_eq!(out[9].bytes(), &[0x80, 0]);
    // They stop operating drives: quick stop, brake engaged, no torque.
    let mut b = Bench::operating();
    for f in &out[..n] {
        b.rig.net(1).bus.queue(0, b.rig.now_ns, *f);
    }
    // 10 frames and the drives' answers (their statuswords change): about
    // 1.4 ms on the bus.
    b.rig.advance(2 * CYCLE_NS);
    for i in 4..CABLES {
        let d = b.rig.drive(i);
        assert_eq!(d.state(), DriveState::SwitchOnDisabled);
        assert!(d.brake_engaged());
        assert_eq!(d.torque_nm(b.rig.now_ns + canopen_drives::sim::SimDrive::BRAKE_DELAY_NS), 0.0);
        assert_eq!(d.nmt(), Nmt::PreOperational);
    }
    // A buffer too small takes what fits.
    assert_eq!(emergency_frames(&configs(), 0, &mut out[..3]), 3);
}

#[test]
fn drives_that_hear_no_board_quick_stop_by_themselves() {
    // The board stops (a hang, a reset, its bus cut): no RPDO for 5 ms.
    let mut b = Bench::operating();
    let mut at = None;
    for ms in 1..=20u32 {
        b.rig.advance(CYCLE_NS);
        if at.is_none() && (0..CABLES).all(|i| b.rig.drive(i).brake_engaged()) {
            at = Some(ms);
        }
    }
    let at = at.expect("every brake engaged");
    println!("without the board, every drive quick stopped within {at} ms");
    assert!(at <= u32::from(Timing::DEFAULT.rpdo_timeout_ms) + 1, "{at} ms");
    for i in 0..CABLES {
        let d = b.rig.drive(i);
        assert_eq!(d.state(), DriveState::SwitchOnDisabled);
        assert_eq!(d.rpdo_timeouts, 1);
        assert_eq!(d.torque_nm(b.rig.now_ns + canopen_drives::sim::SimDrive::BRAKE_DELAY_NS), 0.0);
    }
    // The board hears the EMCYs (0x8250, RPDO timeout) when it is back.
    let (_, f) = b.fault(2);
    assert_eq!((f.cause, f.code), (DriveFaultCause::Emergency, 0x8250));
}

/// The cycle on a bus, from the bus's log: the RPDOs, then the SYNC, then
/// the positions, all within the 1 ms; the bus load.
/// A fifth drive on a bus is what `check_layout` refuses (a robot file
/// with all eight on CAN1 was accepted and its drives never came up: found
/// with `hal-sim --robot`). On the simulated buses (the step's frames 0.1 ms
/// into the cycle): four drives a bus come up and each cycle's positions
/// are back before the next read; with five on CAN1 the fifth position
/// comes back after it, every cycle (read a cycle late: the loop's delay
/// is not the one its PID predicts over, and the bus is 92 % busy); with
/// eight the drives never come up.
#[test]
fn a_fifth_drive_on_a_bus_is_refused_as_the_bus_cannot_serve_it() {
    let layout = |on_can1: usize| -> [DriveConfig; CABLES] {
        core::array::from_fn(|i| {
            let (bus, node) = if i < on_can1 { (0, i + 1) } else { (1, i - on_can1 + 1) };
            DriveConfig { bus: bus as u8, node: node as u8, ..configs()[i] }
        })
    };
    let mut outcomes = Vec::new();
    for on_can1 in [4, 5, 8] {
        let configs = layout(on_can1);
        let buses = configs.map(|c| c.bus);
        let refused = canopen_drives::check_layout(&buses).is_err();
        let (rig, layer) = SimRig::new(configs, Timing::DEFAULT, None);
        let mut b = Bench {
            rig,
            layer,
            readings: [WinchReading::default(); CABLES],
            brakes: true,
            torques: [0.0; CABLES],
        };
        let ready_after = b.until(500, |_, r| r.is_ok());
        // Once ready: 20 steady cycles, then CAN1's last position of a
        // cycle, from the cycle's start (the next read is at 1 ms).
        let mut last_position = None;
        if ready_after.is_some() {
            for _ in 0..20 {
                b.cycle().unwrap();
            }
            b.rig.net(0).bus.logging = true;
            let start = b.rig.now_ns;
            for _ in 0..3 {
                b.cycle().unwrap();
            }
            let net = b.rig.net(0);
            let sync = net.bus.log.iter().find(|(s, _, _, f)| *s >= start && f.id == 0x080).map(|l| l.1);
            let sync = sync.expect("a SYNC in the cycle");
            last_position = net
                .bus
                .log
                .iter()
                .filter(|(s, _, _, f)| *s > sync && (0x181..=0x188).contains(&f.id))
                .take(on_can1)
                .map(|l| l.1 - start)
                .max();
        }
        outcomes.push((on_can1, refused, ready_after, last_position));
    }
    println!(
        "drives on CAN1, refused, ready after cycles, CAN1's last position of a cycle (ns): {outcomes:?}"
    );
    assert!(matches!(outcomes[0], (4, false, Some(n), Some(t)) if n < 100 && t < CYCLE_NS), "{outcomes:?}");
    assert!(matches!(outcomes[1], (5, true, Some(_), Some(t)) if t > CYCLE_NS), "{outcomes:?}");
    assert!(matches!(outcomes[2], (8, true, None, None)), "{outcomes:?}");
}

#[test]
fn one_cycle_fits_the_bus_with_room() {
    let mut b = Bench::operating();
    for _ in 0..200 {
        b.cycle().unwrap();
    }
    b.rig.net(0).bus.logging = true;
    let bits0 = b.rig.net(0).bus.busy_bits();
    let t0 = b.rig.now_ns;
    let cycles = 1000u64;
    for _ in 0..cycles {
        b.cycle().unwrap();
    }
    let net = b.rig.net(0);
    let load = (net.bus.busy_bits() - bits0) as f64 * net.bus.bit_ns as f64 / (cycles * CYCLE_NS) as f64;
    println!("CAN1 load over {cycles} cycles (worst-case stuffing): {:.1} %", 100.0 * load);
    assert!(load < 0.80, "{load}");
    // One cycle's frames.
    let cycle: Vec<_> = net
        .bus
        .log
        .iter()
        .filter(|(s, _, _, _)| *s >= t0 + 500 * CYCLE_NS && *s < t0 + 501 * CYCLE_NS)
        .collect();
    let ids: Vec<u16> = cycle.iter().map(|(_, _, _, f)| f.id).collect();
    println!(
        "one cycle on CAN1: {:?}",
        cycle.iter().map(|(s, e, _, f)| (f.id, (s - t0) % CYCLE_NS, (e - t0) % CYCLE_NS)).collect::<Vec<_>>()
    );
    assert_eq!(&ids[..5], &[0x201, 0x202, 0x203, 0x204, 0x080], "RPDOs, then the SYNC");
    assert_eq!(&ids[5..9], &[0x181, 0x182, 0x183, 0x184], "the positions, in arbitration order");
    let last_position_end = cycle[8].1 - (t0 + 500 * CYCLE_NS);
    let sync_end = cycle[4].1 - (t0 + 500 * CYCLE_NS);
    println!(
        "SYNC at {sync_end} ns, last position in at {last_position_end} ns: age at the next read {} ns",
        CYCLE_NS - sync_end
    );
    assert!(last_position_end < 900_000, "positions in before the next step");
}
