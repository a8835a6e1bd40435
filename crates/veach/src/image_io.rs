//! Image files: linear float EXR and PFM, 8-bit sRGB PNG. Every write goes to a temporary file
//! next to the target and is renamed over it only when complete, so a failed write never leaves
//! a half-written image (and leaves an older file in place).

use crate::error::{Error, Result};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Exr,
    Png,
    Pfm,
}

impl ImageFormat {
    pub fn from_path(path: &Path) -> Result<ImageFormat> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("exr") => Ok(ImageFormat::Exr),
            Some("png") => Ok(ImageFormat::Png),
            Some("pfm") => Ok(ImageFormat::Pfm),
            _ => Err(Error::Output {
                path: path.to_owned(),
                message: "unknown image type: use .exr (linear float), .png (8-bit sRGB) or .pfm".into(),
            }),
        }
    }
}

/// sRGB transfer function (IEC 61966-2-1).
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.0031308 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

/// Inverse of `linear_to_srgb`.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

/// False colour of the share of the direct-lighting estimate carried by light samples, per
/// pixel: blue where BRDF samples carry it (share 0), white at half, red where light samples do
/// (share 1), black where both are zero. `emitted` (luminance of directly seen emission, part of
/// the BRDF image) is left out of the share. A diverging map (Moreland, "Diverging Color Maps
/// for Scientific Visualization", 2009, end points), returned as linear RGB.
pub fn light_share_false_colour(light: &[[f32; 3]], brdf: &[[f32; 3]], emitted: &[f32]) -> Vec<[f32; 3]> {
    let lum = |c: &[f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let (blue, white, red) = ([0.230, 0.299, 0.754], [0.865, 0.865, 0.865], [0.706, 0.016, 0.150]);
    light
        .iter()
        .zip(brdf)
        .zip(emitted)
        .map(|((l, b), e)| {
            let (a, c) = (lum(l).max(0.0), (lum(b) - e).max(0.0));
            // Below rounding of the emission: nothing was sampled.
            let c = if c <= 1e-6 * e { 0.0 } else { c };
            if a + c <= 0.0 || (a + c).is_nan() {
                return [0.0; 3];
            }
            let t = a / (a + c);
            let (from, to, u) = if t < 0.5 { (blue, white, 2.0 * t) } else { (white, red, 2.0 * t - 1.0) };
            std::array::from_fn(|k| srgb_to_linear(from[k] + (to[k] - from[k]) * u))
        })
        .collect()
}

/// Writes linear RGB pixels (row-major, top row first). `exposure` is in stops and applies to
/// PNG only; float formats keep the radiance values as they are.
pub fn write_image(path: &Path, width: u32, height: u32, pixels: &[[f32; 3]], exposure: f32) -> Result<()> {
    write_image_with_metadata(path, width, height, pixels, exposure, &[])
}

/// `write_image`, with `metadata` (name, value) in the file's header: text attributes of an EXR,
/// iTXt chunks of a PNG (`veach render` records its settings there; PFM has no place for them).
/// A PNG with metadata also records its `exposure` (`veach:exposure`), which its pixels depend on.
/// Characters outside Latin-1, which EXR text cannot hold, become '?' in an EXR.
pub fn write_image_with_metadata(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
    exposure: f32,
    metadata: &[(String, String)],
) -> Result<()> {
    let format = ImageFormat::from_path(path)?;
    assert_eq!(pixels.len(), (width * height) as usize);
    let clean: Vec<[f32; 3]> = pixels.iter().map(|p| p.map(|v| if v.is_finite() { v } else { 0.0 })).collect();
    write_atomically(path, |file| match format {
        ImageFormat::Exr => write_exr(file, width, height, &clean, metadata),
        ImageFormat::Png => {
            let scale = 2f32.powf(exposure);
            let srgb: Vec<u8> = clean
                .iter()
                .flatten()
                .map(|&v| (linear_to_srgb((v * scale).clamp(0.0, 1.0)) * 255.0 + 0.5) as u8)
                .collect();
            let mut metadata = metadata.to_vec();
            if !metadata.is_empty() {
                metadata.push(("veach:exposure".into(), exposure.to_string()));
            }
            write_png(file, width, height, &srgb, &metadata).map_err(|e| e.to_string())
        }
        ImageFormat::Pfm => write_pfm(file, width, height, &clean).map_err(|e| e.to_string()),
    })
}

/// 8-bit RGB, rows top first, marked as sRGB (the sRGB chunk, PNG spec 3rd ed. §11.3.3.5);
/// each metadata pair an iTXt chunk (UTF-8 text, §11.3.3.4).
fn write_png(
    file: &mut BufWriter<std::fs::File>,
    width: u32,
    height: u32,
    srgb: &[u8],
    metadata: &[(String, String)],
) -> std::result::Result<(), png::EncodingError> {
    let mut encoder = png::Encoder::new(file, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    encoder.add_text_chunk("Software".into(), "veach".into())?;
    for (name, value) in metadata {
        encoder.add_itxt_chunk(name.clone(), value.clone())?;
    }
    let mut writer = encoder.write_header()?;
    writer.write_image_data(srgb)?;
    writer.finish()
}

fn write_exr(
    file: &mut BufWriter<std::fs::File>,
    width: u32,
    height: u32,
    pixels: &[[f32; 3]],
    metadata: &[(String, String)],
) -> std::result::Result<(), String> {
    use exr::prelude::*;
    let text =
        |s: &str| Text::new_or_panic(s.chars().map(|c| if (c as u32) < 256 { c } else { '?' }).collect::<String>());
    let mut attributes = LayerAttributes { software_name: Some(text("veach")), ..LayerAttributes::default() };
    for (name, value) in metadata {
        attributes.other.insert(text(name), AttributeValue::Text(text(value)));
    }
    let w = width as usize;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let [r, g, b] = pixels[p.y() * w + p.x()];
        (r, g, b)
    });
    let layer = Layer::new((w, height as usize), attributes, Encoding::FAST_LOSSLESS, channels);
    Image::from_layer(layer).write().non_parallel().to_buffered(file).map_err(|e| e.to_string())
}

