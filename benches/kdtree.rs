//! Our k-d tree against kiddo in the same run: build at 1M and 10M photons (2 threads both), and k-NN
//! queries (1 thread) for k = 50 / 200 / 1000, with and without a radius cap, on uniform photons and
//! on a caustic-like set. Read the ratios from the paired lines ("ours" / "kiddo").
use caustica::photon::distributions::{points, queries, Distribution};
use caustica::photon::kdtree::{KdTree, KnnResult};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use std::hint::black_box;
use std::num::NonZeroUsize;

fn build(c: &mut Criterion) {
    let mut g = c.benchmark_group("build");
    g.sample_size(10);
    for n in [1_000_000usize, 10_000_000] {
        let pts = points(Distribution::Uniform, n, 1);
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::new("ours", n), &pts, |b, pts| {
            b.iter_batched(
                || pts.iter().enumerate().map(|(i, p)| (*p, i as u32)).collect::<Vec<_>>(),
                |v| KdTree::build(v).unwrap(),
                criterion::BatchSize::LargeInput,
            )
        });
        g.bench_with_input(BenchmarkId::new("kiddo", n), &pts, |b, pts| {
            b.iter(|| ImmutableKdTree::<f32, 3>::new_from_slice_parallel(pts).unwrap())
        });
    }
    g.finish();
}

fn knn(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    for (dist, name) in [(Distribution::Uniform, "uniform"), (Distribution::Caustic, "caustic")] {
        let pts = points(dist, 1_000_000, 1);
        let qs = queries(dist, 10_000, 2);
        let ours = KdTree::build(pts.iter().enumerate().map(|(i, p)| (*p, i as u32)).collect()).unwrap();
        let theirs = ImmutableKdTree::<f32, 3>::new_from_slice(&pts).unwrap();
        let mut g = c.benchmark_group(format!("knn_{name}"));
        g.throughput(Throughput::Elements(qs.len() as u64));
        // The cap for "capped": the radius holding about k/2 photons on average (uniform: r³ ∝ k).
        for (k, capped) in [(50usize, false), (200, false), (200, true), (1000, false)] {
            let r2 = if capped {
                (0.5 * k as f32 / 1e6 * 3.0 / (4.0 * std::f32::consts::PI)).powf(2.0 / 3.0)
            } else {
                f32::INFINITY
            };
            let id = format!("k{k}{}", if capped { "_capped" } else { "" });
            let kk = NonZeroUsize::new(k).unwrap();
            g.bench_function(BenchmarkId::new("ours", &id), |b| {
                let mut res = KnnResult::new();
                b.iter(|| {
                    pool.install(|| {
                        let mut s = 0usize;
                        for q in &qs {
                            ours.knn(*q, k, r2, &mut res);
                            s += res.len();
                        }
                        black_box(s)
                    })
                })
            });
            g.bench_function(BenchmarkId::new("kiddo", &id), |b| {
                b.iter(|| {
                    pool.install(|| {
                        let mut s = 0usize;
                        for q in &qs {
                            let f = if capped {
                                theirs.query(q).nearest_n::<SquaredEuclidean<f32>>(kk).within(r2).execute()
                            } else {
                                theirs.query(q).nearest_n::<SquaredEuclidean<f32>>(kk).execute()
                            };
                            s += f.len();
                        }
                        black_box(s)
                    })
                })
            });
        }
        g.finish();
    }
}

// No plots: criterion's plotting back end (without gnuplot) needs a system font to label its charts and
// panics without one (a fresh Debian has none); the figures are read from the console.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = build, knn
}
criterion_main!(benches);
