//! `caustica bench time-vs-error`: path tracing at a sweep of samples per pixel and photon mapping at a
//! sweep of photon counts and of gather counts, each timed and scored against a cached reference; writes
//! a CSV, a log-log chart of error against seconds (SVG through plotters, PNG drawn here), and the
//! equal-time error ratio PM/PT.
use crate::accel::Accel;
use crate::color::Rgb;
use crate::film::Image;
use crate::metrics::{compare_masked, light_free_pixels};
use crate::output::with_suffix;
use crate::pipeline::{reference, Reference};
use crate::scene::load_scene_with;
use anyhow::Result;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

#[derive(Clone, Debug, Serialize)]
pub struct Run {
    pub series: String,
    pub spp: u32,
    pub photons: u64,
    pub gather: u32,
    pub seconds: f64,
    /// RMSE against the reference with the reference's own noise taken out: √(max(0, raw² − σ²)), σ the
    /// reference mean's RMSE on the same clamped, masked scale (the two are independent, so raw²
    /// estimates true² + σ²).
    pub rmse: f64,
    /// RMSE as measured against the (noisy) reference.
    pub rmse_raw: f64,
    pub rel_mse: f64,
}

pub struct Options<'a> {
    pub scene: &'a Path,
    pub budget_s: f64,
    /// Sweeps to run: pt, pm, ppm, sppm, bdpt, vcm.
    pub methods: &'a [String],
    pub reference: crate::pipeline::RefKind,
    pub out: &'a Path,
    pub quiet: bool,
    /// Scene overrides applied to every render and to the reference (e.g. a smaller resolution).
    pub sets: &'a [String],
    /// Overrides applied after `sets` to the timed renders only.
    pub sweep_sets: &'a [String],
    /// Overrides applied after `sets` to the reference only (part of its cache key).
    pub ref_sets: &'a [String],
}

/// PT's RMSE at `t` seconds, interpolated log-log between its runs (extrapolated with the Monte Carlo
/// slope −1/2 beyond them).
pub fn pt_rmse_at(pt: &[Run], t: f64) -> Option<f64> {
    let first = pt.first()?;
    let last = pt.last()?;
    if t <= first.seconds {
        return Some(first.rmse * (first.seconds / t).sqrt());
    }
    if t >= last.seconds {
        return Some(last.rmse * (last.seconds / t).sqrt());
    }
    let w = pt.windows(2).find(|w| w[0].seconds <= t && t <= w[1].seconds)?;
    let f = (t.ln() - w[0].seconds.ln()) / (w[1].seconds.ln() - w[0].seconds.ln()).max(1e-12);
    Some((w[0].rmse.ln() + f * (w[1].rmse.ln() - w[0].rmse.ln())).exp())
}

/// What every sweep shares: the scene's accelerator, the clamped reference, the scored pixels.
struct Sweep<'a> {
    o: &'a Options<'a>,
    accel: Accel,
    keep: Vec<bool>,
    reference: Image,
    /// Variance of the reference mean on the scoring scale (clamped, masked).
    ref_var: f64,
    /// Seconds each of the sweeps may spend.
    share: f64,
    /// The overrides of every timed render: `--set`, then `--sweep-set`.
    sets: Vec<String>,
    pb: indicatif::ProgressBar,
}

/// Radiance clamped to the displayable range [0, 1]: a light's mirror image counts for what it looks
/// like, not for the thousands its radiance would weigh in a squared error.
fn clamp(img: &Image) -> Image {
    Image { pixels: img.pixels.iter().map(|p| p.clamp(Rgb::ZERO, Rgb::ONE)).collect(), ..img.clone() }
}

