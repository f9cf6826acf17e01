//! The board's drive layer ([`CanDrives`]) on two [`LoopbackPort`]s with a
//! [`SimDrive`] per cable, `no_std`: what the QEMU demo's measured step
//! drives (its frames looped back in memory, the models answering between
//! steps) and what it times the layer alone with.

use cdpr_control::{WinchDrives, CABLES};

use super::{LoopbackPort, Ring, SimDrive};
use crate::cia402::DriveState;
use crate::config::{DriveConfig, Timing};
use crate::drives::CanDrives;

/// The drive layer on the loopback ports.
pub type LoopbackDrives = CanDrives<LoopbackPort, LoopbackPort>;

/// The layer, the eight drive models in bus order and the time.
#[derive(Debug)]
pub struct LoopbackRig {
    /// The board's layer (its `WinchDrives` is what a control loop uses).
    pub layer: LoopbackDrives,
    /// The models, CAN1's first (`on_can1` of them).
    models: [SimDrive; CABLES],
    /// The cable each model stands for.
    cable_of: [usize; CABLES],
    on_can1: usize,
    now_ns: u64,
}

impl LoopbackRig {
    /// The drives of `configs` (each model with rated torque
    /// `rated_torque_mnm`, thousandths of a newton metre), powered at time
    /// 0, and the layer with `timing`. Nothing is exchanged yet.
    pub fn new(configs: [DriveConfig; CABLES], rated_torque_mnm: u32, timing: Timing) -> Self {
        let mut cable_of = [0usize; CABLES];
        let mut j = 0;
        for bus in 0..2u8 {
            for (i, _) in configs.iter().enumerate().filter(|(_, c)| c.bus == bus) {
                if let Some(slot) = cable_of.get_mut(j) {
                    *slot = i;
                }
                j += 1;
            }
        }
        let on_can1 = configs.iter().filter(|c| c.bus == 0).count();
        let mut models: [SimDrive; CABLES] =
            core::array::from_fn(|j| SimDrive::new(configs[cable_of[j]].node, rated_torque_mnm));
        for m in models.iter_mut() {
            // The boot-ups go nowhere: the layer's NMT reset at its first
            // read makes every drive boot again.
            m.power_on(0, &mut Ring::new());
        }
        let layer = CanDrives::new(LoopbackPort::new(), LoopbackPort::new(), configs, timing);
        Self { layer, models, cable_of, on_can1, now_ns: 0 }
    }

    /// The encoders: cable `i`'s drive reports `counts[i]` (position
    /// actual) at its next SYNC.
    pub fn set_positions(&mut self, counts: &[i32; CABLES]) {
        for (m, &i) in self.models.iter_mut().zip(&self.cable_of) {
            m.set_position(counts[i]);
        }
    }

    /// `period_ns` later: what the layer sent reaches the models, their
    /// answers wait for the layer's next read, their timers run.
    pub fn deliver(&mut self, period_ns: u64) {
        self.now_ns = self.now_ns.wrapping_add(period_ns);
        let (m1, m2) = self.models.split_at_mut(self.on_can1.min(CABLES));
        let (p1, p2) = self.layer.ports();
        p1.deliver(m1, self.now_ns);
        p2.deliver(m2, self.now_ns);
    }

    /// Runs the start-up (brakes engaged, no torque), a cycle of
    /// `period_ns` at a time, until every drive is operational and switched
    /// on, at most `cycles` cycles; whether it got there.
    pub fn start(&mut self, cycles: u32, period_ns: u64) -> bool {
        let mut readings = [cdpr_control::WinchReading::default(); CABLES];
        for _ in 0..cycles {
            let _ = self.layer.read(&mut readings);
            let _ = self.layer.set_brakes(true);
            let _ = self.layer.apply(&[0.0; CABLES]);
            self.deliver(period_ns);
            if self.layer.ready() && self.models.iter().all(|m| m.state() == DriveState::SwitchedOn) {
                return true;
            }
        }
        false
    }

    /// The model of cable `i`.
    pub fn model(&self, i: usize) -> Option<&SimDrive> {
        self.cable_of.iter().position(|&c| c == i).and_then(|j| self.models.get(j))
    }
}
