//! Fixed-radius search: every point with squared distance ≤ r² from the query, into a reusable buffer.
use super::knn::{within_mask, Entry};
use super::KdTree;

impl<T> KdTree<T> {
    /// Appends (squared distance, tree index) of every point within `r2` of `q` to `out` (cleared first).
    pub fn within(&self, q: [f32; 3], r2: f32, out: &mut Vec<(f32, u32)>, stack: &mut Vec<Entry>) {
        out.clear();
        let mut d2s = [0.0f32; super::BUCKET];
        self.traverse(q, r2, stack, |lo, hi, _bound| {
            let n = self.bucket_d2(q, lo, hi, &mut d2s);
            let mut mask = within_mask(&d2s, n, r2, true);
            while mask != 0 {
                let i = mask.trailing_zeros();
                out.push((d2s[i as usize], lo + i));
                mask &= mask - 1;
            }
        });
    }
}

/// Traversal stack for `within`, reusable across queries.
pub type Stack = Vec<Entry>;
