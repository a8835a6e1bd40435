//! The bytes a glTF file refers to: its buffers and images, read from data URIs, the GLB's binary
//! chunk or files beside it. Each read is bounded by what the file declares (a buffer's
//! byteLength) or by a fixed limit (an image), so that a URI naming a device or a huge file
//! cannot take the machine's memory; every failure names the buffer or image and the file.

use base64::Engine;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest encoded image file a texture may come from.
pub const MAX_IMAGE_FILE_BYTES: u64 = 256 << 20;

/// The largest decoded texture: 8192 × 8192 RGBA8 (256 MiB). Textures are stored as RGBA8 on
/// the GPU, in one storage binding with the others (lavapipe's limit is 128 MiB per binding).
pub const MAX_TEXTURE_BYTES: u64 = 256 << 20;

/// Where a URI points: inline data (base64) or a file.
enum UriTarget {
    Data(Vec<u8>),
    File(PathBuf),
}

/// Resolves a glTF URI (glTF 2.0 §3.3, "URIs": relative paths, percent-encoded; data URIs in
/// base64).
fn resolve_uri(uri: &str, base: &Path) -> Result<UriTarget, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err("a data URI that is not base64".into());
        };
        return base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map(UriTarget::Data)
            .map_err(|e| format!("its data URI is not valid base64: {e}"));
    }
    let path = if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        PathBuf::from(percent_decode(rest)?)
    } else if uri.contains(':') && !looks_like_windows_drive(uri) {
        return Err(format!("URI scheme of '{uri}' is not supported (only relative paths, file: and data:)"));
    } else {
        base.join(percent_decode(uri)?)
    };
    Ok(UriTarget::File(path))
}

fn looks_like_windows_drive(uri: &str) -> bool {
    let b = uri.as_bytes();
    b.len() > 2 && b[0].is_ascii_alphabetic() && b[1] == b':' && (b[2] == b'/' || b[2] == b'\\')
}

fn percent_decode(s: &str) -> Result<String, String> {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok());
            let Some(v) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) else {
                return Err(format!("'{s}' has a malformed percent escape"));
            };
            out.push(v);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).map_err(|_| format!("'{s}' is not UTF-8 once decoded"))
}

/// Reads at most `limit` bytes of a file (a device such as /dev/zero never ends).
fn read_file_bounded(path: &Path, limit: u64) -> Result<Vec<u8>, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mut bytes = Vec::new();
    file.take(limit).read_to_end(&mut bytes).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Ok(bytes)
}

/// The document's buffers, each exactly its byteLength long (then padded to 4 bytes, as the
/// accessors' alignment expects), and warnings for buffers that hold more than they declare.
pub fn read_buffers(
    doc: &gltf::Document,
    base: &Path,
    blob: Option<&[u8]>,
) -> Result<(Vec<gltf::buffer::Data>, Vec<String>), String> {
    let mut buffers = Vec::new();
    let mut warnings = Vec::new();
    for buffer in doc.buffers() {
        let declared = buffer.length();
        let name = match buffer.name() {
            Some(n) => format!("buffer {} ('{n}')", buffer.index()),
            None => format!("buffer {}", buffer.index()),
        };
        let (mut bytes, what) = match buffer.source() {
            gltf::buffer::Source::Bin => {
                let blob =
                    blob.ok_or_else(|| format!("{name} refers to the GLB binary chunk, which the file lacks"))?;
                (blob.to_vec(), "the GLB binary chunk".to_string())
            }
            gltf::buffer::Source::Uri(uri) => match resolve_uri(uri, base).map_err(|e| format!("{name}: {e}"))? {
                UriTarget::Data(d) => (d, "its data URI".to_string()),
                UriTarget::File(path) => {
                    // One byte past the declared length tells a longer file from an exact one.
                    let d = read_file_bounded(&path, declared as u64 + 1).map_err(|e| format!("{name}: {e}"))?;
                    (d, format!("{} ('{uri}')", path.display()))
                }
            },
        };
        if bytes.len() < declared {
            return Err(format!(
                "{name}: {what} holds {} bytes, but the buffer's byteLength is {declared}",
                bytes.len()
            ));
        }
        // GLB pads its binary chunk to 4 bytes (glTF 2.0 §4.4.3.3), so up to 3 more are expected.
        let slack = if matches!(buffer.source(), gltf::buffer::Source::Bin) { 3 } else { 0 };
        if bytes.len() > declared + slack {
            warnings.push(format!(
                "{name}: {what} holds more than the buffer's byteLength of {declared} bytes; the rest is ignored"
            ));
        }
        bytes.truncate(declared);
        while !bytes.len().is_multiple_of(4) {
            bytes.push(0);
        }
        buffers.push(gltf::buffer::Data(bytes));
    }
    Ok((buffers, warnings))
}

