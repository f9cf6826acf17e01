//! Per-cycle cost statistics without allocation: min / median / max from a
//! caller-provided fixed buffer sorted once at the end ([`Samples`]), and a
//! running mean and max ([`Running`]).

/// Summary of a set of samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Summary {
    /// Smallest sample.
    pub min: u32,
    /// Median (mean of the two middle samples for an even count, rounded down).
    pub median: u32,
    /// Largest sample.
    pub max: u32,
    /// Number of samples.
    pub count: u32,
}

/// Samples recorded into a fixed buffer; samples beyond its length are
/// not stored.
pub struct Samples<'a> {
    buf: &'a mut [u32],
    len: usize,
}

impl<'a> Samples<'a> {
    /// Empty, recording into `buf`.
    pub fn new(buf: &'a mut [u32]) -> Self {
        Self { buf, len: 0 }
    }

    /// Records one sample.
    pub fn push(&mut self, value: u32) {
        if let Some(slot) = self.buf.get_mut(self.len) {
            *slot = value;
            self.len += 1;
        }
    }

    /// The stored samples, in the order recorded (until [`Samples::summary`] sorts them).
    pub fn as_slice(&self) -> &[u32] {
        &self.buf[..self.len]
    }

    /// Forgets every sample (keeps the buffer).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Sorts the stored samples and summarises them (all zero when empty).
    pub fn summary(&mut self) -> Summary {
        let s = &mut self.buf[..self.len];
        if s.is_empty() {
            return Summary::default();
        }
        s.sort_unstable();
        let n = s.len();
        let median =
            if n % 2 == 1 { s[n / 2] } else { ((u64::from(s[n / 2 - 1]) + u64::from(s[n / 2])) / 2) as u32 };
        Summary { min: s[0], median, max: s[n - 1], count: n as u32 }
    }
}

/// Running mean and max (no buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Running {
    sum: u64,
    max: u32,
    count: u32,
}

impl Running {
    /// Records one sample.
    pub fn push(&mut self, value: u32) {
        self.sum += u64::from(value);
        self.max = self.max.max(value);
        self.count += 1;
    }

    /// Mean, rounded to nearest (0 when empty).
    pub fn mean(&self) -> u32 {
        if self.count == 0 {
            0
        } else {
            ((self.sum + u64::from(self.count) / 2) / u64::from(self.count)) as u32
        }
    }

    /// Largest sample (0 when empty).
    pub fn max(&self) -> u32 {
        self.max
    }
}
