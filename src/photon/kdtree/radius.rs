//! Fixed-radius search: every point with squared distance ≤ r² from the query, into a reusable buffer.
use super::knn::Entry;
use super::KdTree;

impl<T> KdTree<T> {
    /// Appends (squared distance, tree index) of every point within `r2` of `q` to `out` (cleared first).
    pub fn within(&self, q: [f32; 3], r2: f32, out: &mut Vec<(f32, u32)>, stack: &mut Vec<Entry>) {
        out.clear();
        let mut d2s = [0.0f32; super::BUCKET];
        self.traverse(q, r2, stack, |lo, hi, _bound| {
            let n = self.bucket_d2(q, lo, hi, &mut d2s);
            for (i, &d2) in d2s[..n].iter().enumerate() {
                if d2 <= r2 {
                    out.push((d2, lo + i as u32));
                }
            }
        });
    }
}

/// Traversal stack for `within`, reusable across queries.
pub type Stack = Vec<Entry>;
