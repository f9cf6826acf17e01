//! The simulated serial link and clock, and the host at the far end.
//!
//! * [`SerialLink`]: two byte queues (host to device, device to host) with a
//!   line rate: the board's USART1 at [`BAUD`] (460 800 baud 8N1: 46.08
//!   bytes per 1 ms cycle, each way) passes whole bytes as their time
//!   accrues, the rest wait their turn. The device side feeds every byte to
//!   `ControlLoop::receive_byte`, exactly as the firmware's USART1 task
//!   does.
//! * [`Host`]: encodes `cdpr_protocol` frames into the link and decodes the
//!   telemetry frames coming back.
//! * [`SimClock`]: simulated time as a `cdpr_control::TickCounter`
//!   (microseconds), and [`WallTicks`], the host's clock in nanoseconds to
//!   time the control step itself.

use std::collections::VecDeque;
use std::time::Instant;

use cdpr_control::TickCounter;
use cdpr_protocol::{encode, DeviceMessage, FrameDecoder, FrameError, HostMessage, Telemetry, MAX_FRAME};

/// The board's line rate (`firmware::serial::BAUD`), bits per second.
pub const BAUD: u32 = 460_800;

/// Two byte queues with a line rate.
#[derive(Debug, Clone)]
pub struct SerialLink {
    to_device: VecDeque<u8>,
    to_host: VecDeque<u8>,
    /// Bytes per 1 ms cycle (10 bits per byte, 8N1).
    bytes_per_cycle: f64,
    /// Line time accrued but not yet used, bytes, each way.
    credit_to_device: f64,
    credit_to_host: f64,
}

impl SerialLink {
    /// An empty link at `baud` (8N1) with a 1 ms cycle.
    pub fn at_baud(baud: u32) -> Self {
        Self {
            to_device: VecDeque::new(),
            to_host: VecDeque::new(),
            bytes_per_cycle: f64::from(baud) / 10.0 / 1000.0,
            credit_to_device: 0.0,
            credit_to_host: 0.0,
        }
    }

    /// Bytes the line carries each way per cycle.
    pub fn bytes_per_cycle(&self) -> f64 {
        self.bytes_per_cycle
    }

    /// Whole bytes of `queue` the line passes this cycle; an idle line
    /// saves no time up (a UART does not send faster after a pause).
    fn pass(queue: &mut VecDeque<u8>, credit: &mut f64, rate: f64) -> Vec<u8> {
        if queue.is_empty() {
            *credit = 0.0;
            return Vec::new();
        }
        *credit += rate;
        let n = (*credit as usize).min(queue.len());
        *credit -= n as f64;
        queue.drain(..n).collect()
    }

    /// Queues bytes from the host.
    pub fn host_write(&mut self, bytes: &[u8]) {
        self.to_device.extend(bytes);
    }

    /// Queues bytes from the device.
    pub fn device_write(&mut self, bytes: &[u8]) {
        self.to_host.extend(bytes);
    }

    /// The bytes that reach the device this cycle.
    pub fn device_read(&mut self) -> Vec<u8> {
        Self::pass(&mut self.to_device, &mut self.credit_to_device, self.bytes_per_cycle)
    }

    /// The bytes that reach the host this cycle.
    pub fn host_read(&mut self) -> Vec<u8> {
        Self::pass(&mut self.to_host, &mut self.credit_to_host, self.bytes_per_cycle)
    }

    /// Bytes waiting for the host.
    pub fn pending_to_host(&self) -> usize {
        self.to_host.len()
    }

    /// Bytes waiting for the device.
    pub fn pending_to_device(&self) -> usize {
        self.to_device.len()
    }
}

/// The host end: frames out, telemetry in.
#[derive(Debug, Clone, Default)]
pub struct Host {
    decoder: FrameDecoder,
    /// Every telemetry sample received, in order.
    pub telemetry: Vec<Telemetry>,
    /// Frames from the device that did not decode.
    pub rejected: u32,
}

impl Host {
    /// A host that has received nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sends one message.
    pub fn send(&self, link: &mut SerialLink, message: &HostMessage) -> Result<(), FrameError> {
        let mut frame = [0u8; MAX_FRAME];
        let n = encode(message, &mut frame)?;
        link.host_write(&frame[..n]);
        Ok(())
    }

    /// Reads what arrived this cycle.
    pub fn receive(&mut self, link: &mut SerialLink) {
        for b in link.host_read() {
            match self.decoder.push::<DeviceMessage>(b) {
                Some(Ok(DeviceMessage::Telemetry(t))) => self.telemetry.push(t),
                // The simulated board does not answer `Identify`.
                Some(Ok(DeviceMessage::Identity(_))) => {}
                Some(Err(_)) => self.rejected += 1,
                None => {}
            }
        }
    }
}

/// Simulated time in microseconds (wrapping at 32 bits like a hardware timer).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimClock {
    /// Microseconds since the start of the run.
    pub micros: u64,
}

impl TickCounter for SimClock {
    fn ticks(&self) -> u32 {
        self.micros as u32
    }
}

/// The host's monotonic clock in nanoseconds, to time the control step.
#[derive(Debug, Clone, Copy)]
pub struct WallTicks {
    start: Instant,
}

impl WallTicks {
    /// Counting from now.
    pub fn new() -> Self {
        Self { start: Instant::now() }
    }
}

impl Default for WallTicks {
    fn default() -> Self {
        Self::new()
    }
}

impl TickCounter for WallTicks {
    fn ticks(&self) -> u32 {
        self.start.elapsed().as_nanos() as u32
    }
}