impl Sweep<'_> {
    fn row(&self, series: &str, spp: u32, photons: u64, gather: u32, seconds: f64, img: &Image) -> Result<Run> {
        let e = compare_masked(&clamp(img), &self.reference, &self.keep)
            .ok_or_else(|| anyhow::anyhow!("reference size differs from the scene's resolution"))?;
        self.pb.inc(1);
        let rmse = (e.rmse * e.rmse - self.ref_var).max(0.0).sqrt();
        Ok(Run { series: series.into(), spp, photons, gather, seconds, rmse, rmse_raw: e.rmse, rel_mse: e.rel_mse })
    }

    /// One planned photon-map render with `photons` caustic photons (half as many direct and indirect),
    /// `spp` eye samples and, if given, gather count `k` for every map.
    fn pm_run(&self, photons: u64, spp: u32, gather: Option<u32>) -> Result<(f64, Image)> {
        let mut sets = self.sets.clone();
        sets.extend([
            format!("render.pm_spp={spp}"),
            format!("render.photons.caustic={photons}"),
            format!("render.photons.indirect={}", photons / 2),
            format!("render.photons.direct={}", photons / 2),
        ]);
        if let Some(k) = gather {
            sets.extend(["caustic", "indirect", "direct"].map(|m| format!("render.gather.{m}={k}")));
        }
        let s = load_scene_with(self.o.scene, &sets)?;
        let out = crate::pipeline::render_pm_default(&s, &self.accel, true)?;
        Ok((out.seconds, out.image))
    }

    fn path_tracing(&self, base: &crate::scene::Scene, runs: &mut Vec<Run>) -> Result<()> {
        let mut spent = 0.0;
        for spp in (0..12).map(|i| 1u32 << i) {
            if spent > self.share {
                break;
            }
            let out = crate::pipeline::render_path(base, &self.accel, spp, true);
            spent += out.seconds;
            runs.push(self.row("PT", spp, 0, 0, out.seconds, &out.image)?);
        }
        Ok(())
    }

    /// Photons ×4 and eye samples ×2 per step: both halves of PM's error (density blur, eye-pass noise)
    /// shrink together, the way one would raise quality in practice.
    fn photon_counts(&self, gather: u32, runs: &mut Vec<Run>) -> Result<()> {
        let mut spent = 0.0;
        for (i, p) in (0..8).map(|i| 10_000u64 << (2 * i)).enumerate() {
            if spent > self.share {
                break;
            }
            let spp = 1u32 << i;
            let (secs, img) = self.pm_run(p, spp, None)?;
            spent += secs;
            runs.push(self.row("PM photons", spp, p, gather, secs, &img)?);
        }
        Ok(())
    }

    /// One progressive run (`ppm`, `sppm`, `bdpt` or `vcm`) for the sweep's time share, read after 1, 2,
    /// 4, … passes: the time of a point is the run's own time up to that pass. The photons column counts
    /// photons (light subpaths for bdpt and vcm) shot up to that pass.
    fn progressive(&self, mode: crate::scene::file::Mode, runs: &mut Vec<Run>) -> Result<()> {
        use crate::scene::file::Mode;
        let mut sets = self.sets.clone();
        let name = mode.layer_name();
        sets.push(format!("render.mode=\"{name}\""));
        sets.push("render.progressive.passes=100000".into());
        sets.push(format!("render.progressive.time_s={:?}", self.share));
        let s = load_scene_with(self.o.scene, &sets)?;
        let plan = crate::pipeline::plan_for(&s, &self.accel);
        let marks: Vec<u32> = (0..17).map(|i| 1u32 << i).collect();
        let p = crate::pipeline::render_progressive(&s, &self.accel, &plan, true, &marks)?;
        let per_pass = match mode {
            Mode::Bdpt | Mode::Vcm => {
                crate::integrator::vcm::light_paths(&s, crate::integrator::vcm::VcmOptions::of_scene(&s)) as u64
            }
            _ => s.render.progressive.photons_per_pass,
        };
        let series = name.to_uppercase();
        for (i, secs, img) in &p.snapshots {
            runs.push(self.row(&series, *i, per_pass * *i as u64, 0, *secs, img)?);
        }
        // The last pass too, when it was not a power of two.
        if let Some(last) = p.records.last().filter(|r| !marks.contains(&r.pass)) {
            runs.push(self.row(
                &series,
                last.pass,
                per_pass * last.pass as u64,
                0,
                p.output.seconds,
                &p.output.image,
            )?);
        }
        Ok(())
    }

    /// The gather sweep, at the photon count that did best against PT at equal time.
    fn gather_counts(&self, runs: &mut Vec<Run>) -> Result<()> {
        let pt: Vec<Run> = runs.iter().filter(|r| r.series == "PT").cloned().collect();
        let versus_pt = |r: &Run| r.rmse / pt_rmse_at(&pt, r.seconds).unwrap_or(1.0);
        let (photons, spp) = runs
            .iter()
            .filter(|r| r.series == "PM photons")
            .min_by(|a, b| versus_pt(a).total_cmp(&versus_pt(b)))
            .map_or((10_000, 1), |r| (r.photons, r.spp));
        let mut spent = 0.0;
        for k in [10u32, 30, 100, 300, 1000, 3000, 10000] {
            if spent > self.share {
                break;
            }
            let (secs, img) = self.pm_run(photons, spp, Some(k))?;
            spent += secs;
            runs.push(self.row("PM gather", spp, photons, k, secs, &img)?);
        }
        Ok(())
    }
}

