//! STL reading (binary and ASCII, told apart robustly) and writing.
//!
//! How the two are told apart, in order:
//! 1. the file is exactly `84 + 50 n` bytes long, `n` being the `u32` at byte 80: binary,
//!    even when the header starts with `solid` (many binary writers put that there);
//! 2. it starts with `solid` and its first kilobyte is text (no NUL or other control bytes
//!    except tab, CR, LF, FF): ASCII;
//! 3. otherwise binary; longer than `84 + 50 n` is accepted (trailing bytes ignored), shorter
//!    is [`MeshLoadError::StlTruncated`].

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

use crate::error::{MeshLoadError, MeshSaveError};
use crate::lex::Lexer;
use crate::raw::{MAX_ABS_COORDINATE, MeshFormat, RawMesh, coordinate_ok};
use crate::trimesh::TriMesh;
use crate::units::Units;

const HEADER: usize = 84;
const RECORD: usize = 50;

/// Parses STL bytes; `path` is used in error messages only.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<(RawMesh, MeshFormat), MeshLoadError> {
    let declared = (bytes.len() >= HEADER).then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]));
    let expected = declared.map(|n| HEADER as u64 + RECORD as u64 * u64::from(n));
    if expected == Some(bytes.len() as u64) {
        return parse_binary(bytes, path).map(|r| (r, MeshFormat::StlBinary));
    }
    if looks_like_ascii(bytes) {
        return parse_ascii(bytes, path).map(|r| (r, MeshFormat::StlAscii));
    }
    parse_binary(bytes, path).map(|r| (r, MeshFormat::StlBinary))
}

fn looks_like_ascii(bytes: &[u8]) -> bool {
    let start = bytes.iter().position(|b| !b.is_ascii_whitespace()).unwrap_or(bytes.len());
    let rest = &bytes[start..];
    if rest.len() < 5 || !rest[..5].eq_ignore_ascii_case(b"solid") {
        return false;
    }
    let head = &bytes[..bytes.len().min(1024)];
    head.iter().all(|&b| b >= 0x20 || matches!(b, b'\t' | b'\n' | b'\r' | 0x0c))
}

fn parse_binary(bytes: &[u8], path: &Path) -> Result<RawMesh, MeshLoadError> {
    let truncated = |declared: u64, complete: u64| MeshLoadError::StlTruncated {
        path: path.to_path_buf(),
        declared_triangles: declared,
        complete_triangles: complete,
        expected_bytes: HEADER as u64 + RECORD as u64 * declared,
        actual_bytes: bytes.len() as u64,
    };
    if bytes.len() < HEADER {
        return Err(truncated(0, 0));
    }
    let n = u64::from(u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]));
    let body = &bytes[HEADER..];
    let complete = (body.len() / RECORD) as u64;
    if complete < n {
        return Err(truncated(n, complete));
    }
    let vertex_count = n.checked_mul(3).filter(|&c| c <= u64::from(u32::MAX));
    let Some(vertex_count) = vertex_count else {
        return Err(MeshLoadError::TooLarge { path: path.to_path_buf() });
    };
    let mut raw =
        RawMesh { vertices: Vec::with_capacity(vertex_count as usize), triangles: Vec::with_capacity(n as usize) };
    for (t, rec) in body.chunks_exact(RECORD).take(n as usize).enumerate() {
        let f = |k: usize| f64::from(f32::from_le_bytes([rec[4 * k], rec[4 * k + 1], rec[4 * k + 2], rec[4 * k + 3]]));
        let base = raw.vertices.len() as u32;
        for corner in 0..3 {
            // Floats 0..3 are the facet normal, ignored; corners follow.
            let v = [f(3 + 3 * corner), f(4 + 3 * corner), f(5 + 3 * corner)];
            if !v.iter().all(|c| c.is_finite()) {
                return Err(MeshLoadError::StlNonFinite { path: path.to_path_buf(), triangle: t as u64 });
            }
            if let Some(&value) = v.iter().find(|c| !coordinate_ok(**c)) {
                return Err(MeshLoadError::StlCoordinateTooLarge {
                    path: path.to_path_buf(),
                    triangle: t as u64,
                    value,
                });
            }
            raw.vertices.push(v);
        }
        raw.triangles.push([base, base + 1, base + 2]);
    }
    Ok(raw)
}

