//! The candidate model set of a streaming run, stored as compactly as its
//! density allows: a slab where candidates are dense is kept as a bitmap (one
//! bit per instance), a sparse one as 8-byte instance indices.
//!
//! With every instance a candidate (the worst case), writing 8-byte indices
//! costs more than reading rows of 5-10 sensors (80 MB per 10^7 instances,
//! most of it page faults of fresh memory); a bitmap is 1.25 MB. With few
//! candidates, indices are smaller than a bitmap, so memory still grows
//! with the number of candidates and never more than it did with indices
//! alone: a slab is a bitmap only when that takes fewer bytes
//! (`64 * count > rows`). The indices are derived on demand.

use crate::error::{EdmfError, Result};

/// A run of consecutive instances and their candidates.
#[derive(Debug, Clone, PartialEq)]
pub enum Segment {
    /// Candidate indices, ascending.
    Indices(Vec<u64>),
    /// Instances `first .. first + rows`; bit `i % 64` of word `i / 64` is
    /// set iff instance `first + i` is a candidate (bits past `rows` are 0).
    Bits { first: u64, rows: u64, words: Vec<u64> },
}

impl Segment {
    fn count(&self) -> u64 {
        match self {
            Segment::Indices(v) => v.len() as u64,
            Segment::Bits { words, .. } => words.iter().map(|w| w.count_ones() as u64).sum(),
        }
    }

    /// Appends the candidate indices from the `skip`-th candidate on.
    fn indices_into(&self, mut skip: u64, out: &mut Vec<u64>) {
        match self {
            Segment::Indices(v) => out.extend_from_slice(&v[(skip as usize).min(v.len())..]),
            Segment::Bits { first, words, .. } => {
                for (k, &w) in words.iter().enumerate() {
                    let n = w.count_ones() as u64;
                    if skip >= n {
                        skip -= n;
                        continue;
                    }
                    let mut w = w;
                    for _ in 0..skip {
                        w &= w - 1; // drops the lowest set bit
                    }
                    skip = 0;
                    let base = first + 64 * k as u64;
                    while w != 0 {
                        out.push(base + w.trailing_zeros() as u64);
                        w &= w - 1;
                    }
                }
            }
        }
    }
}

/// Candidates of instances `0 .. n_instances`, as segments in instance order.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CandidateSet {
    segments: Vec<Segment>,
    count: u64,
}

