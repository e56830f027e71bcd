//! k-nearest-neighbour search with a distance cap: near child first, far child only when its splitting
//! plane is within the current bound; candidates gather in an unsorted buffer of up to 2k that a partial
//! selection trims back to the k nearest (reusable, no allocation per query). For k larger than a
//! bucket the search starts from a radius guessed from the local density (see `knn`).
use super::KdTree;

// A bucket's points are picked out by a 32-bit mask.
const _: () = assert!(super::BUCKET == 32);

/// How many points the guessed starting ball should hold, per point asked for: the margin that makes
/// a second pass rare where the density is even (about 1 query in 25 on uniform points, 1M, k = 50).
const GUESS_MARGIN: f32 = 1.5;
/// The density is read off the deepest cell on the query's path holding at least this many times the
/// ball's points: large enough that the ball is small beside the cell, local enough to follow the photons.
const GUESS_CELL: f32 = 16.0;

/// Reusable query buffers: the candidates (squared distance, tree index) and the traversal stack.
#[derive(Default, Debug, Clone)]
pub struct KnnResult {
    found: Vec<(f32, u32)>,
    stack: Vec<Entry>,
    /// Queries so far by how they ended: [no guess, in the guessed ball, in the ball widened once,
    /// by a search from an open bound after the guess fell short].
    paths: [u64; 4],
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

    /// Queries answered with this buffer so far, by path: [no guess (k ≤ a bucket, k ≥ the tree's
    /// size, or the guess reached the cap), within the guessed ball, within the ball widened once,
    /// by a full search].
    pub fn paths(&self) -> [u64; 4] {
        self.paths
    }

    /// Squared distances in increasing order (for tests and tools).
    pub fn sorted_d2(&self) -> Vec<f32> {
        let mut v: Vec<f32> = self.found.iter().map(|e| e.0).collect();
        v.sort_by(f32::total_cmp);
        v
    }
}

