//! A textured head for the tests: the shipped MakeHuman head with texture coordinates of
//! its own (each vertex's x and y across the head's front, one per vertex), and a PNG of
//! one colour, written here by hand (stored deflate blocks, CRC-32 and Adler-32) so that no
//! image crate is needed.

use super::data;

/// `makehuman_head.obj` with a `vt` per vertex (its x and y scaled to 0..1 over the
/// head) and every face corner `v/vt` with `vt = v`.
pub fn textured_makehuman_obj() -> String {
    let text = std::fs::read_to_string(data("heads/makehuman_head.obj")).unwrap();
    let xy: Vec<[f32; 2]> = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f32> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            [v[0], v[1]]
        })
        .collect();
    let (min, max) = xy.iter().fold(([f32::MAX; 2], [f32::MIN; 2]), |(lo, hi), p| {
        (
            [lo[0].min(p[0]), lo[1].min(p[1])],
            [hi[0].max(p[0]), hi[1].max(p[1])],
        )
    });
    // Vertices and the rest first, then a coordinate per vertex, then the faces naming both.
    let mut out = String::with_capacity(text.len() * 2);
    let mut faces = String::new();
    for line in text.lines() {
        if let Some(corners) = line.strip_prefix("f ") {
            let corners: Vec<String> = corners.split_whitespace().map(|c| format!("{c}/{c}")).collect();
            faces.push_str(&format!("f {}\n", corners.join(" ")));
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    for [x, y] in &xy {
        out.push_str(&format!(
            "vt {} {}\n",
            (x - min[0]) / (max[0] - min[0]),
            (y - min[1]) / (max[1] - min[1])
        ));
    }
    out.push_str(&faces);
    out
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn adler32(bytes: &[u8]) -> u32 {
    let (mut a, mut b) = (1u32, 0u32);
    for &x in bytes {
        a = (a + u32::from(x)) % 65_521;
        b = (b + a) % 65_521;
    }
    (b << 16) | a
}

/// A `width` x `height` PNG of one colour.
pub fn solid_png(width: u32, height: u32, rgb: [u8; 3]) -> Vec<u8> {
    checker_png(width, height, 1, rgb, rgb)
}

/// A `width` x `height` PNG of `squares` x `squares` squares, `a` and `b` in turn (a
/// texture whose mapping shows).
pub fn checker_png(width: u32, height: u32, squares: u32, a: [u8; 3], b: [u8; 3]) -> Vec<u8> {
    let mut raw = Vec::with_capacity(((3 * width + 1) * height) as usize);
    for y in 0..height {
        raw.push(0); // each row: filter type 0 (none), then its pixels
        for x in 0..width {
            let odd = (x * squares / width + y * squares / height) % 2 == 1;
            raw.extend_from_slice(if odd { &b } else { &a });
        }
    }
    let mut zlib = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = raw.chunks(65_535).collect();
    for (i, block) in blocks.iter().enumerate() {
        zlib.push(u8::from(i + 1 == blocks.len()));
        let length = block.len() as u16;
        zlib.extend_from_slice(&length.to_le_bytes());
        zlib.extend_from_slice(&(!length).to_le_bytes());
        zlib.extend_from_slice(block);
    }
    zlib.extend_from_slice(&adler32(&raw).to_be_bytes());
    let mut png = vec![0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];
    let mut header = width.to_be_bytes().to_vec();
    header.extend_from_slice(&height.to_be_bytes());
    header.extend_from_slice(&[8, 2, 0, 0, 0]);
    for (kind, body) in [(b"IHDR", header), (b"IDAT", zlib), (b"IEND", Vec::new())] {
        png.extend_from_slice(&(body.len() as u32).to_be_bytes());
        let mut typed = kind.to_vec();
        typed.extend_from_slice(&body);
        png.extend_from_slice(&typed);
        png.extend_from_slice(&crc32(&typed).to_be_bytes());
    }
    png
}

/// The body of `POST /v1/heads` for the textured MakeHuman head as `id`, its texture
/// `png`.
pub fn textured_request(id: &str, png: &[u8]) -> serde_json::Value {
    use base64::Engine;
    serde_json::json!({
        "id": id,
        "obj": textured_makehuman_obj(),
        "fit": std::fs::read_to_string(data("heads/makehuman_head.fit.toml")).unwrap(),
        "texture": base64::engine::general_purpose::STANDARD.encode(png),
    })
}