impl CandidateSet {
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of candidates.
    pub fn len(&self) -> u64 {
        self.count
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    pub fn segments(&self) -> &[Segment] {
        &self.segments
    }

    /// Takes the segments, leaving the set empty.
    pub fn take(&mut self) -> Vec<Segment> {
        self.count = 0;
        std::mem::take(&mut self.segments)
    }

    /// The candidates among instances `since .. since + rows` as a bitmap:
    /// bit `i % 64` of word `i / 64` set iff instance `since + i` is one.
    /// Bitmap segments are shifted in a word at a time, so a dense set costs
    /// an eighth of a byte per instance (a checkpoint saves this).
    pub fn bitmap(&self, since: u64, rows: u64) -> Vec<u64> {
        let mut out = vec![0u64; rows.div_ceil(64) as usize];
        let end = since + rows;
        // Sets the bits of `w`, whose bit 0 is instance `lo`, that lie in the range.
        let mut put = |lo: u64, mut w: u64| {
            if lo < since {
                w = if since - lo >= 64 { 0 } else { w & (u64::MAX << (since - lo)) };
            }
            if lo + 64 > end {
                w = if end <= lo { 0 } else { w & (u64::MAX >> (lo + 64 - end)) };
            }
            if w == 0 {
                return;
            }
            // Bit 0 of `w` is bit `lo - since` of `out` (lo >= since - 63 here).
            let off = lo as i128 - since as i128;
            let (k, b) = (off.div_euclid(64), off.rem_euclid(64) as u32);
            if k >= 0 {
                out[k as usize] |= w << b;
            }
            if b > 0 && k + 1 < out.len() as i128 {
                out[(k + 1) as usize] |= w >> (64 - b);
            }
        };
        for s in &self.segments {
            match s {
                Segment::Indices(v) => {
                    for &i in &v[v.partition_point(|&i| i < since)..v.partition_point(|&i| i < end)] {
                        put(i, 1);
                    }
                }
                Segment::Bits { first, words, .. } => {
                    for (j, &w) in words.iter().enumerate() {
                        put(first + 64 * j as u64, w);
                    }
                }
            }
        }
        out
    }

    /// The indices of the candidates at instance `since` or later,
    /// ascending. Walks the segments from the end, so asking for the
    /// latest instances costs only what they hold.
    pub fn indices_since(&self, since: u64) -> Vec<u64> {
        let mut parts: Vec<&Segment> = Vec::new();
        let mut cut = None;
        for s in self.segments.iter().rev() {
            let whole = match s {
                Segment::Indices(v) => v.first().is_some_and(|&i| i >= since),
                Segment::Bits { first, .. } => *first >= since,
            };
            if !whole {
                cut = Some(s);
                break;
            }
            parts.push(s);
        }
        let mut out = Vec::new();
        match cut {
            Some(Segment::Indices(v)) => out.extend_from_slice(&v[v.partition_point(|&i| i < since)..]),
            Some(Segment::Bits { first, rows, words }) if first + rows > since => {
                let skip = since - first;
                let (k, bit) = ((skip / 64) as usize, skip % 64);
                let mut tail = words[k..].to_vec();
                tail[0] &= !((1u64 << bit) - 1);
                Segment::Bits { first: first + 64 * k as u64, rows: rows - 64 * k as u64, words: tail }
                    .indices_into(0, &mut out);
            }
            _ => {}
        }
        for s in parts.into_iter().rev() {
            s.indices_into(0, &mut out);
        }
        out
    }

    /// Adds instances `first .. first + rows` (after every instance already
    /// added) whose verdicts are `words` (as in `Segment::Bits`, `count` bits
    /// set): kept as a bitmap when that is smaller than their indices.
    pub fn append(&mut self, first: u64, rows: u64, words: &[u64], count: u64) -> Result<()> {
        debug_assert_eq!(words.len() as u64, rows.div_ceil(64));
        if count == 0 {
            return Ok(());
        }
        self.count += count;
        if 64 * count <= rows {
            let mut v = match self.segments.last_mut() {
                Some(Segment::Indices(v)) => std::mem::take(v),
                _ => Vec::new(),
            };
            reserve(&mut v, count as usize, "candidate indices")?;
            Segment::Bits { first, rows, words: words.to_vec() }.indices_into(0, &mut v);
            match self.segments.last_mut() {
                Some(Segment::Indices(last)) => *last = v,
                _ => self.segments.push(Segment::Indices(v)),
            }
            return Ok(());
        }
        if let Some(Segment::Bits { first: f, rows: r, words: w }) = self.segments.last_mut() {
            if *f + *r == first {
                // Shift-merge onto the end of the bitmap (its last word may be partial).
                let shift = (*r % 64) as u32;
                reserve(w, words.len() + 1, "candidate bitmap")?;
                if shift == 0 {
                    w.extend_from_slice(words);
                } else {
                    for &x in words {
                        *w.last_mut().expect("partial word") |= x << shift;
                        w.push(x >> (64 - shift));
                    }
                }
                *r += rows;
                w.truncate(r.div_ceil(64) as usize);
                return Ok(());
            }
        }
        let mut v = Vec::new();
        reserve(&mut v, words.len(), "candidate bitmap")?;
        v.extend_from_slice(words);
        self.segments.push(Segment::Bits { first, rows, words: v });
        Ok(())
    }

    /// Forgets every candidate at instance `n` or later.
    pub fn truncate(&mut self, n: u64) {
        while let Some(last) = self.segments.last_mut() {
            match last {
                Segment::Indices(v) => {
                    let keep = v.partition_point(|&i| i < n);
                    v.truncate(keep);
                    if !v.is_empty() {
                        break;
                    }
                }
                Segment::Bits { first, rows, words } => {
                    if *first < n {
                        *rows = (*rows).min(n - *first);
                        words.truncate(rows.div_ceil(64) as usize);
                        if *rows % 64 != 0 {
                            *words.last_mut().expect("partial word") &= (1u64 << (*rows % 64)) - 1;
                        }
                        break;
                    }
                }
            }
            self.segments.pop();
        }
        self.count = self.segments.iter().map(Segment::count).sum();
    }
}

/// Room for `more` elements, or an error (an allocation failure would abort
/// the whole process, Python included).
pub(crate) fn reserve<T>(v: &mut Vec<T>, more: usize, what: &'static str) -> Result<()> {
    v.try_reserve(more)
        .map_err(|_| EdmfError::OutOfMemory { what, elements: more })
}

/// Candidate bits written by the kernels as they go, one bit per row (set =
/// candidate), from bit `offset` of `words` on: the kernels know a group of
/// rows' verdicts as bits already (their mask registers), so no value per row
/// is written and read back. The bits are ORed in: they must be 0 beforehand.
/// Call [`BitSink::finish`] after the last push.
pub struct BitSink<'a> {
    words: &'a mut [u64],
    /// Word being filled.
    word: usize,
    /// Its bits so far (from bit 0 of the word).
    acc: u64,
    /// Bits of `acc` in use, < 64.
    fill: u32,
}