pub fn run(o: &Options) -> Result<()> {
    let dir = o.out.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let t0 = Instant::now();
    let r = reference(o.scene, &[o.sets, o.ref_sets].concat(), o.reference, &dir.join("ref"), o.quiet)?;
    eprintln!(
        "reference {} (noise: halves differ by RMSE {:.5}) in {:.1} s",
        r.path.display(),
        r.halves_rmse,
        t0.elapsed().as_secs_f64()
    );
    let sets = [o.sets, o.sweep_sets].concat();
    let base = load_scene_with(o.scene, &sets)?;
    let (w, h) = (base.camera.width, base.camera.height);
    if (r.image.width, r.image.height) != (w, h) {
        anyhow::bail!(
            "{}: the reference size differs from the timed renders' ({}×{} against {w}×{h}); a resolution set by \
             --sweep-set or --ref-set must be set for both, with --set",
            o.scene.display(),
            r.image.width,
            r.image.height
        );
    }
    let accel = Accel::new(&base).map_err(anyhow::Error::msg)?;
    let keep = light_free_pixels(&base, &accel, 4);
    let ref_noise = mean_noise(&r, clamp, &keep).unwrap_or(0.0);
    eprintln!(
        "reference noise on the scoring scale (clamped, lights masked): RMSE {ref_noise:.5}; subtracted in quadrature"
    );
    let sweep = Sweep {
        o,
        accel,
        keep,
        reference: clamp(&r.image),
        ref_var: ref_noise * ref_noise,
        share: o.budget_s / budget_parts(o.methods),
        sets,
        pb: crate::progress::progress(12 + 8 + 7 + 4 * 18, "sweep", o.quiet),
    };
    let mut runs: Vec<Run> = Vec::new();
    let wants = |m: &str| o.methods.iter().any(|x| x == m);
    if wants("pt") {
        sweep.path_tracing(&base, &mut runs)?;
    }
    if wants("pm") {
        sweep.photon_counts(base.render.gather.caustic, &mut runs)?;
        sweep.gather_counts(&mut runs)?;
    }
    use crate::scene::file::Mode;
    for mode in [Mode::Ppm, Mode::Sppm, Mode::Bdpt, Mode::Vcm] {
        if wants(mode.layer_name()) {
            sweep.progressive(mode, &mut runs)?;
        }
    }
    sweep.pb.finish_and_clear();
    report(o, &runs, ref_noise)
}

/// How many equal parts the budget is split into: one each for PT, PPM and SPPM, two for PM (its
/// photon-count and gather-count sweeps); BDPT and VCM get a part on top. All methods: five parts (12 s
/// each of 60 s); `--methods sppm` alone: the whole budget, so one curve can be followed to its end.
pub fn budget_parts(methods: &[String]) -> f64 {
    let wants = |m: &str| methods.iter().any(|x| x == m);
    let parts = ["pt", "ppm", "sppm"].iter().filter(|m| wants(m)).count() + 2 * usize::from(wants("pm"));
    parts.max(1) as f64
}

/// The first line of the CSV `run` writes and `redraw` reads.
const CSV_HEADER: &str = "series,spp,photons,gather,seconds,rmse,rmse_raw,rel_mse";

