//! The byte link to a board: a serial port (`serialport`) or a TCP socket
//! (the firmware in QEMU, `cargo xtask qemu`), with the host's writes
//! paced to the board's line rate so that a link that cannot keep up
//! shows on the host too (QEMU's USART takes bytes at any rate).

use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// How long one read waits for bytes.
pub const READ_TIMEOUT: Duration = Duration::from_millis(5);

/// A connection to the board: bytes both ways, reads that time out.
pub trait Transport: Send {
    /// Reads what has arrived (0 bytes after [`READ_TIMEOUT`] of silence).
    fn read_some(&mut self, buf: &mut [u8]) -> io::Result<usize>;
    /// Writes all of `bytes`.
    fn write_all_bytes(&mut self, bytes: &[u8]) -> io::Result<()>;
}

/// A serial port at `baud`, 8N1.
pub fn serial(port: &str, baud: u32) -> io::Result<Box<dyn Transport>> {
    let port = serialport::new(port, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_TIMEOUT)
        .open()
        .map_err(io::Error::other)?;
    Ok(Box::new(Serial(port)))
}

/// A TCP connection to `address` (`host:port`), within `timeout`.
pub fn tcp(address: &str, timeout: Duration) -> io::Result<Box<dyn Transport>> {
    use std::net::ToSocketAddrs;
    let mut last = io::Error::new(io::ErrorKind::NotFound, format!("{address}: no address"));
    for a in address.to_socket_addrs()? {
        match TcpStream::connect_timeout(&a, timeout) {
            Ok(s) => {
                s.set_read_timeout(Some(READ_TIMEOUT))?;
                s.set_nodelay(true)?;
                return Ok(Box::new(Tcp(s)));
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

struct Serial(Box<dyn serialport::SerialPort>);

impl Transport for Serial {
    fn read_some(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.0.read(buf) {
            Err(e) if e.kind() == io::ErrorKind::TimedOut => Ok(0),
            r => r,
        }
    }
    fn write_all_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.0.write_all(bytes)?;
        self.0.flush()
    }
}

struct Tcp(TcpStream);

impl Transport for Tcp {
    fn read_some(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self.0.read(buf) {
            Ok(0) => Err(io::Error::new(io::ErrorKind::UnexpectedEof, "the board closed the connection")),
            Err(e) if matches!(e.kind(), io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut) => Ok(0),
            r => r,
        }
    }
    fn write_all_bytes(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.0.write_all(bytes)
    }
}

/// Paces writes to a line rate: a write of `n` bytes waits until the line
/// has sent what was written before (10 bits per byte, 8N1).
#[derive(Debug, Clone, Copy)]
pub struct Pacer {
    seconds_per_byte: f64,
    free_at: Option<Instant>,
}

impl Pacer {
    /// A pacer for `baud` (8N1).
    pub fn new(baud: u32) -> Self {
        Self { seconds_per_byte: 10.0 / f64::from(baud.max(1)), free_at: None }
    }

    /// Waits until `n` more bytes may go, and books their time on the line.
    pub fn wait_for(&mut self, n: usize) {
        let now = Instant::now();
        let start = match self.free_at {
            Some(t) if t > now => {
                std::thread::sleep(t - now);
                t
            }
            _ => now,
        };
        self.free_at = Some(start + Duration::from_secs_f64(self.seconds_per_byte * n as f64));
    }
}
