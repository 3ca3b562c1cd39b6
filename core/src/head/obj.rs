//! Wavefront OBJ reader for dense heads: `v` and `f` records, polygons fanned into
//! triangles, and the texture coordinates (`vt`, and each face corner's `v/vt`) when every
//! face has them; everything else (normals, groups, materials) skipped.
//!
//! Why not tobj: its `single_index: false` mode renumbers vertices in first-use order per
//! object and drops unreferenced ones, and facewire's vertex-indexed data (expression
//! targets, deformed frames written "in the same vertex order as the input") needs the
//! file's own numbering. Its errors also carry no line numbers, which ours always do.

use glam::Vec3;

use crate::quote::quote;

/// Refuses files with more vertices or triangles than this (bounded memory on uploads).
pub const MAX_ELEMENTS: usize = 5_000_000;

/// Largest coordinate magnitude a vertex may have. Nearest-point queries square
/// differences of coordinates in f32 (R*-tree envelopes), which overflow to infinity and
/// then NaN past about 1e19; no head in any unit lies a million kilometres out.
pub const MAX_COORDINATE: f32 = 1e15;

/// Most corners one `f` line may have. Scanners and modellers write triangles and quads
/// (n-gons of a dozen corners at most); a polygon of thousands of corners fans into
/// thousands of thin triangles around one vertex, which no face mesh needs.
pub const MAX_FACE_CORNERS: usize = 64;

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ObjError {
    /// `found` is quoted and cut by [`quote`].
    #[error("line {line}: {field} {found} is not a number")]
    NotANumber {
        line: usize,
        field: &'static str,
        found: String,
    },
    #[error("line {line}: vertex {vertex} has a non-finite coordinate ({value})")]
    NotFinite { line: usize, vertex: usize, value: f32 },
    #[error(
        "line {line}: vertex {vertex} has a coordinate of {value:e}; at most {MAX_COORDINATE:e} either way"
    )]
    TooFar { line: usize, vertex: usize, value: f32 },
    #[error("line {line}: vertex record needs 3 coordinates, found {found}")]
    ShortVertex { line: usize, found: usize },
    #[error("line {line}: face needs at least 3 corners, found {found}")]
    ShortFace { line: usize, found: usize },
    #[error("line {line}: a face with {corners} corners; at most {limit}")]
    FaceTooLarge {
        line: usize,
        corners: usize,
        limit: usize,
    },
    #[error("line {line}: face corner {index} is out of range (the file has {count} vertices so far)")]
    IndexOutOfRange { line: usize, index: i64, count: usize },
    #[error("line {line}: texture coordinate {index} is out of range (the file has {count} so far)")]
    TextureIndexOutOfRange { line: usize, index: i64, count: usize },
    #[error("line {line}: texture coordinate {which} is {value}; it must be finite")]
    TextureNotFinite { line: usize, which: usize, value: f32 },
    #[error("line {line}: more than {limit} vertices or triangles")]
    TooLarge { line: usize, limit: usize },
    #[error("the file has no triangles")]
    NoTriangles,
}

/// Vertices (head units, file order) and triangles (0-based indices) of an OBJ text.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjMesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Where each triangle's corners sit on the texture, when every face says.
    pub texture: Option<TextureCoords>,
}

/// A mesh's texture coordinates: `coords` (u, v; v up, as OBJ writes them) and, for each
/// triangle, the coordinate of each of its corners (a vertex on a seam has one per side).
#[derive(Debug, Clone, PartialEq)]
pub struct TextureCoords {
    pub coords: Vec<[f32; 2]>,
    pub corners: Vec<[u32; 3]>,
}

