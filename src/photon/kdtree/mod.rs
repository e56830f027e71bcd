//! Hand-written balanced k-d tree for photons: median splits, implicit heap-ordered split planes (no
//! pointers), leaf buckets of up to `BUCKET` points, coordinates as one array per axis, and items
//! reordered into tree order. Queries: k nearest within a radius, all within a radius, nearest one.
mod build;
mod knn;
mod radius;

pub use knn::KnnResult;
pub use radius::Stack;

/// Points per leaf bucket at most (leaves hold between BUCKET/2 and BUCKET points).
pub const BUCKET: usize = 32;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum KdError {
    #[error("{count} of {total} positions are NaN or infinite; refusing to build the tree")]
    NonFinite { count: usize, total: usize },
    #[error("{0} points exceed the tree's limit of 2^32 − 1")]
    TooMany(usize),
}

/// A balanced k-d tree over 3-D points carrying items of type `T`.
pub struct KdTree<T> {
    /// Coordinates in tree order, one array per axis (x, y, z): a bucket's points are contiguous in
    /// each, so its distances are computed four or eight at a time without shuffles.
    xyz: [Vec<f32>; 3],
    items: Vec<T>,
    /// Split value of internal node i (heap order: children 2i+1, 2i+2).
    splits: Vec<f32>,
    /// Split axis of internal node i.
    axes: Vec<u8>,
    /// Depth of the leaves (all leaves are at this depth; 0 = a single leaf).
    depth: u32,
    /// Bounding box of the points under each node with 32 leaves or more (heap order; min x, y, z,
    /// max x, y, z): the local density that starts a k-nearest search. A guess reads a cell of at least
    /// 24 × (BUCKET + 1) points, so smaller nodes would never be read.
    boxes: Vec<[f32; 6]>,
}

/// How many nodes keep a bounding box in a tree whose leaves are at `depth`: those at depth ≤ depth − 5.
fn boxed_nodes(depth: u32) -> usize {
    if depth >= 5 {
        (1usize << (depth - 4)) - 1
    } else {
        0
    }
}

impl<T> KdTree<T> {
    pub fn len(&self) -> usize {
        self.xyz[0].len()
    }

    pub fn is_empty(&self) -> bool {
        self.xyz[0].is_empty()
    }

    /// Position of the point at tree index `i`.
    pub fn position(&self, i: u32) -> [f32; 3] {
        let i = i as usize;
        [self.xyz[0][i], self.xyz[1][i], self.xyz[2][i]]
    }

    pub fn item(&self, i: u32) -> &T {
        &self.items[i as usize]
    }

    /// Bytes held per point (coordinates, item, split planes, node boxes), the figure the photon map reports.
    pub fn bytes_per_point(&self) -> f64 {
        let n = self.len().max(1) as f64;
        let total = self.len() * (12 + std::mem::size_of::<T>()) + self.splits.len() * 5 + self.boxes.len() * 24;
        total as f64 / n
    }

    /// Range of points under node `node` at depth `d`, given its parent's range split at the midpoint.
    #[inline(always)]
    fn mid(lo: u32, hi: u32) -> u32 {
        lo + (hi - lo) / 2
    }
}