/// An image's encoded bytes, from a buffer view, a data URI or a file (at most
/// `MAX_IMAGE_FILE_BYTES`).
fn encoded_image(source: gltf::image::Source, base: &Path, buffers: &[gltf::buffer::Data]) -> Result<Vec<u8>, String> {
    match source {
        gltf::image::Source::View { view, .. } => {
            let data = &buffers.get(view.buffer().index()).ok_or("its buffer view refers to a missing buffer")?.0;
            let (start, end) = (view.offset(), view.offset() + view.length());
            data.get(start..end).map(<[u8]>::to_vec).ok_or_else(|| {
                format!("its buffer view (bytes {start}..{end}) lies outside its buffer of {} bytes", data.len())
            })
        }
        gltf::image::Source::Uri { uri, .. } => match resolve_uri(uri, base)? {
            UriTarget::Data(d) => Ok(d),
            UriTarget::File(path) => {
                let d = read_file_bounded(&path, MAX_IMAGE_FILE_BYTES + 1)?;
                if d.len() as u64 > MAX_IMAGE_FILE_BYTES {
                    return Err(format!(
                        "{} is larger than {} MiB, the most veach reads for one texture",
                        path.display(),
                        MAX_IMAGE_FILE_BYTES >> 20
                    ));
                }
                Ok(d)
            }
        },
    }
}

/// Decodes a texture's image (PNG or JPEG, as glTF 2.0 §5.18 allows), refusing one whose decoded
/// size exceeds `MAX_TEXTURE_BYTES` before decoding it.
pub fn read_image(
    image: &gltf::image::Image,
    base: &Path,
    buffers: &[gltf::buffer::Data],
) -> Result<gltf::image::Data, String> {
    use gltf::image::Format;
    use image::DynamicImage;
    let bytes = encoded_image(image.source(), base, buffers)?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read its image: {e}"))?;
    match reader.format() {
        Some(image::ImageFormat::Png | image::ImageFormat::Jpeg) => {}
        Some(other) => return Err(format!("its image is {other:?}; glTF textures are PNG or JPEG")),
        None => return Err("its image is neither PNG nor JPEG".into()),
    }
    let (width, height) = reader.into_dimensions().map_err(|e| format!("cannot read its image: {e}"))?;
    let texels = width as u64 * height as u64;
    if texels * 4 > MAX_TEXTURE_BYTES {
        return Err(format!(
            "its image is {width}x{height}: {} MiB as RGBA8, above veach's limit of {} MiB per texture \
             (8192x8192); scale it down",
            (texels * 4) >> 20,
            MAX_TEXTURE_BYTES >> 20
        ));
    }
    let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read its image: {e}"))?;
    // Room for the decoder's 16-bit and float forms of an image within the limit.
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(MAX_TEXTURE_BYTES * 4);
    reader.limits(limits);
    let decoded = reader.decode().map_err(|e| format!("cannot decode its image: {e}"))?;
    let (width, height) = (decoded.width(), decoded.height());
    let (format, pixels) = match decoded {
        DynamicImage::ImageLuma8(i) => (Format::R8, i.into_raw()),
        DynamicImage::ImageLumaA8(i) => (Format::R8G8, i.into_raw()),
        DynamicImage::ImageRgb8(i) => (Format::R8G8B8, i.into_raw()),
        DynamicImage::ImageRgba8(i) => (Format::R8G8B8A8, i.into_raw()),
        DynamicImage::ImageLuma16(i) => (Format::R16, bytemuck::cast_slice(&i.into_raw()).to_vec()),
        DynamicImage::ImageLumaA16(i) => (Format::R16G16, bytemuck::cast_slice(&i.into_raw()).to_vec()),
        DynamicImage::ImageRgb16(i) => (Format::R16G16B16, bytemuck::cast_slice(&i.into_raw()).to_vec()),
        DynamicImage::ImageRgba16(i) => (Format::R16G16B16A16, bytemuck::cast_slice(&i.into_raw()).to_vec()),
        other => (Format::R8G8B8A8, other.into_rgba8().into_raw()),
    };
    Ok(gltf::image::Data { pixels, format, width, height })
}