/// The metadata in an image file's header (`write_image_with_metadata`), name and value, sorted
/// by name: an EXR's text attributes, a PNG's text chunks; none for PFM.
pub fn read_metadata(path: &Path) -> Result<Vec<(String, String)>> {
    let err = |m: String| Error::Output { path: path.to_owned(), message: m };
    let mut found = Vec::new();
    match ImageFormat::from_path(path)? {
        ImageFormat::Exr => {
            let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| err(e.to_string()))?;
            for header in &meta.headers {
                for (name, value) in &header.own_attributes.other {
                    if let exr::meta::attribute::AttributeValue::Text(t) = value {
                        found.push((name.to_string(), t.to_string()));
                    }
                }
            }
        }
        ImageFormat::Png => {
            let file = std::fs::File::open(path).map_err(|e| err(e.to_string()))?;
            let reader =
                png::Decoder::new(std::io::BufReader::new(file)).read_info().map_err(|e| err(e.to_string()))?;
            let info = reader.info();
            for chunk in &info.uncompressed_latin1_text {
                found.push((chunk.keyword.clone(), chunk.text.clone()));
            }
            for chunk in &info.utf8_text {
                found.push((chunk.keyword.clone(), chunk.get_text().map_err(|e| err(e.to_string()))?));
            }
        }
        ImageFormat::Pfm => {}
    }
    found.sort();
    Ok(found)
}

/// Portable float map: "PF", size, -1 (little endian), then rows from the bottom up.
fn write_pfm(out: &mut BufWriter<std::fs::File>, width: u32, height: u32, pixels: &[[f32; 3]]) -> std::io::Result<()> {
    write!(out, "PF\n{width} {height}\n-1.0\n")?;
    for row in (0..height as usize).rev() {
        for p in &pixels[row * width as usize..(row + 1) * width as usize] {
            for v in p {
                out.write_all(&v.to_le_bytes())?;
            }
        }
    }
    Ok(())
}

/// A temporary name next to `path`, unique to this call: by process and by a count within it, so
/// that two threads writing the same file (tests that share a scene) do not rename each other's.
/// Short whatever the output's name (a name near the file system's 255-byte limit still takes
/// one), and of veach's own form, so that `remove_stale_temp_files` can tell one that a killed
/// process left.
fn temp_path(path: &Path) -> PathBuf {
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    path.with_file_name(format!("{TEMP_PREFIX}{}-{n}{TEMP_SUFFIX}", std::process::id()))
}

const TEMP_PREFIX: &str = ".veach-partial-";
const TEMP_SUFFIX: &str = ".tmp";

