//! `veach merge`: renders of disjoint ranges of camera samples (`veach render --first-sample K
//! --spp N`, one per machine or job) added into the render of all of them.
//!
//! A pixel's estimate over samples 0..N is the mean of its N samples; parts hold the means of
//! their own ranges, so the whole is their mean weighted by sample counts, Σ n_i·x_i / Σ n_i.
//! Parts must come from the same scene and settings and tile 0..N with no overlap and no gap:
//! a missing part would otherwise leave a noisier image that looks like a finished one.

use crate::console::errln;
use anyhow::{Context, Result, bail};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
#[command(after_long_help = "Each part is an EXR written by `veach render --first-sample K --spp N`, whose \
header records its range of camera samples, the scene's content hash and every setting. The parts must \
differ in nothing but their ranges (and adapters and render times) and cover camera samples 0..N with no \
overlap and no gap; the output records 0..N, so merged images merge again.")]
pub struct MergeArgs {
    /// Parts: EXR images rendered with --first-sample
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output image: .exr (with the merged header), .pfm or .png
    #[arg(short, long)]
    output: PathBuf,
    /// Refuse unless the parts cover camera samples 0..N exactly: a job array's total, so that
    /// a part missing at the end is an error too
    #[arg(long, value_name = "N")]
    expect_spp: Option<u64>,
    /// Print nothing but errors
    #[arg(short, long)]
    quiet: bool,
}

/// Header entries that may differ between parts of one render: where and how fast each part
/// ran, and the range itself. Every other `veach:` entry must match.
const PER_PART: [&str; 5] = ["veach:first_sample", "veach:spp", "veach:render_seconds", "veach:adapter", "veach:scene"];

/// One part, as its header describes it.
#[derive(Debug)]
pub struct Part {
    pub path: PathBuf,
    pub first: u64,
    pub count: u64,
    pub header: BTreeMap<String, String>,
}

impl Part {
    pub fn from_header(path: &Path, entries: Vec<(String, String)>) -> Result<Part> {
        let header: BTreeMap<String, String> = entries.into_iter().collect();
        let number = |name: &str| -> Result<u64> {
            let text = header.get(name).with_context(|| {
                format!(
                    "{}: no {name} in its header; parts are EXR images written by `veach render --first-sample`",
                    path.display()
                )
            })?;
            let value: f64 = text.parse().map_err(|_| anyhow::anyhow!("{}: {name} is {text:?}", path.display()))?;
            if !(value >= 0.0 && value.fract() == 0.0 && value <= u32::MAX as f64) {
                bail!("{}: {name} is {text}, not a whole number of camera samples", path.display());
            }
            Ok(value as u64)
        };
        let first = number("veach:first_sample")?;
        let count = number("veach:spp")?;
        if !header.contains_key("veach:scene_hash") {
            bail!("{}: no veach:scene_hash in its header; render the parts with this version of veach", path.display());
        }
        if count == 0 {
            bail!("{}: holds no camera samples", path.display());
        }
        Ok(Part { path: path.to_owned(), first, count, header })
    }

    fn range(&self) -> String {
        format!("samples {}..{}", self.first, self.first + self.count)
    }
}

