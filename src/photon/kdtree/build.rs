//! Tree construction: median split by `select_nth_unstable_by`, axis = largest extent of the node's
//! box unless the median sits on the box's face on that axis (a plane of photons), in parallel with rayon.
use super::{KdError, KdTree, BUCKET};

/// Ranges at least this large are split on two threads.
const PARALLEL_MIN: usize = 1 << 15;

struct Work<'a, T> {
    pts: &'a mut [([f32; 3], T)],
    splits: &'a [std::sync::atomic::AtomicU32],
    axes: &'a [std::sync::atomic::AtomicU8],
    /// Bounding boxes of the points under the nodes that have one (min x, y, z, max x, y, z).
    boxes: &'a [[std::sync::atomic::AtomicU32; 6]],
}

impl<T: Copy + Default + Send + Sync> KdTree<T> {
    /// Builds the tree; refuses non-finite positions (with their count).
    pub fn build(points: Vec<([f32; 3], T)>) -> Result<KdTree<T>, KdError> {
        let n = points.len();
        if n >= u32::MAX as usize {
            return Err(KdError::TooMany(n));
        }
        let bad = points.iter().filter(|(p, _)| !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite())).count();
        if bad > 0 {
            return Err(KdError::NonFinite { count: bad, total: n });
        }
        let leaves = n.div_ceil(BUCKET).max(1);
        let depth = leaves.next_power_of_two().trailing_zeros();
        let inner = (1usize << depth) - 1;
        let splits: Vec<std::sync::atomic::AtomicU32> = (0..inner).map(|_| Default::default()).collect();
        let axes: Vec<std::sync::atomic::AtomicU8> = (0..inner).map(|_| Default::default()).collect();
        let mut pts = points;
        let boxes: Vec<[std::sync::atomic::AtomicU32; 6]> =
            (0..super::boxed_nodes(depth)).map(|_| Default::default()).collect();
        split_node(Work { pts: &mut pts, splits: &splits, axes: &axes, boxes: &boxes }, 0, 0, depth);
        // Into structure-of-arrays form from the back, a block at a time, shrinking the source as it
        // empties: the points are held about once, not twice, at the peak (the positions' zeroed
        // allocation is only backed by memory where it is written).
        let mut xyz = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
        let mut items = vec![T::default(); n];
        const BLOCK: usize = 1 << 20;
        while !pts.is_empty() {
            let from = pts.len().saturating_sub(BLOCK);
            for (i, (p, item)) in pts.drain(from..).enumerate() {
                for (axis, c) in xyz.iter_mut().zip(p) {
                    axis[from + i] = c;
                }
                items[from + i] = item;
            }
            pts.shrink_to_fit();
        }
        Ok(KdTree {
            xyz,
            items,
            splits: splits.into_iter().map(|a| f32::from_bits(a.into_inner())).collect(),
            axes: axes.into_iter().map(|a| a.into_inner()).collect(),
            depth,
            boxes: boxes.into_iter().map(|b| b.map(|c| f32::from_bits(c.into_inner()))).collect(),
        })
    }
}

/// Chooses the split axis: the largest extent, unless the median coordinate equals the box's min or
/// max on it; then the next axis by extent where it lies strictly inside. `median(a)` gives the median.
pub(super) fn choose_axis(lo: [f32; 3], hi: [f32; 3], mut median: impl FnMut(usize) -> f32) -> usize {
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| (hi[b] - lo[b]).total_cmp(&(hi[a] - lo[a])));
    for &a in &order {
        if hi[a] - lo[a] <= 0.0 {
            break;
        }
        let m = median(a);
        if m > lo[a] && m < hi[a] {
            return a;
        }
    }
    order[0]
}

fn split_node<T: Copy + Send + Sync>(w: Work<'_, T>, node: usize, d: u32, depth: u32) {
    if d == depth {
        return;
    }
    let n = w.pts.len();
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for (p, _) in w.pts.iter() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if let Some(b) = w.boxes.get(node) {
        for (c, v) in b.iter().zip(lo.iter().chain(&hi)) {
            c.store(v.to_bits(), std::sync::atomic::Ordering::Relaxed);
        }
    }
    let mid = n / 2;
    let pts = w.pts;
    let mut last = usize::MAX;
    let axis = choose_axis(lo, hi, |a| {
        pts.select_nth_unstable_by(mid, |x, y| x.0[a].total_cmp(&y.0[a]));
        last = a;
        pts[mid].0[a]
    });
    if last != axis {
        // The last probe partitioned another axis (every axis was degenerate): partition on this one.
        pts.select_nth_unstable_by(mid, |x, y| x.0[axis].total_cmp(&y.0[axis]));
    }
    let split = pts[mid].0[axis];
    w.splits[node].store(split.to_bits(), std::sync::atomic::Ordering::Relaxed);
    w.axes[node].store(axis as u8, std::sync::atomic::Ordering::Relaxed);
    let (left, right) = pts.split_at_mut(mid);
    let (lw, rw) = (
        Work { pts: left, splits: w.splits, axes: w.axes, boxes: w.boxes },
        Work { pts: right, splits: w.splits, axes: w.axes, boxes: w.boxes },
    );
    if n >= PARALLEL_MIN {
        rayon::join(|| split_node(lw, 2 * node + 1, d + 1, depth), || split_node(rw, 2 * node + 2, d + 1, depth));
    } else {
        split_node(lw, 2 * node + 1, d + 1, depth);
        split_node(rw, 2 * node + 2, d + 1, depth);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_of_points_is_not_split_on_its_normal() {
        // Box tall in y, but the y-median sits on the floor (most points at y = 0).
        let lo = [0.0, 0.0, 0.0];
        let hi = [1.0, 5.0, 0.8];
        let a = choose_axis(lo, hi, |a| if a == 1 { 0.0 } else { 0.5 });
        assert_eq!(a, 0);
    }

    #[test]
    fn refuses_non_finite_with_count() {
        let pts = vec![([0.0, 0.0, 0.0], 0u32), ([f32::NAN, 0.0, 0.0], 1), ([0.0, f32::INFINITY, 0.0], 2)];
        assert_eq!(KdTree::build(pts).err(), Some(KdError::NonFinite { count: 2, total: 3 }));
    }

    #[test]
    fn every_split_separates_its_children() {
        let mut r = crate::math::Rng::new(1, 0, 0);
        let pts: Vec<([f32; 3], u32)> =
            (0..5000).map(|i| ([r.next_f32(), (r.next_f32() * 4.0).floor(), r.next_f32()], i)).collect();
        let t = KdTree::build(pts).unwrap();
        fn check(t: &KdTree<u32>, node: usize, lo: u32, hi: u32, d: u32) {
            if d == t.depth {
                assert!(hi - lo <= super::BUCKET as u32 && hi > lo);
                return;
            }
            let m = KdTree::<u32>::mid(lo, hi);
            let (a, s) = (t.axes[node] as usize, t.splits[node]);
            assert!((lo..m).all(|i| t.position(i)[a] <= s));
            assert!((m..hi).all(|i| t.position(i)[a] >= s));
            check(t, 2 * node + 1, lo, m, d + 1);
            check(t, 2 * node + 2, m, hi, d + 1);
        }
        check(&t, 0, 0, t.len() as u32, 0);
    }
}