pub fn parse(text: &str) -> Result<ObjMesh, ObjError> {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut coords: Vec<[f32; 2]> = Vec::new();
    let mut texture_corners: Vec<[u32; 3]> = Vec::new();
    // Whether every face so far gave each corner a texture coordinate.
    let mut textured = true;
    let mut corners: Vec<u32> = Vec::with_capacity(8);
    let mut uv_corners: Vec<Option<u32>> = Vec::with_capacity(8);
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let mut fields = raw.split_whitespace();
        match fields.next() {
            Some("v") => {
                if positions.len() >= MAX_ELEMENTS {
                    return Err(ObjError::TooLarge {
                        line,
                        limit: MAX_ELEMENTS,
                    });
                }
                let mut xyz = [0.0f32; 3];
                let mut found = 0;
                for (k, text) in fields.take(3).enumerate() {
                    let value: f32 = text.parse().map_err(|_| ObjError::NotANumber {
                        line,
                        field: ["x", "y", "z"][k],
                        found: quote(text),
                    })?;
                    if !value.is_finite() {
                        return Err(ObjError::NotFinite {
                            line,
                            vertex: positions.len(),
                            value,
                        });
                    }
                    if value.abs() > MAX_COORDINATE {
                        return Err(ObjError::TooFar {
                            line,
                            vertex: positions.len(),
                            value,
                        });
                    }
                    xyz[k] = value;
                    found += 1;
                }
                if found < 3 {
                    return Err(ObjError::ShortVertex { line, found });
                }
                positions.push(Vec3::from_array(xyz));
            }
            Some("vt") => {
                if coords.len() >= MAX_ELEMENTS {
                    return Err(ObjError::TooLarge {
                        line,
                        limit: MAX_ELEMENTS,
                    });
                }
                // `u [v [w]]`: v is 0 when left out, w is ignored.
                let mut uv = [0.0f32; 2];
                for (k, text) in fields.take(2).enumerate() {
                    let value: f32 = text.parse().map_err(|_| ObjError::NotANumber {
                        line,
                        field: ["u", "v"][k],
                        found: quote(text),
                    })?;
                    if !value.is_finite() {
                        return Err(ObjError::TextureNotFinite {
                            line,
                            which: coords.len(),
                            value,
                        });
                    }
                    uv[k] = value;
                }
                coords.push(uv);
            }
            Some("f") => {
                corners.clear();
                uv_corners.clear();
                for corner in fields.by_ref().take(MAX_FACE_CORNERS + 1) {
                    let (vertex, uv) = parse_corner(line, corner, positions.len(), coords.len())?;
                    corners.push(vertex);
                    uv_corners.push(uv);
                }
                if corners.len() > MAX_FACE_CORNERS {
                    return Err(ObjError::FaceTooLarge {
                        line,
                        corners: corners.len() + fields.count(),
                        limit: MAX_FACE_CORNERS,
                    });
                }
                if corners.len() < 3 {
                    return Err(ObjError::ShortFace {
                        line,
                        found: corners.len(),
                    });
                }
                if triangles.len() + corners.len() > MAX_ELEMENTS {
                    return Err(ObjError::TooLarge {
                        line,
                        limit: MAX_ELEMENTS,
                    });
                }
                for k in 1..corners.len() - 1 {
                    triangles.push([corners[0], corners[k], corners[k + 1]]);
                }
                textured &= uv_corners.iter().all(Option::is_some);
                if textured {
                    let uv = |k: usize| uv_corners[k].expect("every corner has one");
                    for k in 1..corners.len() - 1 {
                        texture_corners.push([uv(0), uv(k), uv(k + 1)]);
                    }
                }
            }
            _ => {}
        }
    }
    if triangles.is_empty() {
        return Err(ObjError::NoTriangles);
    }
    let texture = textured.then_some(TextureCoords {
        coords,
        corners: texture_corners,
    });
    Ok(ObjMesh {
        positions,
        triangles,
        texture,
    })
}