/// Checks that the parts belong together and tile 0..N, and returns them sorted by range.
pub fn check_parts(mut parts: Vec<Part>, expect_spp: Option<u64>) -> Result<Vec<Part>> {
    let Some(first) = parts.first() else { bail!("no parts to merge") };
    for other in &parts[1..] {
        let keys: std::collections::BTreeSet<&String> = first.header.keys().chain(other.header.keys()).collect();
        // The scene first: another scene's camera differs too, but the scene is what to say.
        let scene_first = keys.iter().copied().filter(|k| *k == "veach:scene_hash").chain(keys.iter().copied());
        for key in scene_first {
            if !key.starts_with("veach:") || PER_PART.contains(&key.as_str()) {
                continue;
            }
            let (a, b) = (first.header.get(key), other.header.get(key));
            if a != b {
                let show = |v: Option<&String>| v.map_or("nothing".to_string(), |v| format!("{v:?}"));
                let what = if key == "veach:scene_hash" { " (another scene, or the scene changed)" } else { "" };
                bail!(
                    "{} and {} are not parts of one render: {key} is {} against {}{what}",
                    first.path.display(),
                    other.path.display(),
                    show(a),
                    show(b)
                );
            }
        }
    }
    parts.sort_by_key(|p| (p.first, p.count));
    if parts[0].first > 0 {
        bail!(
            "samples 0..{} are missing: the first part, {}, starts at sample {}",
            parts[0].first,
            parts[0].path.display(),
            parts[0].first
        );
    }
    for pair in parts.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let end = a.first + a.count;
        if b.first < end {
            bail!("{} ({}) and {} ({}) overlap", a.path.display(), a.range(), b.path.display(), b.range());
        }
        if b.first > end {
            bail!("samples {end}..{} are missing, between {} and {}", b.first, a.path.display(), b.path.display());
        }
    }
    let last = parts.last().expect("at least one part");
    let total = last.first + last.count;
    match expect_spp {
        Some(n) if total < n => {
            bail!("samples {total}..{n} are missing: the parts end at {} ({})", total, last.path.display())
        }
        Some(n) if total > n => bail!("the parts cover samples 0..{total}, more than --expect-spp {n}"),
        _ => {}
    }
    Ok(parts)
}

