//! How the vector kernels prefetch: how far ahead of the rows being tested,
//! and into which cache. The hardware prefetcher alone leaves them waiting on
//! memory (on a 2-core Xeon: no prefetch twice as slow, 2 KiB ahead 20 %
//! slower than 4-8 KiB), and the best hint differs between CPUs, so the
//! AVX-512 short-row kernels (`periodic`, `row_batches`: rows of up to two
//! vectors, and back-to-back rows whose pattern repeats within eight) use the
//! one chosen for this CPU ([`Prefetch::for_cpu`]); the others keep a constant
//! one ([`Prefetch::FIXED`]), which on an AMD EPYC (family 0x19) did as well
//! or better for their rows (there a non-temporal prefetch, or none, halved
//! the long rows' speed). A prefetch is a hint: the candidates do not
//! depend on it.

use super::cpu::Cpu;
use std::arch::x86_64::*;
use std::sync::atomic::{AtomicU8, AtomicUsize, Ordering};

/// Environment variable naming the prefetch the AVX-512 kernels use instead
/// of this CPU's (`t0|t1|t2|nta:<bytes ahead>` or `off`), to compare them.
pub const PREFETCH_ENV: &str = "EDMF_RS_PREFETCH";

/// Which cache a prefetched line goes to (`_MM_HINT_*`). Each one's value
/// is the code the hint in use is stored as (`Prefetch::now` reads it) and
/// that [`Prefetch::line_as`] takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Hint {
    T0,
    /// Into L2 (and L3), not L1.
    T1,
    T2,
    /// For data read once: close to the core, kept out of the other caches
    /// where the CPU can.
    Nta,
    Off,
}

/// The prefetch of the vector kernels: the line `bytes` past each line read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Prefetch {
    pub hint: Hint,
    pub bytes: usize,
}

impl Prefetch {
    /// The AVX-512 short-row kernels' prefetch measured best on `cpu`'s kind,
    /// side by side through `falsify` on 800 MB with two threads (`python
    /// benches/throughput.py --floor --prefetch t1:8192`; `docs/performance.md`,
    /// "AMD EPYC of CPU family 25 (session 19)"):
    /// - AMD Zen 3 and later (family 0x19+): non-temporal, 4 KiB ahead,
    ///   measured on Zen 4 only (EPYC, family 0x19 model 0x11): 0.995-1.131
    ///   times the speed of `t1:8192` on rows of 5-16 sensors with
    ///   diagnostics (`benches/results-short-rows.txt`, "session 19:
    ///   prefetch scan").
    /// - Others: into L2, 8 KiB ahead (the other kernels' until session 35,
    ///   [`Prefetch::FIXED`]), measured best on an Intel Xeon; AMD before
    ///   Zen 3 keeps it too (not measured there).
    pub fn for_cpu(cpu: Cpu) -> Prefetch {
        if cpu.amd && cpu.family >= 0x19 {
            Prefetch { hint: Hint::Nta, bytes: 4096 }
        } else {
            Prefetch { hint: Hint::T1, bytes: 8192 }
        }
    }

    /// A prefetch by name: `t0`, `t1`, `t2` or `nta`, `:`, bytes ahead
    /// (a multiple of 64 up to 1 MiB), or `off`.
    pub fn from_name(name: &str) -> Option<Prefetch> {
        if name.trim().eq_ignore_ascii_case("off") {
            return Some(Prefetch { hint: Hint::Off, bytes: 0 });
        }
        let (hint, bytes) = name.trim().split_once(':')?;
        let hint = match hint.to_ascii_lowercase().as_str() {
            "t0" => Hint::T0,
            "t1" => Hint::T1,
            "t2" => Hint::T2,
            "nta" => Hint::Nta,
            _ => return None,
        };
        let bytes: usize = bytes.parse().ok()?;
        (bytes % 64 == 0 && bytes <= 1 << 20).then_some(Prefetch { hint, bytes })
    }