/// `7`, `7/1`, `7//3`, `7/1/3` or negative (relative) indices: the vertex, and the
/// texture coordinate when the corner names one.
fn parse_corner(
    line: usize,
    text: &str,
    count: usize,
    coords: usize,
) -> Result<(u32, Option<u32>), ObjError> {
    let mut fields = text.split('/');
    let vertex = fields.next().unwrap_or(text);
    let resolve = |text: &str, field: &'static str, count: usize| -> Result<(i64, i64), ObjError> {
        let index: i64 = text.parse().map_err(|_| ObjError::NotANumber {
            line,
            field,
            found: quote(text),
        })?;
        Ok((
            index,
            if index > 0 {
                index - 1
            } else {
                count as i64 + index
            },
        ))
    };
    let (index, resolved) = resolve(vertex, "face corner", count)?;
    if index == 0 || resolved < 0 || resolved >= count as i64 {
        return Err(ObjError::IndexOutOfRange { line, index, count });
    }
    let uv = match fields.next() {
        None | Some("") => None,
        Some(uv) => {
            let (index, resolved) = resolve(uv, "texture corner", coords)?;
            if index == 0 || resolved < 0 || resolved >= coords as i64 {
                return Err(ObjError::TextureIndexOutOfRange {
                    line,
                    index,
                    count: coords,
                });
            }
            Some(resolved as u32)
        }
    };
    Ok((resolved as u32, uv))
}