fn parse_ascii(bytes: &[u8], path: &Path) -> Result<RawMesh, MeshLoadError> {
    let text = String::from_utf8_lossy(bytes);
    let mut lx = Lexer::new(&text);
    let err = |line: usize, message: String| MeshLoadError::StlSyntax { path: path.to_path_buf(), line, message };
    let mut raw = RawMesh::default();
    let mut solids = 0usize;
    let mut corners: Vec<[f64; 3]> = Vec::with_capacity(4);

    // Top level: `solid NAME ... endsolid NAME`, possibly several in a row.
    while let Some((line, tok)) = lx.next_token() {
        if !tok.eq_ignore_ascii_case("solid") {
            return Err(err(line, format!("expected `solid`, found `{tok}`")));
        }
        solids += 1;
        lx.skip_line();
        loop {
            let Some((line, tok)) = lx.next_token() else {
                return Err(err(lx.line(), "unexpected end of file: missing `endsolid`".into()));
            };
            if tok.eq_ignore_ascii_case("endsolid") {
                lx.skip_line();
                break;
            }
            if !tok.eq_ignore_ascii_case("facet") {
                return Err(err(line, format!("expected `facet` or `endsolid`, found `{tok}`")));
            }
            expect(&mut lx, "normal", path)?;
            for _ in 0..3 {
                number(&mut lx, path)?;
            }
            expect(&mut lx, "outer", path)?;
            expect(&mut lx, "loop", path)?;
            corners.clear();
            loop {
                let Some((line, tok)) = lx.next_token() else {
                    return Err(err(lx.line(), "unexpected end of file inside a facet".into()));
                };
                if tok.eq_ignore_ascii_case("vertex") {
                    corners.push([coordinate(&mut lx, path)?, coordinate(&mut lx, path)?, coordinate(&mut lx, path)?]);
                } else if tok.eq_ignore_ascii_case("endloop") {
                    if corners.len() < 3 {
                        return Err(err(line, format!("facet has {} vertices, at least 3 needed", corners.len())));
                    }
                    break;
                } else {
                    return Err(err(line, format!("expected `vertex` or `endloop`, found `{tok}`")));
                }
            }
            expect(&mut lx, "endfacet", path)?;
            // Polygons with more than three corners are fanned from the first.
            for k in 1..corners.len() - 1 {
                let base = u32::try_from(raw.vertices.len())
                    .ok()
                    .filter(|b| b.checked_add(3).is_some())
                    .ok_or_else(|| MeshLoadError::TooLarge { path: path.to_path_buf() })?;
                raw.vertices.extend_from_slice(&[corners[0], corners[k], corners[k + 1]]);
                raw.triangles.push([base, base + 1, base + 2]);
            }
        }
    }
    if solids == 0 {
        return Err(err(lx.line(), "empty file: expected `solid`".into()));
    }
    Ok(raw)
}

fn expect(lx: &mut Lexer<'_>, word: &str, path: &Path) -> Result<(), MeshLoadError> {
    match lx.next_token() {
        Some((_, tok)) if tok.eq_ignore_ascii_case(word) => Ok(()),
        Some((line, tok)) => Err(MeshLoadError::StlSyntax {
            path: path.to_path_buf(),
            line,
            message: format!("expected `{word}`, found `{tok}`"),
        }),
        None => Err(MeshLoadError::StlSyntax {
            path: path.to_path_buf(),
            line: lx.line(),
            message: format!("unexpected end of file: expected `{word}`"),
        }),
    }
}

fn number(lx: &mut Lexer<'_>, path: &Path) -> Result<f64, MeshLoadError> {
    number_on_line(lx, path).map(|(_, x)| x)
}

/// The next token as a finite number, and its 1-based line.
fn number_on_line(lx: &mut Lexer<'_>, path: &Path) -> Result<(usize, f64), MeshLoadError> {
    let Some((line, tok)) = lx.next_token() else {
        return Err(MeshLoadError::StlSyntax {
            path: path.to_path_buf(),
            line: lx.line(),
            message: "unexpected end of file: expected a number".into(),
        });
    };
    match tok.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok((line, x)),
        _ => Err(MeshLoadError::StlSyntax {
            path: path.to_path_buf(),
            line,
            message: format!("`{tok}` is not a finite number"),
        }),
    }
}

/// A vertex coordinate: a finite number within ±[`MAX_ABS_COORDINATE`].
fn coordinate(lx: &mut Lexer<'_>, path: &Path) -> Result<f64, MeshLoadError> {
    let (line, x) = number_on_line(lx, path)?;
    if coordinate_ok(x) {
        return Ok(x);
    }
    Err(MeshLoadError::StlSyntax {
        path: path.to_path_buf(),
        line,
        message: format!("coordinate {x:e} is beyond ±{MAX_ABS_COORDINATE:e}, the largest a mesh file may hold"),
    })
}

fn save_io(path: &Path, e: std::io::Error) -> MeshSaveError {
    MeshSaveError::Io { path: path.to_path_buf(), message: e.to_string() }
}

/// Writes `mesh` as binary STL with coordinates in `units` (the mesh is in metres).
///
/// The 80-byte header reads `binary STL written by lamina-mesh`; facet normals are the
/// triangles' unit normals (zero for zero-area triangles). Coordinates are rounded to `f32`.
///
/// # Errors
/// [`MeshSaveError::Io`] when the file cannot be written.
pub fn save_stl_binary(path: impl AsRef<Path>, mesh: &TriMesh, units: Units) -> Result<(), MeshSaveError> {
    let path = path.as_ref();
    let k = 1.0 / units.metres_per_unit();
    let mut out = Vec::with_capacity(HEADER + RECORD * mesh.triangle_count());
    let mut header = [b' '; 80];
    let text = b"binary STL written by lamina-mesh";
    header[..text.len()].copy_from_slice(text);
    out.extend_from_slice(&header);
    out.extend_from_slice(&(mesh.triangle_count().min(u32::MAX as usize) as u32).to_le_bytes());
    for (t, tri) in mesh.triangles().iter().enumerate().take(u32::MAX as usize) {
        let n = mesh.triangle_normal(t).unwrap_or([0.0; 3]);
        for c in n {
            out.extend_from_slice(&(c as f32).to_le_bytes());
        }
        for &i in tri {
            for c in mesh.vertices()[i as usize] {
                out.extend_from_slice(&((c * k) as f32).to_le_bytes());
            }
        }
        out.extend_from_slice(&[0, 0]);
    }
    std::fs::write(path, out).map_err(|e| save_io(path, e))
}