    /// The prefetch in use: this CPU's, or the one [`PREFETCH_ENV`] names
    /// (read once), or the last one [`Prefetch::set`].
    #[inline(always)]
    pub fn current() -> Prefetch {
        match HINT.load(Ordering::Relaxed) {
            UNSET => Prefetch::init(),
            _ => Prefetch::now(),
        }
    }

    /// Uses `self` from now on (to compare prefetches side by side in one
    /// process). Kernels running meanwhile may mix the old and new settings
    /// for a moment: harmless, a prefetch is a hint.
    pub fn set(self) {
        BYTES.store(self.bytes, Ordering::Relaxed);
        HINT.store(self.hint as u8, Ordering::Relaxed);
    }

    #[cold]
    fn init() -> Prefetch {
        let p = std::env::var(PREFETCH_ENV)
            .ok()
            .and_then(|v| Prefetch::from_name(&v))
            .unwrap_or_else(|| Prefetch::for_cpu(Cpu::this()));
        p.set();
        p
    }

    /// The name [`Prefetch::from_name`] reads.
    pub fn name(self) -> String {
        let hint = match self.hint {
            Hint::T0 => "t0",
            Hint::T1 => "t1",
            Hint::T2 => "t2",
            Hint::Nta => "nta",
            Hint::Off => return "off".into(),
        };
        format!("{hint}:{}", self.bytes)
    }
}

/// The hint in use, as its `Hint as u8` ([`UNSET`] until chosen),
/// and the bytes ahead: two atomics, read on every prefetch (a relaxed load
/// is a plain load on x86-64; through `falsify` no slower than a constant).
static HINT: AtomicU8 = AtomicU8::new(UNSET);
static BYTES: AtomicUsize = AtomicUsize::new(0);
const UNSET: u8 = u8::MAX;
/// `line_as`'s code for a hint chosen on every line.
pub const RUN_TIME: u8 = u8::MAX;

impl Prefetch {
    /// The prefetch of the AVX2 kernels and of the AVX-512 kernels of longer
    /// rows, whatever the CPU: into L2, 6 KiB ahead, a constant in their
    /// code. Chosen at run time, the prefetch costs a branch on every line,
    /// which the AVX2 kernels, short of registers, paid with 10-13 % of
    /// their speed on f32 rows of 10-50 sensors (AMD EPYC, family 0x19:
    /// 0.870-0.899 of the session start's; `benches/results-short-rows.txt`,
    /// "session 19: where the time went").
    ///
    /// Why 6 KiB: 8 KiB until session 35. Side by side through `falsify`
    /// (AMD EPYC Zen 4, two runs at each level), 6 KiB made rows of 25-200
    /// sensors 1.043 (AVX-512) and 1.047 (AVX2) times as fast by the median
    /// (`benches/results-long-rows.txt`, "session 35: the fixed prefetch
    /// t1:6144"). The distance matters: 4 KiB slowed f64 rows of 200 there,
    /// none or into L1 halved their speed ("session 35: the fixed prefetch's
    /// distance"). The Xeon of the module docs read alike 4 and 8 KiB ahead;
    /// 6 KiB was not measured on an Intel CPU.
    pub const FIXED: Prefetch = Prefetch { hint: Hint::T1, bytes: 6144 };

    /// No prefetch (rereading lines just read).
    pub const OFF: Prefetch = Prefetch { hint: Hint::Off, bytes: 0 };

    /// The prefetch chosen for this CPU, as far as chosen: two plain loads,
    /// no call. Used by the AVX-512 short-row kernels (see the module docs).
    /// Kernels take it once a call (or a row) and pass it into their loops,
    /// so the loops hold it in registers: read on every line (two atomic
    /// loads and a branch each time), it cost the AVX2 kernels, already
    /// short of registers, up to half their speed, and a call on that path
    /// (choosing it there), even never taken, made the compiler keep the
    /// row-batch kernel's vectors in memory. [`crate::kernel::Isa::supported`],
    /// which every vector kernel's dispatch asks first, chooses it; until
    /// then it is off.
    #[inline(always)]
    pub fn now() -> Prefetch {
        let hint = match HINT.load(Ordering::Relaxed) {
            0 => Hint::T0,
            1 => Hint::T1,
            2 => Hint::T2,
            3 => Hint::Nta,
            _ => Hint::Off,
        };
        Prefetch { hint, bytes: BYTES.load(Ordering::Relaxed) }
    }