fn report(o: &Options, runs: &[Run], ref_noise: f64) -> Result<()> {
    let csv = with_suffix(o.out, ".csv");
    let mut text = format!("{CSV_HEADER}\n");
    for r in runs {
        text += &format!(
            "{},{},{},{},{:.4},{:.6},{:.6},{:.6}\n",
            r.series, r.spp, r.photons, r.gather, r.seconds, r.rmse, r.rmse_raw, r.rel_mse
        );
    }
    crate::output::atomic_write(&csv, |tmp| Ok(std::fs::write(tmp, &text)?))?;
    let pt: Vec<Run> = runs.iter().filter(|r| r.series == "PT").cloned().collect();
    println!(
        "{:<11} {:>6} {:>9} {:>6} {:>9} {:>10} {:>10}",
        "series", "spp", "photons", "gather", "seconds", "RMSE", "PM/PT"
    );
    let mut best: Option<(f64, &Run)> = None;
    for r in runs {
        let ratio = if r.series == "PT" { None } else { pt_rmse_at(&pt, r.seconds).map(|p| r.rmse / p) };
        if let Some(x) = ratio {
            if best.is_none_or(|b| x < b.0) {
                best = Some((x, r));
            }
        }
        println!(
            "{:<11} {:>6} {:>9} {:>6} {:>9.3} {:>10.5} {:>10}",
            r.series,
            r.spp,
            r.photons,
            r.gather,
            r.seconds,
            r.rmse,
            ratio.map_or("-".into(), |x| format!("{x:.3}"))
        );
    }
    if let Some((x, r)) = best {
        println!("equal-time RMSE ratio PM/PT: {x:.3} (best PM run: {} photons, gather {}, {:.2} s); reference noise (its mean's RMSE, clamped and masked, subtracted from every score) {ref_noise:.5}", r.photons, r.gather, r.seconds);
    }
    for name in ["PT", "PM photons", "PPM", "SPPM", "BDPT", "VCM"] {
        let s: Vec<&Run> = runs.iter().filter(|r| r.series == name).collect();
        let Some(last) = s.last() else { continue };
        let vs_pt = pt_rmse_at(&pt, last.seconds).map_or("-".into(), |p| format!("{:.3}", last.rmse / p));
        println!(
            "{name:<11} at its largest time ({:.1} s): RMSE {:.5}, ratio to PT {vs_pt}, log-log slope from 4 s on {}",
            last.seconds,
            last.rmse,
            slope(&s, 4.0).map_or("-".into(), |k| format!("{k:.3}"))
        );
    }
    if let Some((t, vcm, best, who)) = vcm_versus_best(runs) {
        println!(
            "VCM at {t:.1} s: RMSE {vcm:.5} = {:.3} × the best of PT, PPM and SPPM there ({who}, {best:.5})",
            vcm / best
        );
    }
    chart_svg(&with_suffix(o.out, ".svg"), runs, &o.scene.display().to_string())?;
    chart_png(&with_suffix(o.out, ".png"), runs, &o.scene.display().to_string())?;
    println!("wrote {}, {}.svg and {}.png", csv.display(), o.out.display(), o.out.display());
    Ok(())
}

const SERIES: [(&str, [f32; 3]); 7] = [
    ("PT", [0.85, 0.2, 0.15]),
    ("PM photons", [0.15, 0.45, 0.85]),
    ("PM gather", [0.2, 0.7, 0.3]),
    ("PPM", [0.75, 0.45, 0.05]),
    ("SPPM", [0.55, 0.2, 0.75]),
    ("BDPT", [0.1, 0.65, 0.7]),
    ("VCM", [0.1, 0.1, 0.1]),
];

