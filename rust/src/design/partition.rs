//! Groups of instances that share a tuple of bins (a partition of the
//! instances), and the joint entropy it gives (Papadopoulou et al. 2014,
//! Eq. 3, written `H = log2 N - (1/N) sum_t c_t log2 c_t`).
//!
//! Adding a location splits each group by its bin: one pass over the
//! members with a counting array indexed by the (dense) bin, so O(N) per
//! location and no hash map. Groups of one instance can never split again
//! and contribute `1 log2 1 = 0`, so they are dropped: later steps read only
//! the instances that are still confused with another.

/// A dense bin label as stored: the narrowest unsigned type that holds a
/// location's labels (u8 up to 256 bins, u16 up to 65,536, else u32).
pub trait Bin: Copy + PartialEq + Send + Sync + 'static {
    /// The largest label this type holds.
    const MAX: u32;
    fn index(self) -> usize;
    /// `v` must be at most [`Bin::MAX`].
    fn from_u32(v: u32) -> Self;
}

macro_rules! impl_bin {
    ($t:ty) => {
        impl Bin for $t {
            const MAX: u32 = <$t>::MAX as u32;
            #[inline(always)]
            fn index(self) -> usize {
                self as usize
            }
            #[inline(always)]
            fn from_u32(v: u32) -> Self {
                v as $t
            }
        }
    };
}
impl_bin!(u8);
impl_bin!(u16);
impl_bin!(u32);

/// Groups of instances that share a tuple of bins, singletons left out.
/// Pairs (the commonest group once most instances are told apart) are
/// kept apart from the larger groups: a pair either stays together or
/// splits, which needs no counting.
#[derive(Debug, Clone)]
pub struct Partition {
    n: usize,
    /// Members of the groups of three or more, group after group.
    order: Vec<u32>,
    /// Start of each of those groups in `order`, plus the end.
    starts: Vec<u32>,
    /// The groups of two.
    pairs: Vec<[u32; 2]>,
    /// All the members in instance order (rows read forwards).
    sorted: Vec<u32>,
    /// `sum_t c_t log2 c_t` over the current tuples.
    sum_clog: f64,
}

/// Groups up to this size that split are counted by comparing their
/// members' bins pairwise, in registers, rather than through a counting
/// array (whose increments of one bin wait on each other).
const SMALL: usize = 12;

/// `sum_b c_b log2 c_b` over the bins of a group of at most [`SMALL`]
/// members: each bin's term is added at its first member, `c_b` counted
/// by comparisons.
#[inline]
fn small_group<B: Bin>(members: &[u32], bins: &[B], clog: &[f64]) -> f64 {
    let s = members.len();
    let mut x = [0usize; SMALL];
    for (j, &k) in members.iter().enumerate() {
        x[j] = bins[k as usize].index();
    }
    let x = &x[..s];
    let mut acc = 0.0;
    for j in 0..s {
        let b = x[j];
        let mut c = 0usize;
        let mut earlier = false;
        for (i, &y) in x.iter().enumerate() {
            let eq = y == b;
            c += eq as usize;
            earlier |= eq & (i < j);
        }
        acc += if earlier { 0.0 } else { clog[c] };
    }
    acc
}

/// `sum_b c_b log2 c_b` over the bins of a group much larger than the bin
/// count: members counted into four interleaved arrays (consecutive
/// increments of one bin then do not wait on each other), then every bin
/// read once. `count` is `4 x labels` zeros, left zeroed.
fn large_group<B: Bin>(members: &[u32], bins: &[B], count: &mut [u32], clog: &[f64]) -> f64 {
    let labels = count.len() / 4;
    let (c0, rest) = count.split_at_mut(labels);
    let (c1, rest) = rest.split_at_mut(labels);
    let (c2, c3) = rest.split_at_mut(labels);
    let quads = members.chunks_exact(4);
    for &k in quads.remainder() {
        c0[bins[k as usize].index()] += 1;
    }
    for q in quads {
        c0[bins[q[0] as usize].index()] += 1;
        c1[bins[q[1] as usize].index()] += 1;
        c2[bins[q[2] as usize].index()] += 1;
        c3[bins[q[3] as usize].index()] += 1;
    }
    let mut acc = 0.0;
    for b in 0..labels {
        let c = c0[b] + c1[b] + c2[b] + c3[b];
        acc += clog[c as usize];
        (c0[b], c1[b], c2[b], c3[b]) = (0, 0, 0, 0);
    }
    acc
}

/// `c log2 c` for every count up to `n`: each count's term, computed once.
pub(crate) fn clog_table(n: usize) -> Vec<f64> {
    (0..=n)
        .map(|c| if c < 2 { 0.0 } else { c as f64 * (c as f64).log2() })
        .collect()
}

impl Partition {
    /// The empty set of locations: all `n` instances in one group.
    pub fn new(n: usize, clog: &[f64]) -> Self {
        let mut part = Partition {
            n,
            order: Vec::new(),
            starts: vec![0],
            pairs: Vec::new(),
            sorted: Vec::new(),
            sum_clog: clog[n],
        };
        let all: Vec<u32> = (0..n as u32).collect();
        part.set_groups(all, if n >= 2 { vec![0, n as u32] } else { vec![0] });
        part
    }

    /// Stores the groups (of two or more, one after another in `members`),
    /// pairs apart.
    fn set_groups(&mut self, members: Vec<u32>, starts: Vec<u32>) {
        let mut order = Vec::with_capacity(members.len());
        let mut big = vec![0u32];
        let mut pairs = Vec::new();
        for w in starts.windows(2) {
            let g = &members[w[0] as usize..w[1] as usize];
            if let [a, b] = g {
                pairs.push([*a, *b]);
            } else {
                order.extend_from_slice(g);
                big.push(order.len() as u32);
            }
        }
        let mut sorted = members;
        sorted.sort_unstable();
        self.order = order;
        self.starts = big;
        self.pairs = pairs;
        self.sorted = sorted;
    }