    /// [`Prefetch::line`] with the hint a constant, `H` = its `Hint as u8`
    /// (or [`RUN_TIME`]: `self`'s, chosen on every line). A loop that
    /// prefetches on every row pays for choosing the hint at run time: a
    /// jump through a table each time (see `row_batches`).
    #[inline(always)]
    pub fn line_as<const H: u8, T>(self, p: *const T) {
        let q = (p as *const i8).wrapping_add(self.bytes);
        // SAFETY: SSE is part of x86-64; prefetching any address is allowed.
        unsafe {
            match H {
                0 => _mm_prefetch::<_MM_HINT_T0>(q),
                1 => _mm_prefetch::<_MM_HINT_T1>(q),
                2 => _mm_prefetch::<_MM_HINT_T2>(q),
                3 => _mm_prefetch::<_MM_HINT_NTA>(q),
                4 => {}
                _ => self.line(p),
            }
        }
    }

    /// Asks for the line `self.bytes` past `p`. A prefetch never faults, so
    /// addresses past the end of the data are harmless.
    #[inline(always)]
    pub fn line<T>(self, p: *const T) {
        // Its own match, not one through `line_as`: written that way, the
        // periodic kernel screened rows of 5 and 10 at 0.90-0.94 of this
        // speed alone (AMD EPYC Zen 4; `benches/results-short-rows.txt`,
        // "session 29 review: the prefetch hint's code").
        let q = (p as *const i8).wrapping_add(self.bytes);
        // SAFETY: SSE is part of x86-64; prefetching any address is allowed.
        unsafe {
            match self.hint {
                Hint::T0 => _mm_prefetch::<_MM_HINT_T0>(q),
                Hint::T1 => _mm_prefetch::<_MM_HINT_T1>(q),
                Hint::T2 => _mm_prefetch::<_MM_HINT_T2>(q),
                Hint::Nta => _mm_prefetch::<_MM_HINT_NTA>(q),
                Hint::Off => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefetch_by_cpu_and_by_name() {
        let zen4 = Cpu { amd: true, family: 0x19 };
        assert_eq!(Prefetch::for_cpu(zen4), Prefetch { hint: Hint::Nta, bytes: 4096 });
        for cpu in [Cpu { amd: true, family: 0x17 }, Cpu { amd: false, family: 6 }] {
            assert_eq!(Prefetch::for_cpu(cpu), Prefetch { hint: Hint::T1, bytes: 8192 });
        }
        assert_eq!(Prefetch::from_name(" NTA:4096"), Some(Prefetch { hint: Hint::Nta, bytes: 4096 }));
        assert_eq!(Prefetch::from_name("t0:0"), Some(Prefetch { hint: Hint::T0, bytes: 0 }));
        assert_eq!(Prefetch::from_name("off").map(|p| p.hint), Some(Hint::Off));
        for bad in ["", "nta", "nta:100", "l2:4096", "t1:-64", &format!("t1:{}", 2 << 20)] {
            assert_eq!(Prefetch::from_name(bad), None, "{bad}");
        }
        for name in ["t0:0", "t1:8192", "t2:64", "nta:4096", "off"] {
            assert_eq!(Prefetch::from_name(name).unwrap().name(), name);
        }
        // `line_as`'s codes, none of them RUN_TIME ...
        let codes: Vec<u8> = ["t0:0", "t1:0", "t2:0", "nta:0", "off"].iter().map(|n| Prefetch::from_name(n).unwrap().hint as u8).collect();
        assert_eq!(codes, [0, 1, 2, 3, 4]);
        // ... in the order `now` decodes them.
        assert_eq!([Hint::T0, Hint::T1, Hint::T2, Hint::Nta, Hint::Off].map(|h| h as u8), [0, 1, 2, 3, 4]);
        assert!(!codes.contains(&RUN_TIME));
    }
}