/// VCM's last point against the best of PT, PPM and SPPM at the same time (each interpolated log-log
/// between its runs, extrapolated with slope −1/2 beyond them): (seconds, VCM's RMSE, the best RMSE,
/// which series).
pub fn vcm_versus_best(runs: &[Run]) -> Option<(f64, f64, f64, &'static str)> {
    let last = runs.iter().rfind(|r| r.series == "VCM")?;
    let t = last.seconds;
    ["PT", "PPM", "SPPM"]
        .iter()
        .filter_map(|&name| {
            let s: Vec<Run> = runs.iter().filter(|r| r.series == name).cloned().collect();
            pt_rmse_at(&s, t).map(|e| (e, name))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(best, who)| (t, last.rmse, best, who))
}

/// Least-squares slope of log RMSE against log seconds over the runs from `from_s` seconds on (None
/// with fewer than two such runs).
pub fn slope(runs: &[&Run], from_s: f64) -> Option<f64> {
    let pts: Vec<(f64, f64)> =
        runs.iter().filter(|r| r.seconds >= from_s && r.rmse > 0.0).map(|r| (r.seconds.ln(), r.rmse.ln())).collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

fn bounds(runs: &[Run]) -> ((f64, f64), (f64, f64)) {
    let xs = runs.iter().map(|r| r.seconds.max(1e-4));
    let ys = runs.iter().map(|r| r.rmse.max(1e-6));
    let (x0, x1) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
    let (y0, y1) = ys.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
    ((x0 / 1.5, x1 * 1.5), (y0 / 1.5, y1 * 1.5))
}

/// The chart on any plotters backend: log-log axes with labelled ticks at every decade and between,
/// a line and markers per series, a legend.
fn draw_chart<DB: plotters::prelude::DrawingBackend>(
    root: plotters::prelude::DrawingArea<DB, plotters::coord::Shift>,
    runs: &[Run],
    title: &str,
) -> Result<()> {
    use plotters::prelude::*;
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow::anyhow!("chart: {e}");
    let ((x0, x1), (y0, y1)) = bounds(runs);
    root.fill(&WHITE).map_err(e)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(format!("RMSE against time: {title}"), ("sans-serif", 20))
        .margin(14)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(
            (x0..x1).log_scale().with_key_points(ticks(x0, x1, false)).with_light_points(ticks(x0, x1, true)),
            (y0..y1).log_scale().with_key_points(ticks(y0, y1, y1 / y0 < 30.0)).with_light_points(ticks(y0, y1, true)),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("seconds (2 threads, log scale)")
        .y_desc("RMSE against the reference (log scale)")
        .x_label_formatter(&|v| format!("{}", *v as f32))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    for (name, c) in SERIES {
        let col = RGBColor((c[0] * 255.0) as u8, (c[1] * 255.0) as u8, (c[2] * 255.0) as u8);
        let pts: Vec<(f64, f64)> =
            runs.iter().filter(|r| r.series == name).map(|r| (r.seconds.max(1e-4), r.rmse.max(1e-6))).collect();
        if pts.is_empty() {
            continue;
        }
        chart
            .draw_series(LineSeries::new(pts.clone(), col.stroke_width(2)))
            .map_err(e)?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 3, col.filled()))).map_err(e)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}

/// Reads a CSV that `run` wrote (`CSV_HEADER` first) and draws its chart again as OUT.svg and OUT.png.
pub fn redraw(csv: &Path, out: &Path, title: &str) -> Result<()> {
    let text = crate::scene::read_text(csv).map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", csv.display()))?;
    let mut lines = text.lines();
    if lines.next().map(str::trim) != Some(CSV_HEADER) {
        anyhow::bail!("{}: line 1: not a time-vs-error CSV (expected the header `{CSV_HEADER}`)", csv.display());
    }
    let mut runs = Vec::new();
    for (i, line) in lines.enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let bad = |what: &str| anyhow::anyhow!("{}: line {}: {what}", csv.display(), i + 2);
        let f: Vec<&str> = line.split(',').collect();
        let [series, spp, photons, gather, seconds, rmse, rmse_raw, rel_mse] = f[..] else {
            return Err(bad("expected 8 comma-separated fields"));
        };
        let num = |s: &str, name: &str| {
            s.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| bad(&format!("`{name}` is not a number ≥ 0")))
        };
        runs.push(Run {
            series: series.to_string(),
            spp: num(spp, "spp")? as u32,
            photons: num(photons, "photons")? as u64,
            gather: num(gather, "gather")? as u32,
            seconds: num(seconds, "seconds")?,
            rmse: num(rmse, "rmse")?,
            rmse_raw: num(rmse_raw, "rmse_raw")?,
            rel_mse: num(rel_mse, "rel_mse")?,
        });
    }
    if runs.is_empty() {
        anyhow::bail!("{}: no runs to draw", csv.display());
    }
    chart_svg(&with_suffix(out, ".svg"), &runs, title)?;
    chart_png(&with_suffix(out, ".png"), &runs, title)?;
    println!("wrote {}.svg and {}.png", out.display(), out.display());
    Ok(())
}

/// Tick positions on a log axis from `lo` to `hi`: 1, 2 and 5 × 10^k, or every digit × 10^k (`dense`).
fn ticks(lo: f64, hi: f64, dense: bool) -> Vec<f64> {
    let digits: &[f64] = if dense { &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0] } else { &[1.0, 2.0, 5.0] };
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    (k0..=k1).flat_map(|k| digits.iter().map(move |d| d * 10f64.powi(k))).filter(|v| *v >= lo && *v <= hi).collect()
}

/// Registers the bundled font as plotters' "sans-serif" (once).
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, crate::font::FONT);
    });
}

fn chart_svg(path: &Path, runs: &[Run], title: &str) -> Result<()> {
    register_font();
    let mut svg = String::new();
    draw_chart(plotters::prelude::SVGBackend::with_string(&mut svg, (900, 600)).into(), runs, title)?;
    crate::output::atomic_write(path, |tmp| Ok(std::fs::write(tmp, &svg)?))
}

/// The same chart as an 8-bit sRGB PNG, text rasterised from the bundled font.
fn chart_png(path: &Path, runs: &[Run], title: &str) -> Result<()> {
    register_font();
    let (w, h) = (900u32, 600u32);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    draw_chart(plotters::prelude::BitMapBackend::with_buffer(&mut rgb, (w, h)).into(), runs, title)?;
    crate::output::write_png_rgb8(path, w, h, &rgb)
}