pub fn merge(args: MergeArgs) -> Result<()> {
    veach::image_io::ImageFormat::from_path(&args.output)?;
    for part in &args.parts {
        if veach::image_io::same_file(part, &args.output) {
            bail!("the output {} is one of the parts; merge into a file of its own", args.output.display());
        }
    }
    veach::image_io::check_writable(&args.output)?;
    let mut parts = Vec::new();
    for path in &args.parts {
        if veach::image_io::ImageFormat::from_path(path)? != veach::image_io::ImageFormat::Exr {
            bail!(
                "{}: parts must be EXR images, whose headers record their samples (PNG is clamped, PFM has no header)",
                path.display()
            );
        }
        parts.push(Part::from_header(path, veach::image_io::read_metadata(path)?)?);
    }
    let parts = check_parts(parts, args.expect_spp)?;
    let total: u64 = parts.iter().map(|p| p.count).sum();

    // Σ n_i·x_i / Σ n_i in f64, so that the parts' order does not round differently.
    let mut size = None;
    let mut sum: Vec<[f64; 3]> = Vec::new();
    for part in &parts {
        let (w, h, pixels) = veach::image_io::read_image(&part.path)?;
        match size {
            None => {
                size = Some((w, h));
                sum = vec![[0.0; 3]; pixels.len()];
            }
            Some(s) if s != (w, h) => {
                bail!("{} is {w}x{h}; {} is {}x{}", part.path.display(), parts[0].path.display(), s.0, s.1)
            }
            Some(_) => {}
        }
        for (i, (s, p)) in sum.iter_mut().zip(&pixels).enumerate() {
            if p.iter().any(|v| !v.is_finite()) {
                bail!(
                    "{}: pixel ({}, {}) is not finite; the file is damaged",
                    part.path.display(),
                    i as u32 % w,
                    i as u32 / w
                );
            }
            for c in 0..3 {
                s[c] += part.count as f64 * p[c] as f64;
            }
        }
    }
    let (w, h) = size.expect("at least one part");
    let mean: Vec<[f32; 3]> = sum.iter().map(|s| s.map(|v| (v / total as f64) as f32)).collect();

    let mut header = parts[0].header.clone();
    let mut adapters: Vec<&str> =
        parts.iter().filter_map(|p| p.header.get("veach:adapter").map(String::as_str)).collect();
    adapters.sort();
    adapters.dedup();
    let seconds: f64 = parts.iter().filter_map(|p| p.header.get("veach:render_seconds")?.parse::<f64>().ok()).sum();
    header.insert("veach:first_sample".into(), "0".into());
    header.insert("veach:spp".into(), format!("{total}.000"));
    header.insert("veach:render_seconds".into(), format!("{seconds:.6}"));
    header.insert("veach:adapter".into(), adapters.join("; "));
    header.insert("veach:merged_parts".into(), parts.len().to_string());
    let metadata: Vec<(String, String)> = header.into_iter().filter(|(k, _)| k.starts_with("veach:")).collect();
    veach::image_io::write_image_with_metadata(&args.output, w, h, &mean, 0.0, &metadata)?;
    if !args.quiet {
        errln!("{}: {w}x{h}, {} parts, samples 0..{total}", args.output.display(), parts.len());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{Part, check_parts};

    fn part(name: &str, first: u64, count: u64, seed: &str) -> Part {
        let entries = vec![
            ("veach:first_sample".to_string(), first.to_string()),
            ("veach:spp".to_string(), format!("{count}.000")),
            ("veach:scene_hash".to_string(), "00ff".to_string()),
            ("veach:seed".to_string(), seed.to_string()),
            ("veach:adapter".to_string(), format!("gpu of {name}")),
        ];
        Part::from_header(name.as_ref(), entries).unwrap()
    }

    fn error(parts: Vec<Part>, expect: Option<u64>) -> String {
        format!("{:#}", check_parts(parts, expect).unwrap_err())
    }

    #[test]
    fn parts_that_tile_the_samples_are_sorted_by_range() {
        let parts = check_parts(vec![part("c", 40, 24, "0"), part("a", 0, 16, "0"), part("b", 16, 24, "0")], Some(64));
        let names: Vec<String> = parts.unwrap().iter().map(|p| p.path.display().to_string()).collect();
        assert_eq!(names, ["a", "b", "c"]);
    }

    #[test]
    fn gaps_overlaps_and_other_settings_are_named() {
        let e = error(vec![part("a", 0, 16, "0"), part("c", 40, 24, "0")], None);
        assert!(e.contains("samples 16..40 are missing, between a and c"), "{e}");
        let e = error(vec![part("a", 0, 16, "0"), part("b", 8, 16, "0")], None);
        assert!(e.contains("a (samples 0..16) and b (samples 8..24) overlap"), "{e}");
        let e = error(vec![part("b", 16, 16, "0")], None);
        assert!(e.contains("samples 0..16 are missing"), "{e}");
        let e = error(vec![part("a", 0, 16, "0"), part("b", 16, 16, "0")], Some(64));
        assert!(e.contains("samples 32..64 are missing"), "{e}");
        let e = error(vec![part("a", 0, 16, "0"), part("b", 16, 16, "1")], None);
        assert!(e.contains("veach:seed is \"0\" against \"1\""), "{e}");
        let mut other_scene = part("b", 16, 16, "0");
        other_scene.header.insert("veach:scene_hash".into(), "0100".into());
        let e = error(vec![part("a", 0, 16, "0"), other_scene], None);
        assert!(e.contains("another scene"), "{e}");
    }

    #[test]
    fn a_header_without_a_range_is_not_a_part() {
        let e = Part::from_header("x.exr".as_ref(), vec![("veach:spp".into(), "4.000".into())]).unwrap_err();
        assert!(format!("{e}").contains("x.exr: no veach:first_sample"), "{e}");
        let entries = vec![
            ("veach:first_sample".into(), "0".into()),
            ("veach:spp".into(), "3.500".into()),
            ("veach:scene_hash".into(), "1".into()),
        ];
        let e = Part::from_header("y.exr".as_ref(), entries).unwrap_err();
        assert!(format!("{e}").contains("not a whole number"), "{e}");
    }
}