/// Removes the temporary files of veach's naming in `dir` whose process no longer runs: left by a
/// write that SIGKILL (or a power cut) stopped before its rename. Only where a process can be
/// looked up by its id (Linux's /proc); elsewhere they stay.
fn remove_stale_temp_files(dir: &Path) {
    let proc = Path::new("/proc/self");
    if !proc.exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(TEMP_PREFIX))
            .and_then(|n| n.strip_suffix(TEMP_SUFFIX))
            .and_then(|n| n.split_once('-'))
            .and_then(|(pid, _)| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !Path::new("/proc").join(pid.to_string()).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Checks, before a render spends its time, that `write_atomically` will be able to create its
/// temporary file next to `path`: the directory exists and takes a new file. Leaves nothing behind.
pub fn check_writable(path: &Path) -> Result<()> {
    let err = |m: String| Error::Output { path: path.to_owned(), message: m };
    if path.is_dir() {
        return Err(err("is a directory; give a file name".into()));
    }
    let tmp = temp_path(path);
    std::fs::File::create(&tmp).map_err(|e| err(format!("cannot write in its directory: {e}")))?;
    let _ = std::fs::remove_file(&tmp);
    Ok(())
}

/// Whether two paths name the same file, whether or not it exists yet: their directories are
/// compared once resolved (links, `..`), their file names as given.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let resolve = |p: &Path| -> Option<PathBuf> {
        if let Ok(c) = p.canonicalize() {
            return Some(c);
        }
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        Some(dir.canonicalize().ok()?.join(p.file_name()?))
    };
    match (resolve(a), resolve(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

/// Writes through `write` into a temporary file, then renames it over `path`.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<std::fs::File>) -> std::result::Result<(), String>,
) -> Result<()> {
    let err = |m: String| Error::Output { path: path.to_owned(), message: m };
    let tmp = temp_path(path);
    if let Some(dir) = tmp.parent() {
        remove_stale_temp_files(if dir.as_os_str().is_empty() { Path::new(".") } else { dir });
    }
    let file = std::fs::File::create(&tmp).map_err(|e| err(format!("cannot create {}: {e}", tmp.display())))?;
    let mut writer = BufWriter::new(file);
    let result = write(&mut writer)
        .and_then(|_| writer.flush().map_err(|e| e.to_string()))
        .and_then(|_| writer.get_ref().sync_all().map_err(|e| e.to_string()));
    drop(writer);
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(format!("write failed: {e}")));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        err(format!("cannot move the finished file into place: {e}"))
    })
}

/// Reads an image to measure error against (`veach bench --reference`, the viewer's reference):
/// `read_image`, refusing one with NaN or infinite pixels, against which every error would be
/// NaN. veach never writes such pixels; another renderer's file may hold them.
pub fn read_reference(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    let (width, height, pixels) = read_image(path)?;
    let bad = pixels.iter().filter(|p| p.iter().any(|v| !v.is_finite())).count();
    if bad > 0 {
        return Err(Error::Output {
            path: path.to_owned(),
            message: format!("{bad} pixels are NaN or infinite; a reference needs finite values"),
        });
    }
    Ok((width, height, pixels))
}

/// Reads a linear RGB image (EXR or PFM as written above, or any format `image` reads).
pub fn read_image(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>)> {
    let err = |m: String| Error::Output { path: path.to_owned(), message: m };
    if ImageFormat::from_path(path).ok() == Some(ImageFormat::Pfm) {
        return read_pfm(path).map_err(err);
    }
    let img = image::open(path).map_err(|e| err(e.to_string()))?.into_rgb32f();
    let (w, h) = img.dimensions();
    Ok((w, h, img.pixels().map(|p| p.0).collect()))
}