/// Two references of one scene compared on the scoring scale (clamped, lights masked), at full
/// resolution and averaged over `BLOCK`×`BLOCK` blocks (where per-pixel noise drowns a small bias).
pub struct Agreement {
    pub scales: Vec<Scale>,
    /// The blocks' differences against their local noise (the verdict on the block scale).
    pub local: LocalNoiseTest,
    /// Per channel, the mean of the first over the mean of the second (masked pixels, unclamped).
    pub mean_ratio: [f64; 3],
}

/// `BLOCK`×`BLOCK` block means compared against the noise where they are: each block's difference d
/// (per channel) over v, the two references' noise variances (from their halves, (h0 − h1)²/4 each)
/// pooled over the 3×3 blocks around it. A caustic or the ring round a light is far noisier than a
/// wall, and a test against the image-wide noise level flags such regions even when only noise
/// differs there; d²/v does not. Pure noise makes d²/v about F(1, ν)-distributed, ν ≥ 9 (nine pooled
/// blocks), so its mean is at most ν/(ν − 2) = 9/7; a bias adds (bias² / v) on top.
pub struct LocalNoiseTest {
    /// Blocks compared (those with kept pixels and some noise or difference).
    pub blocks: usize,
    /// Mean of d²/v over blocks and channels.
    pub chi2: f64,
    /// What noise alone gives on average (9/7).
    pub expected: f64,
    /// Largest mean noise alone makes plausible: `expected` plus three standard deviations of the
    /// mean of `blocks` F(1, 9) values (variance 2·9²·8/(7²·5) each).
    pub allowed: f64,
}

/// One scale of an `Agreement`.
pub struct Scale {
    pub name: String,
    /// RMSE between the two references' means.
    pub rmse: f64,
    /// The RMSE their noises alone would give, √(σa² + σb²) (each σ half its halves' difference).
    pub noise: f64,
    /// The difference beyond that noise, √max(0, RMSE² − σa² − σb²).
    pub excess: f64,
    /// Largest excess pure noise makes plausible: three standard deviations of RMSE² (about
    /// 2·noise⁴/n for n Gaussian values, doubled for the noise figures' own error), √(6/√n)·noise.
    pub allowed: f64,
}

pub const BLOCK: u32 = 8;

/// Averages of the kept pixels over `b`×`b` blocks (blocks with none kept are left out), as a one-row
/// image with its all-kept mask.
fn block_means(img: &Image, keep: &[bool], b: u32) -> Image {
    let pixels: Vec<Rgb> = block_grid(img, keep, b).0.into_iter().flatten().collect();
    Image { width: pixels.len() as u32, height: 1, pixels }
}

/// A reference mean's own RMSE on the scale `view` puts images on (over the `keep` values): its halves
/// differ by d, their mean errs by d/2. None if the halves' sizes do not fit `keep`.
fn mean_noise(r: &Reference, view: impl Fn(&Image) -> Image, keep: &[bool]) -> Option<f64> {
    compare_masked(&view(&r.halves[0]), &view(&r.halves[1]), keep).map(|e| e.rmse / 2.0)
}

impl Agreement {
    /// Whether the pixels differ by no more than noise makes plausible, and the blocks by no more than
    /// their local noise does (the block scale's image-wide figure is for information: with noise that
    /// varies across the image its plausible bound is too tight).
    pub fn agrees(&self) -> bool {
        self.scales.first().is_none_or(|s| s.excess <= s.allowed) && self.local.chi2 <= self.local.allowed
    }
}

/// Per block of `b`×`b` pixels, the mean of its kept pixels (None where none is kept), row by row, and
/// the number of blocks per row.
fn block_grid(img: &Image, keep: &[bool], b: u32) -> (Vec<Option<Rgb>>, usize) {
    let bw = img.width.div_ceil(b);
    let mut sum = vec![(Rgb::ZERO, 0u32); (bw * img.height.div_ceil(b)) as usize];
    for y in 0..img.height {
        for x in 0..img.width {
            let i = (y * img.width + x) as usize;
            if keep[i] {
                let s = &mut sum[((y / b) * bw + x / b) as usize];
                s.0 += img.pixels[i];
                s.1 += 1;
            }
        }
    }
    (sum.iter().map(|s| (s.1 > 0).then(|| s.0 / s.1 as f32)).collect(), bw as usize)
}

