//! A head's texture image as uploaded (the `map_Kd` image of its OBJ's material): a PNG or
//! JPEG file that viewers draw on the rest mesh. It is checked before it is kept (its
//! format from its first bytes, its size from its header) and then stored and served as
//! it came, never decoded here: what is kept is an image a browser decodes, of bounded
//! size.

/// The largest side a texture may have, pixels (what WebGL2 guarantees is 2048; desktop
/// and phone GPUs take 8192 or more).
pub const MAX_TEXTURE_SIDE: u32 = 8192;

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// A texture's file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextureFormat {
    Png,
    Jpeg,
}

impl TextureFormat {
    /// Its HTTP content type.
    pub fn content_type(self) -> &'static str {
        match self {
            TextureFormat::Png => "image/png",
            TextureFormat::Jpeg => "image/jpeg",
        }
    }
}

/// Why an image is not taken as a texture.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum TextureError {
    #[error("texture: not a PNG or JPEG image (it starts with {0})")]
    Format(String),
    #[error("texture: {width} x {height} pixels; at most {MAX_TEXTURE_SIDE} a side")]
    TooLarge { width: u32, height: u32 },
    #[error("texture: its {0} header is cut short or broken")]
    Header(&'static str),
}

/// The format of texture `bytes`, once its header says it is an image of at most
/// [`MAX_TEXTURE_SIDE`] pixels a side.
pub fn check(bytes: &[u8]) -> Result<TextureFormat, TextureError> {
    let (format, width, height) = if bytes.starts_with(&PNG_SIGNATURE) {
        let (width, height) = png_size(bytes).ok_or(TextureError::Header("PNG"))?;
        (TextureFormat::Png, width, height)
    } else if bytes.starts_with(&[0xff, 0xd8, 0xff]) {
        let (width, height) = jpeg_size(bytes).ok_or(TextureError::Header("JPEG"))?;
        (TextureFormat::Jpeg, width, height)
    } else {
        let start: Vec<String> = bytes.iter().take(8).map(|b| format!("{b:02x}")).collect();
        return Err(TextureError::Format(format!("bytes {}", start.join(" "))));
    };
    if width == 0 || height == 0 || width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
        return Err(TextureError::TooLarge { width, height });
    }
    Ok(format)
}

fn be_u16(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from(u16::from_be_bytes(
        bytes.get(at..at + 2)?.try_into().ok()?,
    )))
}

fn be_u32(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_be_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

/// A PNG's first chunk is its header: `IHDR`, width, height.
fn png_size(bytes: &[u8]) -> Option<(u32, u32)> {
    (bytes.get(12..16)? == b"IHDR").then_some(())?;
    Some((be_u32(bytes, 16)?, be_u32(bytes, 20)?))
}

/// A JPEG's size is in its start-of-frame segment: the markers before it are walked by
/// their lengths (each step moves forward, so a broken file ends the walk).
fn jpeg_size(bytes: &[u8]) -> Option<(u32, u32)> {
    let mut at = 2;
    loop {
        if *bytes.get(at)? != 0xff {
            return None;
        }
        let marker = *bytes.get(at + 1)?;
        if marker == 0xff {
            at += 1; // fill byte
            continue;
        }
        let is_frame = (0xc0..=0xcf).contains(&marker) && !matches!(marker, 0xc4 | 0xc8 | 0xcc);
        if is_frame {
            return Some((be_u16(bytes, at + 7)?, be_u16(bytes, at + 5)?));
        }
        let length = be_u16(bytes, at + 2)? as usize;
        if length < 2 {
            return None;
        }
        at += 2 + length;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png(width: u32, height: u32) -> Vec<u8> {
        let mut bytes = PNG_SIGNATURE.to_vec();
        bytes.extend_from_slice(&13u32.to_be_bytes());
        bytes.extend_from_slice(b"IHDR");
        bytes.extend_from_slice(&width.to_be_bytes());
        bytes.extend_from_slice(&height.to_be_bytes());
        bytes.extend_from_slice(&[8, 2, 0, 0, 0]);
        bytes
    }

    /// A JPEG's start: SOI, an APP0 segment of 16 bytes, then SOF0 (8-bit, height, width).
    fn jpeg(width: u16, height: u16) -> Vec<u8> {
        let mut bytes = vec![0xff, 0xd8, 0xff, 0xe0, 0, 16];
        bytes.extend_from_slice(&[0; 14]);
        bytes.extend_from_slice(&[0xff, 0xc0, 0, 17, 8]);
        bytes.extend_from_slice(&height.to_be_bytes());
        bytes.extend_from_slice(&width.to_be_bytes());
        bytes.extend_from_slice(&[3; 10]);
        bytes
    }

    #[test]
    fn png_and_jpeg_are_read_by_their_headers() {
        assert_eq!(check(&png(1024, 512)), Ok(TextureFormat::Png));
        assert_eq!(check(&jpeg(2048, 2048)), Ok(TextureFormat::Jpeg));
        assert_eq!(TextureFormat::Jpeg.content_type(), "image/jpeg");
    }

    #[test]
    fn what_is_not_a_bounded_image_is_refused_by_name() {
        assert_eq!(
            check(&png(16_384, 16)),
            Err(TextureError::TooLarge {
                width: 16_384,
                height: 16
            })
        );
        assert_eq!(
            check(&jpeg(0, 10)),
            Err(TextureError::TooLarge { width: 0, height: 10 })
        );
        assert_eq!(check(&png(4, 4)[..18]), Err(TextureError::Header("PNG")));
        assert_eq!(check(&jpeg(4, 4)[..12]), Err(TextureError::Header("JPEG")));
        // A segment of length 0 would not move the walk on.
        assert_eq!(
            check(&[0xff, 0xd8, 0xff, 0xe0, 0, 0]),
            Err(TextureError::Header("JPEG"))
        );
        let error = check(b"GIF89a..").unwrap_err();
        assert!(error.to_string().contains("47 49 46 38 39 61 2e 2e"), "{error}");
    }
}