impl<'a> BitSink<'a> {
    pub fn new(words: &'a mut [u64], offset: usize) -> Self {
        BitSink { words, word: offset / 64, acc: 0, fill: (offset % 64) as u32 }
    }

    /// Appends the `n` (1..=64) low bits of `bits` (bits above them are 0).
    #[inline(always)]
    pub fn push(&mut self, bits: u64, n: u32) {
        debug_assert!((1..=64).contains(&n) && (n == 64 || bits >> n == 0));
        self.acc |= bits << self.fill;
        let fill = self.fill + n;
        if fill >= 64 {
            self.words[self.word] |= self.acc;
            self.word += 1;
            // The bits that did not fit (none if the word was empty).
            self.acc = if self.fill == 0 { 0 } else { bits >> (64 - self.fill) };
            self.fill = fill - 64;
        } else {
            self.fill = fill;
        }
    }

    /// Appends one bit per verdict of `verdicts` (set iff the verdict is 0).
    pub fn push_verdicts(&mut self, verdicts: &[u32]) {
        let mut w = [0u64; 1];
        for chunk in verdicts.chunks(64) {
            verdict_words(chunk, &mut w);
            self.push(w[0], chunk.len() as u32);
        }
    }

    /// Writes the last, partial word.
    pub fn finish(self) {
        if self.fill > 0 {
            self.words[self.word] |= self.acc;
        }
    }
}

/// Number of candidates (set bits) of `words`.
pub fn count_bits(words: &[u64]) -> usize {
    words.iter().map(|w| w.count_ones() as usize).sum()
}

/// Writes one bit per verdict (bit set = candidate, `v == 0`) into `words`
/// (`ceil(verdicts / 64)` words, bits past the end 0); returns the number of
/// candidates. No branch per row: the block was just written, it is in L1.
pub fn verdict_words(verdicts: &[u32], words: &mut [u64]) -> usize {
    assert_eq!(words.len(), verdicts.len().div_ceil(64));
    #[cfg(target_arch = "x86_64")]
    if crate::kernel::Isa::detect() == crate::kernel::Isa::Avx512 {
        // SAFETY: the CPU runs AVX-512F (`detect` checked it); lengths checked above.
        return unsafe { verdict_words_avx512(verdicts, words) };
    }
    verdict_words_portable(verdicts, words)
}

/// [`verdict_words`] sixteen verdicts to a comparison (a third of the
/// kernel's time went to the portable loop on short rows).
///
/// # Safety
/// AVX-512F is available; `words.len() == ceil(verdicts.len() / 64)`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt")]
unsafe fn verdict_words_avx512(verdicts: &[u32], words: &mut [u64]) -> usize {
    use std::arch::x86_64::*;
    let whole = verdicts.len() / 64;
    let mut count = 0;
    let zero = _mm512_setzero_si512();
    for (w, chunk) in words[..whole].iter_mut().zip(verdicts.chunks_exact(64)) {
        let mut bits = 0u64;
        for q in 0..4 {
            let v = _mm512_loadu_si512(chunk.as_ptr().add(16 * q) as *const __m512i);
            bits |= (_mm512_cmpeq_epi32_mask(v, zero) as u64) << (16 * q);
        }
        *w = bits;
        count += bits.count_ones() as usize;
    }
    count + verdict_words_portable(&verdicts[64 * whole..], &mut words[whole..])
}

