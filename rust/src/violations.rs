//! Per-instance rejecting-sensor counts (`n_violated`) of a streaming run,
//! kept in the narrowest unsigned integer that holds the sensor count: one
//! byte per instance up to 255 sensors (the common case), two up to 65,535,
//! else four. A count never exceeds the number of sensors, so narrowing is
//! exact. The public type stays `u32` (int32 in Python): the counts are
//! widened once, when taken, instead of being held four bytes each for the
//! whole run.

use crate::candidates::reserve;
use crate::error::Result;

#[derive(Debug, Clone, PartialEq)]
pub enum Violations {
    U8(Vec<u8>),
    U16(Vec<u16>),
    U32(Vec<u32>),
}

macro_rules! each {
    ($self:expr, $v:ident => $e:expr) => {
        match $self {
            Violations::U8($v) => $e,
            Violations::U16($v) => $e,
            Violations::U32($v) => $e,
        }
    };
}

impl Violations {
    /// Empty counts for rows of `n_sensors` sensors.
    pub fn for_sensors(n_sensors: usize) -> Self {
        if n_sensors <= u8::MAX as usize {
            Violations::U8(Vec::new())
        } else if n_sensors <= u16::MAX as usize {
            Violations::U16(Vec::new())
        } else {
            Violations::U32(Vec::new())
        }
    }

    pub fn len(&self) -> usize {
        each!(self, v => v.len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Bytes a count takes.
    pub fn width(&self) -> usize {
        match self {
            Violations::U8(_) => 1,
            Violations::U16(_) => 2,
            Violations::U32(_) => 4,
        }
    }

    /// Forgets the counts from instance `n` on.
    pub fn truncate(&mut self, n: usize) {
        each!(self, v => v.truncate(n))
    }

    /// Appends `counts` (each at most the sensor count); an error, not an
    /// abort, if memory runs out.
    pub fn extend(&mut self, counts: &[u32]) -> Result<()> {
        const WHAT: &str = "per-instance violation counts";
        // Exact: a count is at most the sensor count, which fits the type.
        match self {
            Violations::U8(v) => reserve(v, counts.len(), WHAT).map(|_| v.extend(counts.iter().map(|&c| c as u8))),
            Violations::U16(v) => reserve(v, counts.len(), WHAT).map(|_| v.extend(counts.iter().map(|&c| c as u16))),
            Violations::U32(v) => reserve(v, counts.len(), WHAT).map(|_| v.extend_from_slice(counts)),
        }
    }

    /// The counts as `u32`.
    pub fn to_u32(&self) -> Result<Vec<u32>> {
        let mut out = Vec::new();
        reserve(&mut out, self.len(), "per-instance violation counts")?;
        match self {
            Violations::U8(v) => out.extend(v.iter().map(|&c| u32::from(c))),
            Violations::U16(v) => out.extend(v.iter().map(|&c| u32::from(c))),
            Violations::U32(v) => out.extend_from_slice(v),
        }
        Ok(out)
    }

    /// The counts as `u32`, leaving `self` empty (moved when already `u32`).
    pub fn take_u32(&mut self) -> Result<Vec<u32>> {
        let out = match self {
            Violations::U32(v) => std::mem::take(v),
            _ => self.to_u32()?,
        };
        self.truncate(0);
        each!(self, v => v.shrink_to_fit());
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_round_trip_in_the_narrowest_type() {
        for (n_m, width) in [(1usize, 1usize), (255, 1), (256, 2), (65_535, 2), (65_536, 4)] {
            let mut v = Violations::for_sensors(n_m);
            assert_eq!(v.width(), width, "{n_m} sensors");
            let counts: Vec<u32> = (0..1000u64).map(|i| (i * 7919 % (n_m as u64 + 1)) as u32).collect();
            v.extend(&counts[..600]).unwrap();
            v.extend(&counts[600..]).unwrap();
            assert_eq!(v.to_u32().unwrap(), counts);
            assert!(counts.contains(&(n_m as u32)) || n_m > 1000, "the largest count is exercised");
            v.truncate(10);
            assert_eq!(v.take_u32().unwrap(), &counts[..10]);
            assert!(v.is_empty());
        }
    }
}