/// The local-noise test of two references on `BLOCK`×`BLOCK` blocks of their clamped images.
fn local_noise_test(refs: [&Reference; 2], keep: &[bool]) -> LocalNoiseTest {
    let grid = |img: &Image| block_grid(&clamp(img), keep, BLOCK);
    let ((a, bw), (c, _)) = (grid(&refs[0].image), grid(&refs[1].image));
    // Per block and channel: the noise variance of both means, from each one's halves.
    let mut var = vec![None; a.len()];
    for r in refs {
        let (h0, h1) = (grid(&r.halves[0]).0, grid(&r.halves[1]).0);
        for (v, (x, y)) in var.iter_mut().zip(h0.iter().zip(&h1)) {
            if let (Some(x), Some(y)) = (x, y) {
                let d = (*x - *y).as_dvec3();
                *v = Some(v.unwrap_or(glam::DVec3::ZERO) + d * d / 4.0);
            }
        }
    }
    let bh = a.len() / bw.max(1);
    let (mut sum, mut count) = (0.0f64, 0usize);
    for by in 0..bh {
        for bx in 0..bw {
            let (Some(x), Some(y)) = (a[by * bw + bx], c[by * bw + bx]) else { continue };
            let mut pooled = (glam::DVec3::ZERO, 0u32);
            for ny in by.saturating_sub(1)..(by + 2).min(bh) {
                for nx in bx.saturating_sub(1)..(bx + 2).min(bw) {
                    if let Some(v) = var[ny * bw + nx] {
                        pooled = (pooled.0 + v, pooled.1 + 1);
                    }
                }
            }
            let v = pooled.0 / pooled.1.max(1) as f64;
            let d = (x - y).as_dvec3();
            for k in 0..3 {
                if d[k] == 0.0 && v[k] == 0.0 {
                    continue; // black, or saturated, in both: nothing to compare
                }
                sum += d[k] * d[k] / v[k].max(1e-300);
                count += 1;
            }
        }
    }
    let expected = 9.0 / 7.0;
    let per_value = 2.0 * 81.0 * 8.0 / (49.0 * 5.0);
    LocalNoiseTest {
        blocks: count / 3,
        chi2: sum / count.max(1) as f64,
        expected,
        allowed: expected + 3.0 * (per_value / (count / 3).max(1) as f64).sqrt(),
    }
}