/// Writes positions and triangles as OBJ text (1-based indices), `header` lines as
/// `#` comments first.
pub fn write(
    out: &mut impl std::io::Write,
    header: &[String],
    positions: &[Vec3],
    triangles: &[[u32; 3]],
) -> std::io::Result<()> {
    for line in header {
        writeln!(out, "# {line}")?;
    }
    for p in positions {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for t in triangles {
        writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    Ok(())
}

/// [`write`] with texture coordinates: `vt` records, then each face corner as `v/vt`
/// (`texture.corners` has one entry per triangle).
pub fn write_textured(
    out: &mut impl std::io::Write,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    texture: &TextureCoords,
) -> std::io::Result<()> {
    for p in positions {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for [u, v] in &texture.coords {
        writeln!(out, "vt {u} {v}")?;
    }
    for (t, c) in triangles.iter().zip(&texture.corners) {
        let [a, b, d] = [0, 1, 2].map(|k| format!("{}/{}", t[k] + 1, c[k] + 1));
        writeln!(out, "f {a} {b} {d}")?;
    }
    Ok(())
}

/// Another object after what [`write`] wrote: `o name`, its vertices, its triangles
/// numbered after the `first_vertex` vertices already in the file.
pub fn write_object(
    out: &mut impl std::io::Write,
    name: &str,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    first_vertex: u32,
) -> std::io::Result<()> {
    writeln!(out, "o {name}")?;
    for p in positions {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    let base = first_vertex + 1;
    for t in triangles {
        writeln!(out, "f {} {} {}", t[0] + base, t[1] + base, t[2] + base)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_polygons_slashes_and_negative_indices() {
        let text =
            "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -3 -1\n";
        let mesh = parse(text).unwrap();
        assert_eq!(mesh.positions.len(), 4);
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 3]]);
    }

    #[test]
    fn texture_coordinates_follow_each_triangle_s_corners_across_a_seam() {
        // A quad whose right edge is a seam: vertex 2 and 3 have a coordinate per side.
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 0.5 0\nvt 0.5 1\nvt 0 1\n\
                    vt 1 0\nvt 1 1 0\nf 1/1 2/2/1 3/3/1 4/4\nf 2/5 3/-1 4/4\n";
        let mesh = parse(text).unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [1, 2, 3]]);
        let texture = mesh.texture.unwrap();
        assert_eq!(texture.coords.len(), 6);
        assert_eq!((texture.coords[1], texture.coords[5]), ([0.5, 0.0], [1.0, 1.0]));
        assert_eq!(texture.corners, vec![[0, 1, 2], [0, 2, 3], [4, 5, 3]]);
        // A face without them: no texture for the mesh.
        let partly = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/1 3/1\nf 1 2 3\n").unwrap();
        assert_eq!(partly.texture, None);
        assert_eq!(
            parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap().texture,
            None
        );
        // Out of range or not finite: refused, naming the line.
        assert_eq!(
            parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n"),
            Err(ObjError::TextureIndexOutOfRange {
                line: 5,
                index: 2,
                count: 1
            })
        );
        assert!(matches!(
            parse("v 0 0 0\nvt 0 inf\n"),
            Err(ObjError::TextureNotFinite {
                line: 2,
                which: 0,
                ..
            })
        ));
    }

    #[test]
    fn a_textured_mesh_written_reads_back_the_same() {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE];
        let triangles = vec![[0, 1, 2], [1, 3, 2]];
        let texture = TextureCoords {
            coords: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.5]],
            corners: vec![[0, 1, 2], [4, 3, 2]],
        };
        let mut text = Vec::new();
        write_textured(&mut text, &positions, &triangles, &texture).unwrap();
        let back = parse(std::str::from_utf8(&text).unwrap()).unwrap();
        assert_eq!((back.positions, back.triangles), (positions, triangles));
        assert_eq!(back.texture, Some(texture));
    }

    #[test]
    fn keeps_unreferenced_vertices_in_file_order() {
        let mesh = parse("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 2 3 4\n").unwrap();
        assert_eq!(mesh.positions[0], Vec3::splat(9.0));
        assert_eq!(mesh.triangles, vec![[1, 2, 3]]);
    }

    #[test]
    fn errors_name_the_line() {
        assert_eq!(
            parse("v 0 0 0\nv 1 x 0\n"),
            Err(ObjError::NotANumber {
                line: 2,
                field: "y",
                found: quote("x")
            })
        );
        assert_eq!(
            parse("v 0 0 0\nv 1 x 0\n").unwrap_err().to_string(),
            "line 2: y \"x\" is not a number"
        );
        match parse("v 0 0 0\nv 1 nan 0\n") {
            Err(ObjError::NotFinite {
                line: 2,
                vertex: 1,
                value,
            }) => assert!(value.is_nan()),
            other => panic!("expected NotFinite, got {other:?}"),
        }
        assert_eq!(
            parse("v 0 0 0\nv 1 -2e15 0\n"),
            Err(ObjError::TooFar {
                line: 2,
                vertex: 1,
                value: -2e15
            })
        );
        assert_eq!(
            parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"),
            Err(ObjError::IndexOutOfRange {
                line: 4,
                index: 4,
                count: 3
            })
        );
        assert_eq!(parse("v 0 0\n"), Err(ObjError::ShortVertex { line: 1, found: 2 }));
        assert_eq!(
            parse("v 0 0 0\nf 1 1\n"),
            Err(ObjError::ShortFace { line: 2, found: 2 })
        );
        assert_eq!(parse("garbage\n"), Err(ObjError::NoTriangles));
    }

    #[test]
    fn a_huge_polygon_is_refused_with_its_size() {
        let corners: Vec<String> = (1..=80_000).map(|i| i.to_string()).collect();
        let text = format!(
            "{}# the polygon\nf {}\n",
            "v 0 0 0\n".repeat(80_000),
            corners.join(" ")
        );
        assert_eq!(
            parse(&text).unwrap_err().to_string(),
            "line 80002: a face with 80000 corners; at most 64"
        );
        let ring: Vec<String> = (1..=MAX_FACE_CORNERS).map(|i| i.to_string()).collect();
        let text = format!("{}f {}\n", "v 0 0 0\n".repeat(MAX_FACE_CORNERS), ring.join(" "));
        assert_eq!(parse(&text).unwrap().triangles.len(), MAX_FACE_CORNERS - 2);
    }

    #[test]
    fn a_six_megabyte_token_is_quoted_short() {
        let token = "9".repeat(3_000_000) + &"x".repeat(3_000_000);
        let err = parse(&format!("v 0 0 0\nv 1 {token} 0\n"))
            .unwrap_err()
            .to_string();
        assert!(
            err.len() < 120,
            "{} bytes: {}",
            err.len(),
            &err[..200.min(err.len())]
        );
        assert!(err.ends_with("… (6000000 bytes) is not a number"), "{err}");
        let err = parse(&format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 {token}\n"))
            .unwrap_err()
            .to_string();
        assert!(err.len() < 120, "{} bytes", err.len());
    }
}
