//! The hand-written k-d tree against two oracles: a brute-force scan (exact squared distances) and
//! kiddo. For every query the sorted squared distances must be identical (ties may pick other points).
use caustica::photon::kdtree::{KdTree, KnnResult, Stack};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use proptest::prelude::*;
use std::num::NonZeroUsize;

fn d2(a: [f32; 3], b: [f32; 3]) -> f32 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    let dz = a[2] - b[2];
    dx * dx + dy * dy + dz * dz
}

fn brute_knn(pts: &[[f32; 3]], q: [f32; 3], k: usize, r2: f32) -> Vec<f32> {
    let mut d: Vec<f32> = pts.iter().map(|p| d2(*p, q)).filter(|&x| x <= r2).collect();
    d.sort_by(f32::total_cmp);
    d.truncate(k);
    d
}

fn kiddo_knn(t: &ImmutableKdTree<f32, 3>, q: [f32; 3], k: usize, r2: f32) -> Vec<f32> {
    let k = NonZeroUsize::new(k).unwrap();
    let found = if r2.is_finite() {
        t.query(&q).nearest_n::<SquaredEuclidean<f32>>(k).within(r2).execute()
    } else {
        t.query(&q).nearest_n::<SquaredEuclidean<f32>>(k).execute()
    };
    let mut d: Vec<f32> = found.iter().map(|r| r.distance).collect();
    d.sort_by(f32::total_cmp);
    d
}

/// Checks every query kind on one point set; returns an error message on the first disagreement.
fn check(pts: &[[f32; 3]], queries: &[[f32; 3]], k: usize, r2: f32) -> Result<(), String> {
    let tree =
        KdTree::build(pts.iter().enumerate().map(|(i, p)| (*p, i as u32)).collect()).map_err(|e| e.to_string())?;
    if tree.len() != pts.len() {
        return Err(format!("tree holds {} of {} points", tree.len(), pts.len()));
    }
    let kid = (!pts.is_empty()).then(|| ImmutableKdTree::<f32, 3>::new_from_slice(pts).unwrap());
    let mut res = KnnResult::new();
    let mut within = Vec::new();
    let mut stack = Stack::new();
    for &q in queries {
        let used = tree.knn(q, k, r2, &mut res);
        let ours = res.sorted_d2();
        let want = brute_knn(pts, q, k, r2);
        if ours != want {
            return Err(format!("knn k={k} r2={r2} q={q:?}: ours {ours:?} brute {want:?}"));
        }
        // Every returned index must really be at the distance reported.
        for &(dd, i) in res.items() {
            if d2(tree.position(i), q) != dd || d2(pts[*tree.item(i) as usize], q) != dd {
                return Err(format!("index {i} does not match its distance {dd}"));
            }
        }
        let expect_used = if want.len() == k && k > 0 {
            *want.last().unwrap()
        } else if k == 0 {
            0.0
        } else {
            r2
        };
        if used != expect_used {
            return Err(format!("radius used {used}, expected {expect_used}"));
        }
        if let Some(kt) = &kid {
            if k > 0 {
                let theirs = kiddo_knn(kt, q, k, r2);
                if theirs != want {
                    return Err(format!("kiddo disagrees with brute force: {theirs:?} vs {want:?}"));
                }
            }
        }
        tree.within(q, r2, &mut within, &mut stack);
        let mut w: Vec<f32> = within.iter().map(|e| e.0).collect();
        w.sort_by(f32::total_cmp);
        if w != brute_knn(pts, q, usize::MAX, r2) {
            return Err(format!("within r2={r2} q={q:?} differs from brute force"));
        }
        let best = pts.iter().map(|p| d2(*p, q)).min_by(f32::total_cmp);
        if tree.nearest(q, &mut res).map(|x| x.1) != best {
            return Err(format!("nearest at {q:?} differs"));
        }
        // The nearest point a predicate accepts (here: a third of the points, by their coordinates),
        // within the cap: what the radiance cache asks for.
        let pick = |p: [f32; 3]| p[0].to_bits().is_multiple_of(3);
        let best_where =
            pts.iter().filter(|p| pick(**p)).map(|p| d2(*p, q)).filter(|x| *x <= r2).min_by(f32::total_cmp);
        let got = tree.nearest_where(q, r2, &mut res, |i, _| pick(tree.position(i)));
        if got.map(|x| x.1) != best_where {
            return Err(format!("nearest_where at {q:?} r2={r2}: {got:?}, brute force {best_where:?}"));
        }
        if let Some((i, d)) = got {
            if !pick(tree.position(i)) || d2(tree.position(i), q) != d {
                return Err(format!("nearest_where returned a point it should not have: {i}"));
            }
        }
    }
    Ok(())
}

#[derive(Debug, Clone, Copy)]
enum Shape {
    Uniform,
    Clustered,
    Plane,
    Line,
    Identical,
    Duplicates,
}

