//! Partial renders (`caustica render --part i/N`) and `caustica merge`: a render split into N
//! independent shares that any scheduler (Slurm job arrays, a shell loop, Kubernetes jobs) can run
//! anywhere, then merged into the image one machine would have made.
//!
//! A part file (`OUT-part-i-of-N.part`) is self-contained:
//!
//! ```text
//! "CSTPART\x01" | header length (u64 LE) | header (JSON, `PartHeader`)
//! | per layer, per pixel: sum R, G, B and weight (f64 LE each) | SHA-256 of everything before it
//! ```
//!
//! The sums are un-normalised (sample sums in f64, weight = samples or passes taken), so merging is
//! adding sums and weights and dividing once, exactly as the single render does. A JSON copy of the
//! header is written beside it for people; `merge` reads only the `.part` files.
use crate::film::{Image, Sums};
use crate::output::{self, with_suffix};
use anyhow::{anyhow, bail, Context, Result};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"CSTPART\x01";
const VERSION: u32 = 1;
/// Bytes per pixel per layer: three f64 sums and an f64 weight.
const PIXEL_BYTES: usize = 32;

/// One layer of a part: which image it is (`pt`, `pm`, `ppm`), how it is split, the weight every
/// pixel has once all parts are added, and the stats of this part's share.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct LayerHeader {
    pub name: String,
    pub split: String,
    pub expected_weight: f64,
    pub stats: Value,
}

/// What a part is: the scene (by content), the effective settings (seed and mode among them), which
/// share, the film size, and where and how long it ran.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PartHeader {
    pub format: String,
    pub version: u32,
    pub scene: String,
    pub scene_hash: String,
    pub settings: Value,
    pub mode: String,
    pub seed: u64,
    pub part: u32,
    pub parts: u32,
    pub width: u32,
    pub height: u32,
    pub host: String,
    /// Wall time of the part's process, from loading the scene to writing the file.
    pub seconds: f64,
    pub layers: Vec<LayerHeader>,
}

/// A part read back: its header, one `Sums` per layer, and the file it came from.
pub struct Partial {
    pub header: PartHeader,
    pub layers: Vec<Sums>,
    pub path: PathBuf,
}

/// The file part `i` of `n` writes for the output base `out`: OUT-part-i-of-n.part.
pub fn part_path(out: &Path, i: u32, n: u32) -> PathBuf {
    with_suffix(out, &format!("-part-{i}-of-{n}.part"))
}

/// This machine's name, for the merged stats (which node rendered what).
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|s| s.trim().to_string())
        .or_else(|_| std::env::var("HOSTNAME"))
        .unwrap_or_default()
}