/// Writes `mesh` as ASCII STL (solid name `lamina`) with coordinates in `units`, printed
/// with enough digits to read back the same `f64`.
///
/// # Errors
/// [`MeshSaveError::Io`] when the file cannot be written.
pub fn save_stl_ascii(path: impl AsRef<Path>, mesh: &TriMesh, units: Units) -> Result<(), MeshSaveError> {
    let path = path.as_ref();
    let k = 1.0 / units.metres_per_unit();
    let mut s = String::from("solid lamina\n");
    for (t, tri) in mesh.triangles().iter().enumerate() {
        let n = mesh.triangle_normal(t).unwrap_or([0.0; 3]);
        let _ = writeln!(s, "  facet normal {:e} {:e} {:e}\n    outer loop", n[0], n[1], n[2]);
        for &i in tri {
            let v = mesh.vertices()[i as usize];
            let _ = writeln!(s, "      vertex {:e} {:e} {:e}", v[0] * k, v[1] * k, v[2] * k);
        }
        s.push_str("    endloop\n  endfacet\n");
    }
    s.push_str("endsolid lamina\n");
    let mut f = std::fs::File::create(path).map_err(|e| save_io(path, e))?;
    f.write_all(s.as_bytes()).map_err(|e| save_io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_triangle_binary(header_start: &[u8]) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b[..header_start.len()].copy_from_slice(header_start);
        b.extend_from_slice(&1u32.to_le_bytes());
        for x in [0.0f32, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
            b.extend_from_slice(&x.to_le_bytes());
        }
        b.extend_from_slice(&[0, 0]);
        b
    }

    #[test]
    fn stl_binary_starting_with_solid_works() {
        let b = one_triangle_binary(b"solid but actually binary");
        let (raw, fmt) = parse(&b, Path::new("x.stl")).unwrap();
        assert_eq!(fmt, MeshFormat::StlBinary);
        assert_eq!(raw.triangles.len(), 1);
        assert_eq!(raw.vertices[1], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn stl_binary_with_trailing_bytes_works() {
        let mut b = one_triangle_binary(b"exporter");
        b.extend_from_slice(b"junk");
        let (raw, fmt) = parse(&b, Path::new("x.stl")).unwrap();
        assert_eq!((fmt, raw.triangles.len()), (MeshFormat::StlBinary, 1));
    }

    #[test]
    fn stl_binary_truncated_solid_header_fails() {
        let mut b = one_triangle_binary(b"solid x");
        b.truncate(100);
        let e = parse(&b, Path::new("cut.stl")).unwrap_err();
        assert!(matches!(e, MeshLoadError::StlTruncated { declared_triangles: 1, complete_triangles: 0, .. }), "{e}");
    }

    #[test]
    fn stl_binary_nan_fails() {
        let mut b = one_triangle_binary(b"x");
        b[84 + 12..84 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = parse(&b, Path::new("nan.stl")).unwrap_err();
        assert!(matches!(e, MeshLoadError::StlNonFinite { triangle: 0, .. }), "{e}");
    }

    #[test]
    fn stl_ascii_quad_facet_and_two_solids_works() {
        let text = "solid a b c\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\n\
                    vertex 0 1 0\nendloop\nendfacet\nendsolid a\nSOLID\n facet normal 0 0 1 outer loop vertex 0 0 0 \
                    vertex 1 0 0 vertex 1 1 0 endloop endfacet endsolid\n";
        let (raw, fmt) = parse(text.as_bytes(), Path::new("a.stl")).unwrap();
        assert_eq!(fmt, MeshFormat::StlAscii);
        assert_eq!(raw.triangles.len(), 3);
    }

    #[test]
    fn stl_ascii_missing_endsolid_fails() {
        let text =
            "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nendloop\nendfacet\n";
        let e = parse(text.as_bytes(), Path::new("a.stl")).unwrap_err();
        assert!(matches!(e, MeshLoadError::StlSyntax { line: 8, .. }), "{e}");
    }

    #[test]
    fn stl_ascii_nan_fails() {
        let text = "solid a\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\n";
        let e = parse(text.as_bytes(), Path::new("a.stl")).unwrap_err();
        assert!(matches!(e, MeshLoadError::StlSyntax { line: 5, .. }), "{e}");
    }

    #[test]
    fn stl_tiny_garbage_fails() {
        let e = parse(b"hello", Path::new("g.stl")).unwrap_err();
        assert!(matches!(e, MeshLoadError::StlTruncated { actual_bytes: 5, .. }), "{e}");
    }
}
