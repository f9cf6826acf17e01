//! The simulated serial link and clock, and the host at the far end.
//!
//! * [`SerialLink`]: two byte queues (host to device, device to host) with a
//!   line rate: at most `bytes_per_cycle` bytes cross each way per control
//!   cycle (100 at 1 Mbit/s 8N1 and 1 kHz), the rest wait their turn. The
//!   device side feeds every byte to `ControlLoop::receive_byte`, exactly
//!   as the firmware's USART1 task does.
//! * [`Host`]: encodes `cdpr_protocol` frames into the link and decodes the
//!   telemetry frames coming back.
//! * [`SimClock`]: simulated time as a `cdpr_control::TickCounter`
//!   (microseconds), and [`WallTicks`], the host's clock in nanoseconds to
//!   time the control step itself.

use std::collections::VecDeque;
use std::time::Instant;

use cdpr_control::TickCounter;
use cdpr_protocol::{encode, DeviceMessage, FrameDecoder, FrameError, HostMessage, Telemetry, MAX_FRAME};

/// Bytes per 1 ms cycle at 1 Mbit/s with 10 bits per byte (8N1).
pub const BYTES_PER_CYCLE_1MBAUD: usize = 100;

/// Two byte queues with a line rate.
#[derive(Debug, Clone)]
pub struct SerialLink {
    to_device: VecDeque<u8>,
    to_host: VecDeque<u8>,
    bytes_per_cycle: usize,
}

impl SerialLink {
    /// An empty link that moves at most `bytes_per_cycle` bytes each way per cycle.
    pub fn new(bytes_per_cycle: usize) -> Self {
        Self { to_device: VecDeque::new(), to_host: VecDeque::new(), bytes_per_cycle }
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
        let n = self.to_device.len().min(self.bytes_per_cycle);
        self.to_device.drain(..n).collect()
    }

    /// The bytes that reach the host this cycle.
    pub fn host_read(&mut self) -> Vec<u8> {
        let n = self.to_host.len().min(self.bytes_per_cycle);
        self.to_host.drain(..n).collect()
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