fn encode(header: &PartHeader, layers: &[&Sums]) -> Result<Vec<u8>> {
    let head = serde_json::to_vec(header)?;
    let pixels = header.width as usize * header.height as usize;
    let mut buf = Vec::with_capacity(16 + head.len() + layers.len() * pixels * PIXEL_BYTES + 32);
    buf.extend_from_slice(MAGIC);
    buf.extend_from_slice(&(head.len() as u64).to_le_bytes());
    buf.extend_from_slice(&head);
    for l in layers {
        if l.sum.len() != pixels || l.weight.len() != pixels {
            bail!("internal error: a layer of {} pixels in a {}×{} part", l.sum.len(), header.width, header.height);
        }
        for (s, w) in l.sum.iter().zip(&l.weight) {
            for v in [s[0], s[1], s[2], *w] {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    let digest = Sha256::digest(&buf);
    buf.extend_from_slice(&digest);
    Ok(buf)
}

/// Writes OUT-part-i-of-N.part and its header as OUT-part-i-of-N.json (both or neither); returns the
/// part file's path.
pub fn write_partial(out: &Path, header: &PartHeader, layers: &[&Sums]) -> Result<PathBuf> {
    let path = part_path(out, header.part, header.parts);
    let bytes = encode(header, layers)?;
    let mut files = output::Batch::default();
    files.stage(&path, |t| std::fs::write(t, &bytes).with_context(|| format!("cannot write {}", t.display())))?;
    files.stage(&path.with_extension("json"), |t| output::encode_json(t, &serde_json::to_value(header)?))?;
    files.commit()?;
    Ok(path)
}

/// Checks a part's start (`head`: at least its first 16 bytes, and the header if present) against the
/// file's length: magic, header, part index, film size, and that the length is exactly what the header
/// implies. Returns the header and where the pixel data starts.
fn check_header(shown: &str, head: &[u8], file_len: u64) -> Result<(PartHeader, usize)> {
    if head.len() < 16 || &head[..8] != MAGIC {
        bail!("{shown}: not a caustica part file (made by `caustica render --part i/N`)");
    }
    let head_len = u64::from_le_bytes(head[8..16].try_into().expect("8 bytes"));
    if head_len > file_len - 16 || head_len > (head.len() - 16) as u64 {
        bail!("{shown}: truncated: the header says {head_len} bytes, the file has {} after its start", file_len - 16);
    }
    let head_end = 16 + head_len as usize;
    let header: PartHeader =
        serde_json::from_slice(&head[16..head_end]).map_err(|e| anyhow!("{shown}: header: {e}"))?;
    if header.format != "caustica-part" || header.version != VERSION {
        bail!(
            "{shown}: format {} version {}; this caustica reads caustica-part version {VERSION}",
            header.format,
            header.version
        );
    }
    if header.parts == 0 || header.part >= header.parts {
        bail!(
            "{shown}: key `part`: part index {} is out of range for {} parts (0 to {})",
            header.part,
            header.parts,
            header.parts.saturating_sub(1)
        );
    }
    let pixels = header.width as u64 * header.height as u64;
    if pixels == 0 || pixels > crate::scene::load::MAX_PIXELS {
        bail!("{shown}: key `width`/`height`: {}×{} is not a film size caustica renders", header.width, header.height);
    }
    if header.layers.is_empty() || header.layers.len() > 4 {
        bail!("{shown}: key `layers`: {} layers (a part has 1 or 2)", header.layers.len());
    }
    let payload = header.layers.len() as u64 * pixels * PIXEL_BYTES as u64;
    let expected = head_end as u64 + payload + 32;
    if file_len != expected {
        bail!(
            "{shown}: {}: {file_len} bytes, a {}×{} part with {} layer(s) has {expected}",
            if file_len < expected { "truncated" } else { "wrong size" },
            header.width,
            header.height,
            header.layers.len()
        );
    }
    Ok((header, head_end))
}

/// Reads only a part's header (and checks its length), for checking a set of parts before reading
/// their pixels.
pub fn read_header(path: &Path) -> Result<PartHeader> {
    use std::io::Read;
    let shown = path.display().to_string();
    crate::scene::regular_file(path).map_err(|e| anyhow!("{shown}: cannot read: {e}"))?;
    let mut f = std::fs::File::open(path).map_err(|e| anyhow!("{shown}: cannot read: {e}"))?;
    let len = f.metadata().map_err(|e| anyhow!("{shown}: cannot read: {e}"))?.len();
    let mut head = vec![0u8; 16];
    if len < 16 || f.read_exact(&mut head).is_err() {
        bail!("{shown}: not a caustica part file (made by `caustica render --part i/N`)");
    }
    let head_len = u64::from_le_bytes(head[8..16].try_into().expect("8 bytes"));
    // A header is a few kB; a larger claim is damage (checked against the length in check_header).
    let want = head_len.min(len - 16).min(64 << 20) as usize;
    head.resize(16 + want, 0);
    f.read_exact(&mut head[16..]).map_err(|e| anyhow!("{shown}: cannot read: {e}"))?;
    Ok(check_header(&shown, &head, len)?.0)
}

/// Reads and checks a whole part file: magic, header, part index, size, length and checksum.
pub fn read_partial(path: &Path) -> Result<Partial> {
    let shown = path.display().to_string();
    crate::scene::regular_file(path).map_err(|e| anyhow!("{shown}: cannot read: {e}"))?;
    let bytes = std::fs::read(path).map_err(|e| anyhow!("{shown}: cannot read: {e}"))?;
    let (header, head_end) = check_header(&shown, &bytes, bytes.len() as u64)?;
    let pixels = header.width as u64 * header.height as u64;
    let body_end = bytes.len() - 32;
    if Sha256::digest(&bytes[..body_end])[..] != bytes[body_end..] {
        bail!("{shown}: checksum mismatch: the file was changed or damaged after it was written");
    }
    let mut at = head_end;
    let mut next = || {
        let v = f64::from_le_bytes(bytes[at..at + 8].try_into().expect("8 bytes"));
        at += 8;
        v
    };
    let mut layers = Vec::new();
    for lh in &header.layers {
        let mut s = Sums::new(header.width, header.height);
        for i in 0..pixels as usize {
            s.sum[i] = [next(), next(), next()];
            s.weight[i] = next();
            if !(s.sum[i].iter().all(|v| v.is_finite()) && s.weight[i].is_finite() && s.weight[i] >= 0.0) {
                bail!("{shown}: layer `{}`: pixel {i} holds a non-finite sum or a negative weight", lh.name);
            }
        }
        layers.push(s);
    }
    Ok(Partial { header, layers, path: path.to_path_buf() })
}

/// The first key (dotted path) where two JSON values differ, if any.
fn first_difference(a: &Value, b: &Value, at: &str) -> Option<String> {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| {
                let sub = if at.is_empty() { k.clone() } else { format!("{at}.{k}") };
                match (x.get(k), y.get(k)) {
                    (Some(p), Some(q)) => first_difference(p, q, &sub),
                    _ => Some(sub),
                }
            })
        }
        _ if a != b => Some(if at.is_empty() { "(value)".into() } else { at.to_string() }),
        _ => None,
    }
}

