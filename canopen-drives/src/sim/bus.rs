//! The simulated bus, the network of drives on it and the board's port.

use std::cell::RefCell;
use std::collections::VecDeque;
use std::rc::Rc;

use crate::frame::RawFrame;
use crate::model::{SimDrive, SimFrame, SimPortError};
use crate::CanPort;

/// One bus: transmitters' queues (index 0 is the board), the frame on the
/// wire, and the time.
#[derive(Debug, Clone)]
pub struct SimBus {
    /// Nanoseconds per bit (1000 at 1 Mbit/s).
    pub bit_ns: u64,
    now_ns: u64,
    queues: Vec<VecDeque<(u64, RawFrame)>>,
    in_flight: Option<(u64, usize, RawFrame)>,
    busy_bits: u64,
    /// Every frame sent: start and end time (ns), transmitter, frame.
    pub log: Vec<(u64, u64, usize, RawFrame)>,
    /// Whether a log is kept.
    pub logging: bool,
}

impl SimBus {
    /// A bus at `bit_rate` bit/s with `transmitters` nodes.
    pub fn new(bit_rate: u64, transmitters: usize) -> Self {
        Self {
            bit_ns: 1_000_000_000 / bit_rate.max(1),
            now_ns: 0,
            queues: vec![VecDeque::new(); transmitters],
            in_flight: None,
            busy_bits: 0,
            log: Vec::new(),
            logging: false,
        }
    }

    /// The time, ns.
    pub fn now_ns(&self) -> u64 {
        self.now_ns
    }

    /// Bits sent so far (worst-case lengths).
    pub fn busy_bits(&self) -> u64 {
        self.busy_bits
    }

    /// Queues `frame` at transmitter `from`, ready to send at `ready_ns`.
    pub fn queue(&mut self, from: usize, ready_ns: u64, frame: RawFrame) {
        if let Some(q) = self.queues.get_mut(from) {
            q.push_back((ready_ns, frame));
        }
    }

    /// Frames waiting at transmitter `from`.
    pub fn waiting(&self, from: usize) -> usize {
        self.queues.get(from).map_or(0, VecDeque::len)
    }

    /// Drops every queued frame of transmitter `from`.
    pub fn drop_queue(&mut self, from: usize) {
        if let Some(q) = self.queues.get_mut(from) {
            q.clear();
        }
    }

    /// The next frame delivered at or before `until_ns`: its end time, its
    /// transmitter and the frame; `None` when none completes by then (the
    /// time is then `until_ns`, a frame may be on the wire).
    pub fn next_delivery(&mut self, until_ns: u64) -> Option<(u64, usize, RawFrame)> {
        loop {
            if let Some((end, from, frame)) = self.in_flight {
                if end <= until_ns {
                    self.in_flight = None;
                    self.now_ns = end;
                    return Some((end, from, frame));
                }
                self.now_ns = until_ns;
                return None;
            }
            // The bus is idle: the earliest a frame is ready.
            let start = self.queues.iter().filter_map(|q| q.front().map(|(r, _)| *r)).min()?.max(self.now_ns);
            if start >= until_ns {
                self.now_ns = until_ns;
                return None;
            }
            // Arbitration among the frames ready at `start`: lowest id.
            let winner = self
                .queues
                .iter()
                .enumerate()
                .filter_map(|(i, q)| q.front().filter(|(r, _)| *r <= start).map(|(_, f)| (f.id, i)))
                .min()?
                .1;
            let (_, frame) = self.queues[winner].pop_front()?;
            let bits = u64::from(frame.worst_case_bits());
            let end = start + bits * self.bit_ns;
            self.busy_bits += bits;
            if self.logging {
                self.log.push((start, end, winner, frame));
            }
            self.in_flight = Some((end, winner, frame));
        }
    }
}

/// A bus with its drives (transmitter `i + 1` is drive `i`) and the frames
/// delivered to the board.
#[derive(Debug)]
pub struct SimNetwork {
    /// The bus.
    pub bus: SimBus,
    /// The drives.
    pub drives: Vec<SimDrive>,
    /// Frames the board has received and not yet taken.
    pub board_rx: VecDeque<RawFrame>,
    /// A drive answers this long after the frame that asks for it, ns.
    pub response_ns: u64,
    /// The board's controller is bus-off (it sends and receives nothing).
    pub bus_off: bool,
    /// The board's transmit queue's capacity, frames.
    pub tx_capacity: usize,
    /// Frames the board queued when its queue was full.
    pub tx_refused: u32,
    /// The time the board's next frames are queued at, ns.
    pub board_time_ns: u64,
    out: Vec<RawFrame>,
}