/// Which of a bucket's points (the first `n` squared distances of `d2s`) lie within `bound`, as a bit
/// mask: d2 < bound, or d2 ≤ bound with `ties`. One vector compare over the whole buffer (entries past
/// `n` are masked off), so that only the points kept cost a scalar step.
#[inline(always)]
pub(super) fn within_mask(d2s: &[f32; super::BUCKET], n: usize, bound: f32, ties: bool) -> u32 {
    let mut mask = 0u32;
    for (i, &d2) in d2s.iter().enumerate() {
        mask |= ((d2 < bound || (ties && d2 == bound)) as u32) << i;
    }
    mask & u32::MAX.checked_shr((super::BUCKET - n) as u32).unwrap_or(0)
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

    /// Squared radius around `q` expected to hold `want` points: the density of the deepest boxed node
    /// on `q`'s path that holds at least `GUESS_CELL` × `want` points, over the bounding box of those
    /// points. Read as points filling the box, or lying on a plane or a line along its longest sides,
    /// whichever gives the largest ball, so photons on a surface are not taken for a sparse volume.
    /// None for trees too small to have boxes, or points all in one place.
    fn density_r2(&self, q: [f32; 3], want: f32) -> Option<f32> {
        if self.boxes.is_empty() {
            return None;
        }
        let (mut node, mut a, mut b) = (0usize, 0u32, self.len() as u32);
        while 2 * node + 2 < self.boxes.len() && ((b - a) / 2) as f32 >= GUESS_CELL * want {
            let mid = Self::mid(a, b);
            if q[self.axes[node] as usize] < self.splits[node] {
                node = 2 * node + 1;
                b = mid;
            } else {
                node = 2 * node + 2;
                a = mid;
            }
        }
        let bx = &self.boxes[node];
        let frac = want / (b - a) as f32;
        let mut e = [bx[3] - bx[0], bx[4] - bx[1], bx[5] - bx[2]];
        e.sort_by(f32::total_cmp);
        // The ball's radius if the points fill the cell's volume, or lie on a plane or a line along its
        // longest sides; the largest of the three (a ball thinner than the cell picks the first).
        let r3 = (frac * e[0] * e[1] * e[2] * (3.0 / (4.0 * std::f32::consts::PI))).cbrt();
        let r2 = (frac * e[1] * e[2] / std::f32::consts::PI).sqrt();
        let r1 = 0.5 * frac * e[2];
        let r = r3.max(r2).max(r1);
        (r.is_finite() && r > 0.0).then_some(r * r)
    }

    /// Gathers candidates within `bound0` into `res.found`, trimming to the k nearest whenever the
    /// buffer fills; `seek` = no bound yet, so the first k found set one. Returns how many are held.
    fn gather(&self, q: [f32; 3], k: usize, bound0: f32, seek: bool, res: &mut KnnResult) -> usize {
        // Never more slots than points: k beyond the tree's size only means "all within the radius".
        let cap = 2 * k.min(self.len()).max(super::BUCKET);
        // Room for a whole bucket past `cap`: a bucket's points are written before the buffer is trimmed.
        res.found.clear();
        res.found.resize(cap + super::BUCKET, (0.0, 0));
        let mut len = 0usize;
        let mut stack = std::mem::take(&mut res.stack);
        let mut d2s = [0.0f32; super::BUCKET];
        let mut have_bound = false;
        self.traverse(q, bound0, &mut stack, |lo, hi, bound| {
            let n = self.bucket_d2(q, lo, hi, &mut d2s);
            let b = *bound;
            // Only the points within the bound are written. Once k are known, a tie with the bound
            // cannot change the k smallest distances.
            let mut mask = within_mask(&d2s, n, b, !have_bound);
            let slots = &mut res.found[len..len + n];
            let mut kept = 0usize;
            while mask != 0 {
                let i = mask.trailing_zeros();
                slots[kept] = (d2s[i as usize], lo + i);
                kept += 1;
                mask &= mask - 1;
            }
            len += kept;
            if len >= cap || (seek && !have_bound && len >= k) {
                *bound = select_k(&mut res.found[..len], k);
                len = k;
                have_bound = true;
            }
        });
        res.stack = stack;
        len
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
        // Starting from an open bound, the search learns its radius from the first buckets it meets,
        // which lie around the query unevenly, and scans about 40% more buckets than the final ball
        // touches (1M uniform points, k = 50). Past a bucket's worth of points it guesses the radius
        // instead and gathers what lies inside: if that holds k, the k nearest are among them.
        // (With k at least the tree's size every point is in the answer: nothing to guess.)
        let guess =
            (k > super::BUCKET && k < self.len()).then(|| self.density_r2(q, k as f32 * GUESS_MARGIN)).flatten();
        self.knn_from(q, k, max_r2, guess, res)
    }

    /// `knn` from a given guess of the squared radius (None: search from an open bound).
    fn knn_from(&self, q: [f32; 3], k: usize, max_r2: f32, guess: Option<f32>, res: &mut KnnResult) -> f32 {
        let (mut len, path) = match guess.filter(|&r2| r2 < max_r2) {
            Some(r2) => {
                let mut len = self.gather(q, k, r2, false, res);
                let mut path = 1;
                // Too few: widen the ball once by the shortfall (in volume, with the same margin),
                // unless it held under a quarter of k (then the guess says little) or would pass the cap.
                // (The widened radius is only worked out here: `powf` is a library call.)
                if len < k && len * 4 >= k {
                    let wide = r2 * (GUESS_MARGIN * k as f32 / (len as f32 + 1.0)).powf(2.0 / 3.0);
                    if wide < max_r2 {
                        len = self.gather(q, k, wide, false, res);
                        path = 2;
                    }
                }
                if len < k {
                    len = self.gather(q, k, max_r2, true, res);
                    path = 3;
                }
                (len, path)
            }
            None => (self.gather(q, k, max_r2, true, res), 0),
        };
        res.paths[path] += 1;
        res.found.truncate(len);
        if len > k {
            select_k(&mut res.found, k);
            res.found.truncate(k);
            len = k;
        }
        if len == k {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Points at x = 1, 2, …, 1000 on a line, queried at the origin: the k nearest are x = 1 … k.
    fn line() -> KdTree<u32> {
        KdTree::build((1..=1000).map(|i| ([i as f32, 0.0, 0.0], i)).collect()).unwrap()
    }

    fn nearest(t: &KdTree<u32>, k: usize, max_r2: f32, guess: Option<f32>) -> (Vec<f32>, f32, [u64; 4]) {
        let mut res = KnnResult::new();
        let used = t.knn_from([0.0; 3], k, max_r2, guess, &mut res);
        (res.sorted_d2(), used, res.paths)
    }

    fn squares(n: usize) -> Vec<f32> {
        (1..=n).map(|i| (i * i) as f32).collect()
    }

    #[test]
    fn each_guess_path_gives_the_exact_k_nearest() {
        let t = line();
        let inf = f32::INFINITY;
        // No guess; a guess holding k or more; one holding 20 of 50 (widened to r ≈ 30.6, still short:
        // then a search from an open bound); one holding 45 (widened to r ≈ 53.0, enough); one holding 5
        // (under a quarter: straight to the search).
        for (guess, path) in [(None, 0), (Some(60.0f32), 1), (Some(20.0), 3), (Some(45.0), 2), (Some(5.0), 3)] {
            let (d2, used, paths) = nearest(&t, 50, inf, guess.map(|r| r * r));
            assert_eq!(d2, squares(50), "guess {guess:?}");
            assert_eq!(used, 2500.0);
            let mut want = [0; 4];
            want[path] = 1;
            assert_eq!(paths, want, "guess {guess:?}");
        }
        // k as large as the tree: every point, found without a guess (which could only fall short).
        let mut res = KnnResult::new();
        assert_eq!(t.knn([0.0; 3], 1000, inf, &mut res), 1e6);
        assert_eq!((res.sorted_d2(), res.paths), (squares(1000), [1, 0, 0, 0]));
        // A cap below the k-th distance: all within the cap, whatever the guess; a guess beyond the cap
        // is not used.
        for guess in [None, Some(10.0f32), Some(30.0), Some(1000.0)] {
            let (d2, used, _) = nearest(&t, 50, 900.0, guess.map(|r| r * r));
            assert_eq!(d2, squares(30), "guess {guess:?}");
            assert_eq!(used, 900.0);
        }
    }

    #[test]
    fn density_guess_reads_a_plane_of_photons_as_a_plane() {
        // 64k photons on a 1 × 1 floor (y = 0) and as many on a wall (x = 0) 1 tall: near the floor's
        // middle 75 photons lie within r² = 75 / (π · 64k); a volume's reading of the same box would be
        // far off (the floor's box is flat, and taken for a volume it holds its points in no space).
        let mut r = crate::math::Rng::new(3, 0, 0);
        let mut pts = Vec::new();
        for i in 0..131_072u32 {
            let (a, b) = (r.next_f32(), r.next_f32());
            pts.push((if i % 2 == 0 { [a, 0.0, b] } else { [0.0, a, b] }, i));
        }
        let t = KdTree::build(pts).unwrap();
        let r2 = t.density_r2([0.5, 0.0, 0.5], 75.0).unwrap();
        let want = 75.0 / (std::f32::consts::PI * 65_536.0);
        assert!((r2 / want - 1.0).abs() < 0.25, "guessed r² {r2}, a plane's {want}");
    }
}