/// A merged render: its images (name, image, stats) ready for `pipeline::write_layers`, and the
/// exposure of the previews.
pub struct Merged {
    pub images: Vec<(String, Image, Value)>,
    pub exposure: f32,
}

/// Reads every part, checks they are the N parts of one render (same scene, settings, mode, size and
/// layers; each index once, none missing), and adds them up in part order. Nothing is written here.
pub fn merge(paths: &[PathBuf]) -> Result<Merged> {
    let t0 = std::time::Instant::now();
    if paths.is_empty() {
        bail!("merge: no part files given (expected OUT-part-i-of-N.part for i = 0 … N−1)");
    }
    // Headers first: the whole set is checked before any pixel is read, and pixels are then added one
    // part at a time (memory: two parts, whatever N is).
    let mut parts: Vec<(PartHeader, &PathBuf)> = Vec::new();
    for p in paths {
        parts.push((read_header(p)?, p));
    }
    let first = &parts[0].0;
    let fshown = parts[0].1.display().to_string();
    for (h, path) in &parts[1..] {
        let shown = path.display();
        if (h.width, h.height) != (first.width, first.height) {
            bail!("{shown}: {}×{} but {fshown} is {}×{}", h.width, h.height, first.width, first.height);
        }
        if h.scene_hash != first.scene_hash {
            bail!("{shown}: a render of a different scene than {fshown} (scene content {}… vs {}…); parts of one render only", &h.scene_hash[..h.scene_hash.len().min(12)], &first.scene_hash[..first.scene_hash.len().min(12)]);
        }
        if let Some(k) = first_difference(&first.settings, &h.settings, "render") {
            bail!(
                "{shown}: key `{k}` differs from {fshown}: {} vs {}; parts must share every setting",
                lookup(&h.settings, &k),
                lookup(&first.settings, &k)
            );
        }
        if h.mode != first.mode {
            bail!("{shown}: mode {} but {fshown} is {}", h.mode, first.mode);
        }
        if h.parts != first.parts {
            bail!(
                "{shown}: part {} of {} but {fshown} is part {} of {}: parts of one split only",
                h.part,
                h.parts,
                first.part,
                first.parts
            );
        }
        let shape = |h: &PartHeader| {
            h.layers.iter().map(|l| (l.name.clone(), l.split.clone(), l.expected_weight)).collect::<Vec<_>>()
        };
        if shape(h) != shape(first) {
            bail!("{shown}: layers {:?} but {fshown} has {:?}", shape(h), shape(first));
        }
    }
    let n = first.parts;
    let mut by_index: Vec<Option<&(PartHeader, &PathBuf)>> = vec![None; n as usize];
    for q in &parts {
        let slot = &mut by_index[q.0.part as usize];
        if let Some(prev) = slot {
            bail!("part {}/{n} given twice: {} and {}", q.0.part, prev.1.display(), q.1.display());
        }
        *slot = Some(q);
    }
    let missing: Vec<u32> = (0..n).filter(|&i| by_index[i as usize].is_none()).collect();
    if !missing.is_empty() {
        let base = parts[0].1.display().to_string();
        let stem = base.split("-part-").next().unwrap_or(&base).to_string();
        bail!(
            "missing part{} {} of {n} (expected {}); render {} and merge again; nothing was written",
            if missing.len() > 1 { "s" } else { "" },
            missing.iter().map(|i| i.to_string()).collect::<Vec<_>>().join(", "),
            missing
                .iter()
                .map(|&i| part_path(Path::new(&stem), i, n).display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            missing.iter().map(|i| format!("--part {i}/{n}")).collect::<Vec<_>>().join(", ")
        );
    }
    let ordered: Vec<&(PartHeader, &PathBuf)> = by_index.into_iter().flatten().collect();
    let mut sums: Vec<Sums> = first.layers.iter().map(|_| Sums::new(first.width, first.height)).collect();
    for (h, path) in &ordered {
        let q = read_partial(path)?;
        if q.header.part != h.part || q.header.scene_hash != h.scene_hash {
            bail!("{}: changed while merging (its header is not the one first read)", path.display());
        }
        for (acc, layer) in sums.iter_mut().zip(&q.layers) {
            acc.add(layer);
        }
    }
    let seconds: Vec<f64> = ordered.iter().map(|q| q.0.seconds).collect();
    let mean_s = seconds.iter().sum::<f64>() / seconds.len() as f64;
    let max_s = seconds.iter().cloned().fold(0.0, f64::max);
    let mut images = Vec::new();
    for ((li, lh), sums) in first.layers.iter().enumerate().zip(sums) {
        if let Some(i) = sums.weight.iter().position(|&w| w != lh.expected_weight) {
            bail!("layer `{}`: pixel {i} has weight {} after adding all {n} parts, {} expected: the parts do not cover the render", lh.name, sums.weight[i], lh.expected_weight);
        }
        let mut stats = lh.stats.clone();
        let sum_of = |key: &str| ordered.iter().map(|q| q.0.layers[li].stats[key].as_u64().unwrap_or(0)).sum::<u64>();
        stats["rays"] = json!(sum_of("rays"));
        stats["nonfinite_samples"] = json!(sum_of("nonfinite_samples"));
        stats.as_object_mut().map(|o| o.remove("rays_per_s"));
        stats["merged"] = json!({
            "parts": ordered.iter().map(|(h, path)| json!({
                "part": h.part,
                "file": path.display().to_string(),
                "host": h.host,
                "seconds": h.seconds,
                "times_s": h.layers[li].stats["times_s"],
            })).collect::<Vec<_>>(),
            "split": lh.split,
            "imbalance_max_over_mean": if mean_s > 0.0 { max_s / mean_s } else { 1.0 },
            "sum_of_part_seconds": seconds.iter().sum::<f64>(),
            "longest_part_seconds": max_s,
            "merge_seconds": t0.elapsed().as_secs_f64(),
        });
        images.push((lh.name.clone(), sums.image(), stats));
    }
    let exposure = first.settings["exposure"].as_f64().unwrap_or(0.0) as f32;
    Ok(Merged { images, exposure })
}

fn lookup<'a>(v: &'a Value, dotted: &str) -> &'a Value {
    dotted.split('.').skip(1).fold(v, |v, k| v.get(k).unwrap_or(&Value::Null))
}
