//! The eight drives on two simulated buses with the board's
//! [`CanDrives`] on them, and the time: what the tests and `hal-sim` run.

use std::cell::{RefCell, RefMut};
use std::rc::Rc;

use cdpr_control::CABLES;

use super::{SimDrive, SimNetwork, SimPort};
use crate::config::{DriveConfig, Timing};
use crate::drives::{CanDrives, BUSES};
use crate::frame::RawFrame;

/// The board's drives on the simulated buses.
pub type SimCanDrives = CanDrives<SimPort, SimPort>;

/// The two buses, which drive of which bus each cable is, and the time.
#[derive(Debug)]
pub struct SimRig {
    /// CAN1 and CAN2.
    pub nets: [Rc<RefCell<SimNetwork>>; BUSES],
    /// Cable `i` is drive `place[i].1` of bus `place[i].0`.
    pub place: [(usize, usize); CABLES],
    /// The time, ns.
    pub now_ns: u64,
    /// When in a cycle the board's frames go out (the control step's
    /// length before its write), ns.
    pub step_ns: u64,
}

impl SimRig {
    /// The drives of `configs` (each with the rated torque its config
    /// says, unless `rated_mnm` gives another), powered at time 0, and the
    /// board's layer with `timing`.
    pub fn new(
        configs: [DriveConfig; CABLES],
        timing: Timing,
        rated_mnm: Option<[u32; CABLES]>,
    ) -> (Self, SimCanDrives) {
        let mut drives: [Vec<SimDrive>; BUSES] = [Vec::new(), Vec::new()];
        let mut place = [(0, 0); CABLES];
        for (i, c) in configs.iter().enumerate() {
            let bus = usize::from(c.bus).min(BUSES - 1);
            let rated = rated_mnm.map_or(libm::roundf(c.rated_torque * 1000.0) as u32, |r| r[i]);
            place[i] = (bus, drives[bus].len());
            drives[bus].push(SimDrive::new(c.node, rated));
        }
        let [d1, d2] = drives;
        let nets = [Rc::new(RefCell::new(SimNetwork::new(d1))), Rc::new(RefCell::new(SimNetwork::new(d2)))];
        let layer =
            CanDrives::new(SimPort::new(nets[0].clone()), SimPort::new(nets[1].clone()), configs, timing);
        (Self { nets, place, now_ns: 0, step_ns: 100_000 }, layer)
    }

    /// Cable `i`'s drive.
    pub fn drive(&self, i: usize) -> RefMut<'_, SimDrive> {
        let (bus, k) = self.place[i];
        RefMut::map(self.nets[bus].borrow_mut(), |n| &mut n.drives[k])
    }

    /// Cable `i`'s drive does `act` now (a fault, a reset): what it sends
    /// goes onto its bus at once.
    pub fn drive_sends(&mut self, i: usize, act: impl FnOnce(&mut SimDrive, u64, &mut Vec<RawFrame>)) {
        let (bus, k) = self.place[i];
        let now = self.now_ns;
        let mut out = Vec::new();
        act(&mut self.drive(i), now, &mut out);
        let mut net = self.net(bus);
        for f in out {
            net.bus.queue(k + 1, now, f);
        }
    }

    /// Cable `i`'s drive drops off its bus: it hears and sends nothing from
    /// now on, and what it had queued is lost.
    pub fn cut_off(&mut self, i: usize) {
        self.drive(i).faults.silent = true;
        let (bus, k) = self.place[i];
        self.net(bus).bus.drop_queue(k + 1);
    }

    /// Bus `bus`'s network.
    pub fn net(&self, bus: usize) -> RefMut<'_, SimNetwork> {
        self.nets[bus].borrow_mut()
    }

    /// Before the control step of the cycle starting now: the board's
    /// frames of this step go out `step_ns` into the cycle.
    pub fn before_step(&mut self) {
        let t = self.now_ns + self.step_ns;
        for n in &self.nets {
            n.borrow_mut().set_board_time(t);
        }
    }

    /// Runs both buses `dt_ns` on.
    pub fn advance(&mut self, dt_ns: u64) {
        self.now_ns += dt_ns;
        for n in &self.nets {
            n.borrow_mut().advance(self.now_ns);
        }
    }
}