fn gen_points(shape: Shape, n: usize, scale: f32, seed: u64) -> Vec<[f32; 3]> {
    let mut r = caustica::math::Rng::new(seed, 11, 0);
    let mut u = move || r.next_f32() * scale;
    match shape {
        Shape::Uniform => (0..n).map(|_| [u(), u(), u()]).collect(),
        Shape::Clustered => {
            let centres: Vec<[f32; 3]> = (0..4).map(|_| [u(), u(), u()]).collect();
            (0..n)
                .map(|i| {
                    let c = centres[i % 4];
                    [c[0] + u() * 0.01, c[1] + u() * 0.01, c[2] + u() * 0.01]
                })
                .collect()
        }
        Shape::Plane => (0..n).map(|_| [u(), 0.5 * scale, u()]).collect(),
        Shape::Line => (0..n)
            .map(|_| {
                let t = u();
                [t, 2.0 * t, 0.25 * scale]
            })
            .collect(),
        Shape::Identical => vec![[0.3 * scale, 0.3 * scale, 0.3 * scale]; n],
        Shape::Duplicates => {
            (0..n).map(|_| [(u() * 4.0 / scale).floor() * scale / 4.0, 0.0, (u() * 4.0 / scale).floor()]).collect()
        }
    }
}

fn shape_strategy() -> impl Strategy<Value = Shape> {
    prop_oneof![
        Just(Shape::Uniform),
        Just(Shape::Clustered),
        Just(Shape::Plane),
        Just(Shape::Line),
        Just(Shape::Identical),
        Just(Shape::Duplicates)
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, rng_seed: proptest::test_runner::RngSeed::Fixed(0xCA05), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn knn_within_nearest_match_brute_force_and_kiddo(
        shape in shape_strategy(),
        n in prop_oneof![Just(0usize), Just(1), Just(2), 3usize..40, 40usize..600],
        k in prop_oneof![Just(0usize), Just(1), 2usize..30, Just(700)],
        radius in prop_oneof![Just(0.0f32), Just(f32::INFINITY), 0.0f32..0.5],
        scale_exp in -6i32..=6,
        seed in any::<u64>(),
    ) {
        let scale = 10f32.powi(scale_exp);
        let pts = gen_points(shape, n, scale, seed);
        let mut qs = gen_points(Shape::Uniform, 4, scale, seed ^ 0x55);
        // Query exactly at stored points too (distance 0, ties).
        qs.extend(pts.iter().take(2));
        let r = radius * scale;
        let r2 = if r.is_finite() { r * r } else { f32::INFINITY };
        prop_assert_eq!(check(&pts, &qs, k, r2), Ok(()));
    }
}

#[test]
fn large_clustered_and_caustic_sets_agree() {
    use caustica::photon::distributions::{points, queries, Distribution};
    for d in [Distribution::Uniform, Distribution::Clustered, Distribution::Plane, Distribution::Caustic] {
        let pts = points(d, 50_000, 3);
        let qs = queries(d, 200, 4);
        for (k, r2) in [(1, f32::INFINITY), (50, f32::INFINITY), (200, 1e-4), (1000, f32::INFINITY)] {
            check(&pts, &qs, k, r2).unwrap_or_else(|e| panic!("{d:?}: {e}"));
        }
    }
}

#[test]
fn non_finite_positions_are_refused_with_their_count() {
    let mut pts: Vec<([f32; 3], u32)> = (0..100).map(|i| ([i as f32, 0.0, 0.0], i)).collect();
    pts[3].0[1] = f32::NAN;
    pts[50].0[2] = f32::NEG_INFINITY;
    let err = KdTree::build(pts).err().expect("must refuse");
    assert!(err.to_string().contains("2 of 100"), "{err}");
}

/// Past a bucket's worth of neighbours the search starts from a radius guessed from the local density,
/// widens it once when it falls short, and searches from an open bound when the guess says little.
/// Every path must give the exact k nearest; the point set is chosen so that each path is taken.
#[test]
fn guessed_radius_paths_all_give_the_exact_k_nearest() {
    use caustica::photon::distributions::{points, queries, Distribution};
    let pts = points(Distribution::Clustered, 50_000, 7);
    let tree = KdTree::build(pts.iter().enumerate().map(|(i, p)| (*p, i as u32)).collect()).unwrap();
    let mut qs = queries(Distribution::Clustered, 3000, 8);
    // Far outside every cluster: the guessed ball there holds nothing.
    qs.extend([[5.0, 5.0, 5.0], [-3.0, 0.5, 0.5], [0.5, 0.5, 40.0]]);
    let mut res = KnnResult::new();
    for (k, r2) in [(10, f32::INFINITY), (50, f32::INFINITY), (120, f32::INFINITY), (50, 4e-4)] {
        for &q in &qs {
            tree.knn(q, k, r2, &mut res);
            assert_eq!(res.sorted_d2(), brute_knn(&pts, q, k, r2), "k = {k}, r2 = {r2}, q = {q:?}");
        }
    }
    let paths = res.paths();
    assert!(paths.iter().all(|&n| n > 0), "every path taken at least once: {paths:?}");
}
