//! Placement of transient resources in one heap, sharing memory between disjoint lifetimes.

/// One transient's memory requirement and lifetime (positions in the compiled order).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AliasRequest {
    /// Bytes required.
    pub size: u64,
    /// Required offset alignment (power of two or 0/1 for none).
    pub align: u64,
    /// First pass position using it.
    pub first: usize,
    /// Last pass position using it (inclusive).
    pub last: usize,
}

/// Offsets of every request in a shared heap.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AliasPlan {
    /// Offset of `items[i]`.
    pub offsets: Vec<u64>,
    /// Bytes needed with aliasing.
    pub heap_size: u64,
    /// Bytes needed if every item got its own range (packed in placement order).
    pub unaliased_size: u64,
}

fn align_up(value: u64, align: u64) -> u64 {
    if align <= 1 {
        value
    } else {
        value.div_ceil(align) * align
    }
}

impl AliasRequest {
    fn lifetime_overlaps(&self, other: &AliasRequest) -> bool {
        self.first <= other.last && other.first <= self.last
    }
}

/// Greedy placement: largest first, each at the lowest aligned offset not overlapping any
/// already-placed item whose lifetime overlaps.
///
/// `granularity` (e.g. `bufferImageGranularity`) is applied to every offset because the
/// placer does not know which items are linear.
pub fn place(items: &[AliasRequest], granularity: u64) -> AliasPlan {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| items[b].size.cmp(&items[a].size));
    let mut offsets = vec![0u64; items.len()];
    let mut placed: Vec<usize> = Vec::with_capacity(items.len());
    let mut heap_size = 0u64;
    let mut unaliased_size = 0u64;
    let mut live: Vec<(u64, u64)> = Vec::new();
    for &i in &order {
        let item = &items[i];
        let align = item.align.max(granularity).max(1);
        live.clear();
        live.extend(
            placed
                .iter()
                .filter(|&&j| items[j].lifetime_overlaps(item) && items[j].size > 0)
                .map(|&j| (offsets[j], offsets[j] + items[j].size)),
        );
        live.sort_unstable();
        let mut candidate = 0u64;
        for &(start, end) in &live {
            if align_up(candidate, align) + item.size <= start {
                break;
            }
            candidate = candidate.max(end);
        }
        let offset = align_up(candidate, align);
        offsets[i] = offset;
        heap_size = heap_size.max(offset + item.size);
        unaliased_size = align_up(unaliased_size, align) + item.size;
        placed.push(i);
    }
    AliasPlan { offsets, heap_size, unaliased_size }
}