    /// H of the current set (Eq. 3 of Papadopoulou et al. 2014), in bits.
    pub fn entropy(&self) -> f64 {
        entropy_of(self.n, self.sum_clog)
    }

    /// Instances still sharing their tuple with another one.
    pub fn n_confused(&self) -> usize {
        self.sorted.len()
    }

    /// Those instances in increasing order: the only rows whose bins matter.
    pub fn confused(&self) -> &[u32] {
        &self.sorted
    }

    /// Renames the members `0..m` in group order (the groups of three or
    /// more, then the pairs) and returns the old name of each new one: rows
    /// of the labels gathered in this order put every group in a contiguous
    /// range, and groups split later stay inside their range, so evaluations
    /// read the labels nearly in sequence.
    pub fn renumber(&mut self) -> Vec<u32> {
        let mut rows = std::mem::take(&mut self.order);
        rows.extend(self.pairs.iter().flatten());
        let big = self.starts.last().copied().unwrap_or(0);
        self.order = (0..big).collect();
        self.pairs = (big..rows.len() as u32).step_by(2).map(|a| [a, a + 1]).collect();
        self.sorted = (0..rows.len() as u32).collect();
        rows
    }

    /// The groups: those of three or more, then the pairs.
    fn groups(&self) -> impl Iterator<Item = &[u32]> {
        self.starts
            .windows(2)
            .map(|w| &self.order[w[0] as usize..w[1] as usize])
            .chain(self.pairs.iter().map(|p| p.as_slice()))
    }

    /// `sum_t c_t log2 c_t` after adding a location whose dense bins are
    /// `bins` (indexed by instance, each below `labels`), without changing
    /// the partition. `count` must be zeros, of at least `labels` (four
    /// times that lets large groups be counted in four interleaved arrays);
    /// it is left zeroed; `touched` is working space.
    ///
    /// Most groups do not split on a given location: a branch-free check
    /// that every member shares the first one's bin settles those (the
    /// group keeps its term); only groups that split are counted, each
    /// member's bin once, the bins it touches listed as they first appear.
    pub fn score<B: Bin>(
        &self,
        bins: &[B],
        labels: usize,
        count: &mut [u32],
        touched: &mut Vec<u32>,
        clog: &[f64],
    ) -> f64 {
        let mut acc = 0.0;
        for w in self.starts.windows(2) {
            let members = &self.order[w[0] as usize..w[1] as usize];
            let first = bins[members[0] as usize];
            let mut same = true;
            for &k in &members[1..] {
                same &= bins[k as usize] == first;
            }
            if same {
                acc += clog[members.len()];
                continue;
            }
            if members.len() <= SMALL {
                acc += small_group(members, bins, clog);
                continue;
            }
            if members.len() >= 4 * labels && count.len() >= 4 * labels {
                acc += large_group(members, bins, &mut count[..4 * labels], clog);
                continue;
            }
            touched.clear();
            for &k in members {
                let b = bins[k as usize].index();
                let c = &mut count[b];
                if *c == 0 {
                    touched.push(b as u32);
                }
                *c += 1;
            }
            for &b in touched.iter() {
                acc += clog[count[b as usize] as usize];
                count[b as usize] = 0;
            }
        }
        // Pairs that stay together, each `2 log2 2 = 2`: counted, not summed.
        let together: u64 = self
            .pairs
            .iter()
            .map(|&[a, b]| (bins[a as usize] == bins[b as usize]) as u64)
            .sum();
        acc + together as f64 * clog[2.min(self.n)]
    }

    /// Splits every group by `bins` (the location is added to the set).
    /// New groups are numbered by first appearance, then counting-sorted, so
    /// the result depends on the inputs only.
    pub fn refine<B: Bin>(&mut self, bins: &[B], map: &mut [u32], clog: &[f64]) {
        let mut label = Vec::with_capacity(self.sorted.len());
        let mut members = Vec::with_capacity(self.sorted.len());
        let mut sizes: Vec<u32> = Vec::new();
        for group in self.groups() {
            for &k in group {
                let b = bins[k as usize].index();
                if map[b] == 0 {
                    sizes.push(0);
                    map[b] = sizes.len() as u32; // id + 1
                }
                let id = map[b] - 1;
                label.push(id);
                members.push(k);
                sizes[id as usize] += 1;
            }
            for &k in group {
                map[bins[k as usize].index()] = 0;
            }
        }
        // Counting sort of the members by new group, singletons dropped.
        let mut offset = vec![0u32; sizes.len()];
        let mut starts = vec![0u32];
        let mut total = 0u32;
        let mut sum = 0.0;
        for (g, &size) in sizes.iter().enumerate() {
            if size >= 2 {
                offset[g] = total;
                total += size;
                starts.push(total);
                sum += clog[size as usize];
            }
        }
        let mut order = vec![0u32; total as usize];
        for (&k, &id) in members.iter().zip(&label) {
            if sizes[id as usize] >= 2 {
                order[offset[id as usize] as usize] = k;
                offset[id as usize] += 1;
            }
        }
        self.set_groups(order, starts);
        self.sum_clog = sum;
    }
}

/// `H = log2 N - (1/N) sum c log2 c`; exactly 0 for a single group.
pub(crate) fn entropy_of(n: usize, sum_clog: f64) -> f64 {
    if n < 2 {
        return 0.0;
    }
    let h = (n as f64).log2() - sum_clog / n as f64;
    h.max(0.0)
}