impl SimNetwork {
    /// A 1 Mbit/s bus with `drives`, powered at time 0 (each sends its
    /// boot-up).
    pub fn new(drives: Vec<SimDrive>) -> Self {
        let mut net = Self {
            bus: SimBus::new(1_000_000, drives.len() + 1),
            drives,
            board_rx: VecDeque::new(),
            response_ns: 20_000,
            bus_off: false,
            tx_capacity: 32,
            tx_refused: 0,
            board_time_ns: 0,
            out: Vec::new(),
        };
        for i in 0..net.drives.len() {
            let mut out = std::mem::take(&mut net.out);
            net.drives[i].power_on(0, &mut out);
            for f in out.drain(..) {
                net.bus.queue(i + 1, 0, f);
            }
            net.out = out;
        }
        net
    }

    /// The board's frames go onto the bus at `ns` from now on (the
    /// simulator sets it to the step's end before the board writes).
    pub fn set_board_time(&mut self, ns: u64) {
        self.board_time_ns = ns;
    }

    /// Runs the bus to `until_ns`: delivers every frame that completes by
    /// then to every other node (the board and the drives), queues the
    /// drives' answers and their timed frames (heartbeats, event timers).
    pub fn advance(&mut self, until_ns: u64) {
        loop {
            let next = self.bus.next_delivery(until_ns);
            let t = next.map_or(until_ns, |(end, _, _)| end);
            for i in 0..self.drives.len() {
                let mut out = std::mem::take(&mut self.out);
                self.drives[i].tick(t, &mut out);
                for f in out.drain(..) {
                    self.bus.queue(i + 1, t, f);
                }
                self.out = out;
            }
            let Some((end, from, frame)) = next else { break };
            if from != 0 && !self.bus_off {
                self.board_rx.push_back(frame);
            }
            for i in 0..self.drives.len() {
                if from == i + 1 {
                    continue;
                }
                let mut out = std::mem::take(&mut self.out);
                self.drives[i].receive(&frame, end, &mut out);
                for f in out.drain(..) {
                    self.bus.queue(i + 1, end + self.response_ns, f);
                }
                self.out = out;
            }
        }
    }
}

/// The board's controller on a [`SimNetwork`] (shared with the simulator,
/// which advances it), plus frames a test slips in ahead of the bus's.
#[derive(Debug, Clone)]
pub struct SimPort {
    /// The network.
    pub net: Rc<RefCell<SimNetwork>>,
    /// Frames the board receives before the bus's (garbage, for tests).
    pub inject: Rc<RefCell<VecDeque<SimFrame>>>,
    /// Receive errors to report before the next frames.
    pub overruns: Rc<RefCell<u32>>,
}

impl SimPort {
    /// The port of `net`.
    pub fn new(net: Rc<RefCell<SimNetwork>>) -> Self {
        Self { net, inject: Rc::default(), overruns: Rc::default() }
    }
}

impl embedded_can::nb::Can for SimPort {
    type Frame = SimFrame;
    type Error = SimPortError;

    fn transmit(&mut self, frame: &SimFrame) -> nb::Result<Option<SimFrame>, SimPortError> {
        let mut net = self.net.borrow_mut();
        if net.bus.waiting(0) >= net.tx_capacity {
            net.tx_refused += 1;
            return Err(nb::Error::WouldBlock);
        }
        if net.bus_off {
            // A bus-off controller takes frames and sends none.
            return Ok(None);
        }
        if let Some(raw) = RawFrame::from_frame(frame) {
            let t = net.board_time_ns;
            net.bus.queue(0, t, raw);
        }
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<SimFrame, SimPortError> {
        {
            let mut o = self.overruns.borrow_mut();
            if *o > 0 {
                *o -= 1;
                return Err(nb::Error::Other(SimPortError));
            }
        }
        if let Some(f) = self.inject.borrow_mut().pop_front() {
            return Ok(f);
        }
        let mut net = self.net.borrow_mut();
        match net.board_rx.pop_front() {
            Some(raw) => raw.to_frame::<SimFrame>().ok_or(nb::Error::WouldBlock),
            None => Err(nb::Error::WouldBlock),
        }
    }
}

impl CanPort for SimPort {
    fn is_bus_off(&mut self) -> bool {
        self.net.borrow().bus_off
    }
}
