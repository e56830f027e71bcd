//! k-nearest-neighbour search with a distance cap: near child first, far child only when its splitting
//! plane is within the current bound; candidates gather in an unsorted buffer of up to 2k that a partial
//! selection trims back to the k nearest (reusable, no allocation per query).
use super::KdTree;

/// Reusable query buffers: the candidates (squared distance, tree index) and the traversal stack.
#[derive(Default, Debug, Clone)]
pub struct KnnResult {
    found: Vec<(f32, u32)>,
    stack: Vec<Entry>,
}

#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// Squared distance from the query to this node's cell (lower bound).
    pub d2: f32,
    /// Per-axis offsets from the query to the cell.
    pub off: [f32; 3],
    pub node: u32,
    pub lo: u32,
    pub hi: u32,
    pub depth: u32,
}

impl KnnResult {
    pub fn new() -> KnnResult {
        KnnResult::default()
    }

    /// The found points as (squared distance, tree index), in no particular order.
    pub fn items(&self) -> &[(f32, u32)] {
        &self.found
    }

    pub fn len(&self) -> usize {
        self.found.len()
    }

    pub fn is_empty(&self) -> bool {
        self.found.is_empty()
    }

    /// Squared distances in increasing order (for tests and tools).
    pub fn sorted_d2(&self) -> Vec<f32> {
        let mut v: Vec<f32> = self.found.iter().map(|e| e.0).collect();
        v.sort_by(f32::total_cmp);
        v
    }
}

/// Moves the `k` smallest entries to the front of `v` and returns the k-th smallest squared distance.
fn select_k(v: &mut [(f32, u32)], k: usize) -> f32 {
    v.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
    v[k - 1].0
}

impl<T> KdTree<T> {
    /// Depth-first, near-child-first traversal. `leaf(lo, hi, bound)` scans a bucket and may tighten
    /// `bound` (squared distance). A subtree is skipped when the squared distance from `q` to its cell,
    /// kept incrementally per axis (Arya & Mount), exceeds the bound.
    #[inline(always)]
    pub(super) fn traverse(
        &self,
        q: [f32; 3],
        mut bound: f32,
        stack: &mut Vec<Entry>,
        mut leaf: impl FnMut(u32, u32, &mut f32),
    ) {
        stack.clear();
        if self.is_empty() {
            return;
        }
        stack.push(Entry { d2: 0.0, off: [0.0; 3], node: 0, lo: 0, hi: self.len() as u32, depth: 0 });
        while let Some(mut e) = stack.pop() {
            if e.d2 > bound {
                continue;
            }
            while e.depth < self.depth {
                let node = e.node as usize;
                let axis = self.axes[node] as usize;
                let diff = q[axis] - self.splits[node];
                let mid = Self::mid(e.lo, e.hi);
                let (near, far) = if diff < 0.0 {
                    ((2 * e.node + 1, e.lo, mid), (2 * e.node + 2, mid, e.hi))
                } else {
                    ((2 * e.node + 2, mid, e.hi), (2 * e.node + 1, e.lo, mid))
                };
                let far_d2 = e.d2 - e.off[axis] * e.off[axis] + diff * diff;
                if far_d2 <= bound {
                    if e.depth + 3 >= self.depth {
                        // The far child's buckets (one to four) will likely be scanned soon: prefetch
                        // them (a hint that does not wait) while the near side is being searched.
                        let (lo, hi) = (far.1 as usize, far.2 as usize);
                        for axis in &self.xyz {
                            let mut i = lo;
                            while i < hi {
                                mem_prefetch::prefetch_read_data::<_, 3>(&axis[i]);
                                i += 16;
                            }
                        }
                    }
                    let mut off = e.off;
                    off[axis] = diff;
                    stack.push(Entry { d2: far_d2, off, node: far.0, lo: far.1, hi: far.2, depth: e.depth + 1 });
                }
                e.node = near.0;
                e.lo = near.1;
                e.hi = near.2;
                e.depth += 1;
            }
            leaf(e.lo, e.hi, &mut bound);
        }
    }