/// Compares two references of `scene` (rendered with the overrides `sets`): whether a consistent
/// estimator's reference (SPPM) agrees with a path-traced one within their noise before it is used.
pub fn reference_agreement(scene: &Path, sets: &[String], refs: [&Reference; 2]) -> Result<Agreement> {
    let base = load_scene_with(scene, sets)?;
    let accel = Accel::new(&base).map_err(anyhow::Error::msg)?;
    let keep = light_free_pixels(&base, &accel, 4);
    let size = || anyhow::anyhow!("{}: the references differ in size from the scene", scene.display());
    let mut scales = Vec::new();
    for b in [1, BLOCK] {
        let view = |img: &Image| if b == 1 { clamp(img) } else { block_means(&clamp(img), &keep, b) };
        let (a, c) = (view(&refs[0].image), view(&refs[1].image));
        let k: Vec<bool> = if b == 1 { keep.clone() } else { vec![true; a.pixels.len()] };
        let d = compare_masked(&a, &c, &k).ok_or_else(size)?.rmse;
        let noise = [mean_noise(refs[0], view, &k).ok_or_else(size)?, mean_noise(refs[1], view, &k).ok_or_else(size)?];
        let expected = (noise[0] * noise[0] + noise[1] * noise[1]).sqrt();
        let excess = (d * d - expected * expected).max(0.0).sqrt();
        let name = if b == 1 { "pixels".to_string() } else { format!("{b}×{b} blocks") };
        let n = (k.iter().filter(|x| **x).count() * 3).max(1) as f64;
        scales.push(Scale { name, rmse: d, noise: expected, excess, allowed: (6.0 / n.sqrt()).sqrt() * expected });
    }
    let mut mean_ratio = [0.0; 3];
    for (c, m) in mean_ratio.iter_mut().enumerate() {
        let mean =
            |img: &Image| img.pixels.iter().zip(&keep).filter(|(_, k)| **k).map(|(p, _)| p[c] as f64).sum::<f64>();
        *m = mean(&refs[0].image) / mean(&refs[1].image).max(1e-300);
    }
    Ok(Agreement { scales, local: local_noise_test(refs, &keep), mean_ratio })
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn the_budget_is_shared_only_by_the_sweeps_that_run() {
        let m = |s: &str| s.split(',').map(String::from).collect::<Vec<_>>();
        assert_eq!(budget_parts(&m("pt,pm,ppm,sppm,bdpt,vcm")), 5.0);
        assert_eq!(budget_parts(&m("sppm")), 1.0);
        assert_eq!(budget_parts(&m("pt,sppm")), 2.0);
        assert_eq!(budget_parts(&m("pm")), 2.0);
        assert_eq!(budget_parts(&m("vcm")), 1.0);
        assert_eq!(budget_parts(&m("bdpt,vcm,pt")), 1.0);
    }
    fn run(s: f64, e: f64) -> Run {
        Run { series: "PT".into(), spp: 1, photons: 0, gather: 0, seconds: s, rmse: e, rmse_raw: e, rel_mse: 0.0 }
    }
    /// A reference of a `size`² image whose true value is `truth(x, y)` and whose mean carries Gaussian
    /// noise of standard deviation `sigma(x, y)` (each half √2 times that).
    fn synthetic(size: u32, truth: impl Fn(u32, u32) -> f32, sigma: impl Fn(u32, u32) -> f32, seed: u64) -> Reference {
        let mut rng = crate::math::Rng::new(seed, 0, 0);
        let mut gauss = || {
            let (u, v) = (rng.next_f32().max(1e-7), rng.next_f32());
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f32::consts::PI * v).cos()
        };
        let mut halves = [Image::new(size, size), Image::new(size, size)];
        for h in halves.iter_mut() {
            for (i, p) in h.pixels.iter_mut().enumerate() {
                let (x, y) = (i as u32 % size, i as u32 / size);
                let s = sigma(x, y) * std::f32::consts::SQRT_2;
                *p = Rgb::new(gauss(), gauss(), gauss()) * s + Rgb::splat(truth(x, y));
            }
        }
        let mut image = Image::new(size, size);
        for (o, (a, b)) in image.pixels.iter_mut().zip(halves[0].pixels.iter().zip(&halves[1].pixels)) {
            *o = (*a + *b) * 0.5;
        }
        Reference { image, halves, halves_rmse: 0.0, path: "synthetic".into(), rendered_s: None }
    }

    #[test]
    fn blocks_are_judged_against_the_noise_where_they_are() {
        // A 256² image, noise 0.02 per pixel except a 64² "caustic" ten times noisier. Unbiased: the
        // local test must accept it (the image-wide bound, blind to where the noise is, need not).
        // The same with the first reference 0.008 darker within 8 pixels of the border (as a gather
        // disc reaching past a wall would make it, 3.2 block standard deviations there): rejected.
        let size = 256;
        let keep = vec![true; (size * size) as usize];
        let sigma = |x: u32, y: u32| if (96..160).contains(&x) && (96..160).contains(&y) { 0.2 } else { 0.02 };
        let edge = |x: u32, y: u32| x.min(y).min(size - 1 - x).min(size - 1 - y) < 8;
        for seed in 0..4 {
            let fair = [synthetic(size, |_, _| 0.5, sigma, 2 * seed), synthetic(size, |_, _| 0.5, sigma, 2 * seed + 1)];
            let t = local_noise_test([&fair[0], &fair[1]], &keep);
            assert!(t.chi2 <= t.allowed, "seed {seed}: unbiased, yet {} > {}", t.chi2, t.allowed);
            assert!((t.chi2 / t.expected - 1.0).abs() < 0.25, "seed {seed}: {} far from {}", t.chi2, t.expected);
            let dark = synthetic(size, |x, y| if edge(x, y) { 0.492 } else { 0.5 }, sigma, 2 * seed);
            let t = local_noise_test([&dark, &fair[1]], &keep);
            assert!(t.chi2 > t.allowed, "seed {seed}: a biased border passed, {} <= {}", t.chi2, t.allowed);
        }
    }

    #[test]
    fn pt_interpolation_follows_the_power_law() {
        let pt = [run(1.0, 1.0), run(4.0, 0.5), run(16.0, 0.25)];
        assert!((pt_rmse_at(&pt, 2.0).unwrap() - 0.5f64.sqrt()).abs() < 1e-9);
        assert!((pt_rmse_at(&pt, 64.0).unwrap() - 0.125).abs() < 1e-9);
        assert!((pt_rmse_at(&pt, 0.25).unwrap() - 2.0).abs() < 1e-9);
    }
}