fn read_pfm(path: &Path) -> std::result::Result<(u32, u32, Vec<[f32; 3]>), String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let mut fields = Vec::new();
    let mut pos = 0;
    while fields.len() < 4 {
        while pos < bytes.len() && bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < bytes.len() && !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos {
            return Err("truncated PFM header".into());
        }
        fields.push(String::from_utf8_lossy(&bytes[start..pos]).into_owned());
    }
    pos += 1;
    if fields[0] != "PF" {
        return Err("not a colour PFM (PF)".into());
    }
    let w: u32 = fields[1].parse().map_err(|_| "bad PFM width")?;
    let h: u32 = fields[2].parse().map_err(|_| "bad PFM height")?;
    let scale: f32 = fields[3].parse().map_err(|_| "bad PFM scale")?;
    let n = w as usize * h as usize;
    if n.checked_mul(12).and_then(|b| b.checked_add(pos)).is_none_or(|end| bytes.len() < end) {
        return Err("truncated PFM data".into());
    }
    let read = |i: usize| {
        let b: [u8; 4] = bytes[pos + 4 * i..pos + 4 * i + 4].try_into().unwrap();
        if scale < 0.0 { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) }
    };
    let mut out = vec![[0.0; 3]; n];
    for row in 0..h as usize {
        for x in 0..w as usize {
            let src = ((h as usize - 1 - row) * w as usize + x) * 3;
            out[row * w as usize + x] = [read(src), read(src + 1), read(src + 2)];
        }
    }
    Ok((w, h, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Threads that write the same file at once (test binaries that share a scene, run with many
    /// threads) each finish, and the file is one writer's whole text. With one temporary name per
    /// process, a writer's rename found its file already moved by another (seen on 16 cores).
    #[test]
    fn writers_of_the_same_file_at_once_all_succeed() {
        let dir = std::env::temp_dir().join(format!("veach-io-race-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("shared.txt");
        let texts: Vec<String> = (0..16).map(|i| format!("writer {i} ").repeat(10_000)).collect();
        std::thread::scope(|s| {
            for text in &texts {
                let path = &path;
                s.spawn(move || {
                    write_atomically(path, |f| {
                        use std::io::Write;
                        f.write_all(text.as_bytes()).map_err(|e| e.to_string())
                    })
                    .unwrap()
                });
            }
        });
        let back = std::fs::read_to_string(&path).unwrap();
        assert!(texts.contains(&back), "the file is no one writer's whole text");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(left.len(), 1, "temporary files left behind: {left:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn float_formats_round_trip_and_png_is_srgb() {
        let dir = std::env::temp_dir().join(format!("veach-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let pixels = vec![[0.25, 1.5, 1.0e3], [0.0, f32::NAN, 2.0]];
        for ext in ["exr", "pfm"] {
            let p = dir.join(format!("a.{ext}"));
            write_image(&p, 2, 1, &pixels, 0.0).unwrap();
            let (w, h, back) = read_image(&p).unwrap();
            assert_eq!((w, h), (2, 1));
            assert_eq!(back[0], [0.25, 1.5, 1.0e3], "{ext}");
            assert_eq!(back[1], [0.0, 0.0, 2.0], "{ext}: NaN must be written as 0");
        }
        let p = dir.join("a.png");
        write_image(&p, 2, 1, &[[0.5; 3], [2.0; 3]], 0.0).unwrap();
        let png = image::open(&p).unwrap().into_rgb8();
        assert_eq!(png.get_pixel(0, 0).0, [188; 3]); // sRGB(0.5) = 0.7354 → 188
        assert_eq!(png.get_pixel(1, 0).0, [255; 3]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn exr_and_png_headers_carry_the_metadata_and_pfm_none() {
        let dir = std::env::temp_dir().join(format!("veach-meta-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let metadata = vec![("veach:scene".to_string(), "scène/ƒ.gltf".to_string()), ("veach:spp".into(), "4".into())];
        let pixels = [[0.5f32; 3]; 6];
        for (ext, scene) in [("exr", "scène/?.gltf"), ("png", "scène/ƒ.gltf")] {
            let p = dir.join(format!("m.{ext}"));
            write_image_with_metadata(&p, 3, 2, &pixels, 0.0, &metadata).unwrap();
            let back = read_metadata(&p).unwrap();
            let value = |name: &str| back.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str());
            // EXR text is Latin-1 (ƒ is not), PNG's iTXt UTF-8.
            assert_eq!(value("veach:scene"), Some(scene), "{ext}: {back:?}");
            assert_eq!(value("veach:spp"), Some("4"), "{ext}: {back:?}");
            assert_eq!(read_image(&p).unwrap().2.len(), 6);
        }
        let p = dir.join("m.pfm");
        write_image_with_metadata(&p, 3, 2, &pixels, 0.0, &metadata).unwrap();
        assert!(read_metadata(&p).unwrap().is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_pfm_header_larger_than_its_data_is_an_error() {
        let dir = std::env::temp_dir().join(format!("veach-pfm-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (name, header) in [("short", "PF\n4 4\n-1.0\n"), ("huge", "PF\n4294967295 4294967295\n-1.0\n")] {
            let p = dir.join(format!("{name}.pfm"));
            std::fs::write(&p, [header.as_bytes(), &[0u8; 48]].concat()).unwrap();
            let e = read_image(&p).unwrap_err().to_string();
            assert!(e.contains(&format!("{name}.pfm")) && e.contains("truncated"), "{e}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn failed_write_keeps_the_old_file_and_leaves_no_temporary() {
        let dir = std::env::temp_dir().join(format!("veach-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("out.exr");
        std::fs::write(&p, b"old").unwrap();
        let r = write_atomically(&p, |_| Err("simulated failure".into()));
        assert!(r.is_err());
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "temporary file left behind");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