    /// Squared distances from `q` to the points of bucket [lo, hi) into `out` (vectorisable loop).
    #[inline(always)]
    pub(super) fn bucket_d2(&self, q: [f32; 3], lo: u32, hi: u32, out: &mut [f32; super::BUCKET]) -> usize {
        let (lo, hi) = (lo as usize, hi as usize);
        let n = hi - lo;
        let (xs, ys, zs) = (&self.xyz[0][lo..hi], &self.xyz[1][lo..hi], &self.xyz[2][lo..hi]);
        for (((o, x), y), z) in out.iter_mut().zip(xs).zip(ys).zip(zs) {
            let dx = x - q[0];
            let dy = y - q[1];
            let dz = z - q[2];
            *o = dx * dx + dy * dy + dz * dz;
        }
        n
    }

    /// The `k` nearest points to `q` with squared distance ≤ `max_r2` (use f32::INFINITY for no cap).
    /// Returns the squared radius actually used: the k-th distance when k were found, else `max_r2`.
    ///
    /// Candidates go into an unsorted buffer of up to 2k entries; when it fills, a partial selection
    /// keeps the k nearest and tightens the bound (amortised O(1) per candidate, no heap sifting).
    pub fn knn(&self, q: [f32; 3], k: usize, max_r2: f32, res: &mut KnnResult) -> f32 {
        res.found.clear();
        if k == 0 {
            return 0.0;
        }
        // Never more slots than points: k beyond the tree's size only means "all within the radius".
        let cap = 2 * k.min(self.len()).max(super::BUCKET);
        // Slots are written unconditionally and kept by advancing `len` (branch-free compaction).
        res.found.resize(cap + super::BUCKET, (0.0, 0));
        let mut len = 0usize;
        let mut stack = std::mem::take(&mut res.stack);
        let mut d2s = [0.0f32; super::BUCKET];
        let mut have_bound = false;
        self.traverse(q, max_r2, &mut stack, |lo, hi, bound| {
            let n = self.bucket_d2(q, lo, hi, &mut d2s);
            let b = *bound;
            let slots = &mut res.found[len..len + n];
            let mut kept = 0usize;
            for (i, &d2) in d2s[..n].iter().enumerate() {
                slots[kept] = (d2, lo + i as u32);
                // Once k are known, a tie with the bound cannot change the k smallest distances.
                kept += if have_bound { d2 < b } else { d2 <= b } as usize;
            }
            len += kept;
            if len >= cap || (!have_bound && len >= k) {
                *bound = select_k(&mut res.found[..len], k);
                len = k;
                have_bound = true;
            }
        });
        res.stack = stack;
        res.found.truncate(len);
        if len > k {
            select_k(&mut res.found, k);
            res.found.truncate(k);
        }
        if res.found.len() == k {
            res.found.iter().fold(0.0f32, |m, e| m.max(e.0))
        } else {
            max_r2
        }
    }

    /// Every point within squared distance `r2` of `q`, into `res` (its buffers reused).
    pub fn within_res(&self, q: [f32; 3], r2: f32, res: &mut KnnResult) {
        let mut stack = std::mem::take(&mut res.stack);
        self.within(q, r2, &mut res.found, &mut stack);
        res.stack = stack;
    }

    /// The nearest point within squared distance `max_r2` that `accept(index, d2)` takes, if any:
    /// (tree index, squared distance). Only points nearer than the best accepted so far are offered,
    /// so a cheap test prunes as well as a plain nearest-point search.
    pub fn nearest_where(
        &self,
        q: [f32; 3],
        max_r2: f32,
        res: &mut KnnResult,
        mut accept: impl FnMut(u32, f32) -> bool,
    ) -> Option<(u32, f32)> {
        let mut best: Option<(u32, f32)> = None;
        let mut d2s = [0.0f32; super::BUCKET];
        let mut stack = std::mem::take(&mut res.stack);
        self.traverse(q, max_r2, &mut stack, |lo, hi, bound| {
            let n = self.bucket_d2(q, lo, hi, &mut d2s);
            for (i, &d2) in d2s[..n].iter().enumerate() {
                let id = lo + i as u32;
                if d2 <= *bound && best.is_none_or(|b| d2 < b.1) && accept(id, d2) {
                    *bound = d2;
                    best = Some((id, d2));
                }
            }
        });
        res.stack = stack;
        best
    }

    /// The single nearest point, if any: (tree index, squared distance).
    pub fn nearest(&self, q: [f32; 3], res: &mut KnnResult) -> Option<(u32, f32)> {
        self.nearest_where(q, f32::INFINITY, res, |_, _| true)
    }
}