fn verdict_words_portable(verdicts: &[u32], words: &mut [u64]) -> usize {
    let mut count = 0;
    for (w, chunk) in words.iter_mut().zip(verdicts.chunks(64)) {
        let mut bits = 0u64;
        for (i, &v) in chunk.iter().enumerate() {
            bits |= ((v == 0) as u64) << i;
        }
        *w = bits;
        count += bits.count_ones() as usize;
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    fn from_flags(flags: &[bool]) -> Vec<u64> {
        let mut w = vec![0u64; flags.len().div_ceil(64)];
        for (i, &f) in flags.iter().enumerate() {
            w[i / 64] |= (f as u64) << (i % 64);
        }
        w
    }

    /// Pseudo-random candidate flags, dense or sparse by stretch.
    fn flags(n: usize, seed: u64) -> Vec<bool> {
        let mut s = seed | 1;
        (0..n)
            .map(|i| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                if (i / 2000) % 2 == 0 {
                    s % 7 != 0
                } else {
                    s % 300 == 0
                }
            })
            .collect()
    }

    #[test]
    fn any_split_into_slabs_gives_the_same_indices_and_truncation_forgets_exactly() {
        let n = 9000;
        for seed in 1..20u64 {
            let f = flags(n, seed);
            let want: Vec<u64> = (0..n as u64).filter(|&i| f[i as usize]).collect();
            let mut set = CandidateSet::new();
            let mut first = 0;
            let mut s = seed;
            while first < n {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let rows = (1 + (s >> 33) as usize % 900).min(n - first);
                let words = from_flags(&f[first..first + rows]);
                let count = f[first..first + rows].iter().filter(|&&x| x).count() as u64;
                set.append(first as u64, rows as u64, &words, count).unwrap();
                first += rows;
            }
            assert_eq!(set.len(), want.len() as u64);
            assert_eq!(set.indices_since(0), want);
            for since in [1u64, 63, 64, 65, 1000, 4321, 8999, 9000, 12000] {
                let tail: Vec<u64> = want.iter().copied().filter(|&i| i >= since).collect();
                assert_eq!(set.indices_since(since), tail, "since {since}");
            }
            assert!(set.segments().iter().any(|s| matches!(s, Segment::Bits { .. })));
            assert!(set.segments().iter().any(|s| matches!(s, Segment::Indices(_))));
            // Any window of instances as a bitmap, against the flags.
            for (since, rows) in [(0u64, 9000u64), (1, 63), (63, 130), (64, 4000), (1999, 2002), (8990, 10), (8999, 50)] {
                let end = (since + rows).min(n as u64);
                let mut window: Vec<bool> = (since..end).map(|i| f[i as usize]).collect();
                window.resize(rows as usize, false); // past the last instance: none
                assert_eq!(set.bitmap(since, rows), from_flags(&window), "since {since}, rows {rows}");
            }
            for cut in [8999u64, 4500, 2500, 1001, 64, 63, 0] {
                set.truncate(cut);
                let kept: Vec<u64> = want.iter().copied().filter(|&i| i < cut).collect();
                assert_eq!(set.indices_since(0), kept, "cut {cut}");
                assert_eq!(set.len(), kept.len() as u64);
            }
        }
    }

    #[test]
    fn verdict_words_set_the_bits_of_zero_verdicts() {
        let v: Vec<u32> = (0..200u32).map(|i| (i % 3 == 1) as u32 * i).collect();
        let want: Vec<bool> = v.iter().map(|&x| x == 0).collect();
        for len in [0usize, 1, 63, 64, 65, 128, 200] {
            let mut w = vec![0; len.div_ceil(64)];
            let n = verdict_words(&v[..len], &mut w);
            assert_eq!(w, from_flags(&want[..len]), "{len}");
            assert_eq!(n, want[..len].iter().filter(|&&x| x).count());
            let mut p = vec![0; len.div_ceil(64)];
            assert_eq!(verdict_words_portable(&v[..len], &mut p), n);
            assert_eq!(p, w);
        }
    }

    #[test]
    fn bit_sink_appends_at_any_offset_in_pieces_of_any_size() {
        let f = flags(700, 7);
        let want = from_flags(&f);
        for offset_rows in [0usize, 1, 63, 64, 100] {
            for piece in [1usize, 3, 4, 16, 64] {
                let mut w = vec![0u64; 700usize.div_ceil(64)];
                // Rows before `offset_rows` through one sink, the rest through another.
                for (start, end) in [(0, offset_rows), (offset_rows, 700)] {
                    let mut sink = BitSink::new(&mut w, start);
                    for s in (start..end).step_by(piece) {
                        let e = (s + piece).min(end);
                        let bits = (s..e).fold(0u64, |b, i| b | (f[i] as u64) << (i - s));
                        sink.push(bits, (e - s) as u32);
                    }
                    sink.finish();
                }
                assert_eq!(w, want, "offset {offset_rows}, piece {piece}");
                assert_eq!(count_bits(&w), f.iter().filter(|&&x| x).count());
            }
        }
        let v: Vec<u32> = f.iter().map(|&c| (!c) as u32 * 3).collect();
        let mut w = vec![0u64; 700usize.div_ceil(64)];
        let mut sink = BitSink::new(&mut w, 0);
        sink.push_verdicts(&v[..5]);
        sink.push_verdicts(&v[5..]);
        sink.finish();
        assert_eq!(w, want);
    }
}
