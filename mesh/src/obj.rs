//! Wavefront OBJ reading (`v` and `f` lines) and writing.
//!
//! Read: `v x y z [w | r g b]` (the first three numbers are kept), `f` with 3 or more corners
//! in any of the forms `i`, `i/t`, `i//n`, `i/t/n` (texture and normal indices are ignored),
//! negative indices counting back from the last vertex defined so far, and lines continued
//! with a trailing `\`. Polygons are fan-triangulated from their first corner. Every other
//! statement (`vt`, `vn`, `g`, `o`, `s`, `usemtl`, `mtllib`, `l`, `p`, comments) is skipped.
//! Positive indices may refer to vertices defined later in the file.

use std::fmt::Write as _;
use std::path::Path;

use crate::error::{MeshLoadError, MeshSaveError};
use crate::raw::{MAX_ABS_COORDINATE, RawMesh, coordinate_ok};
use crate::trimesh::TriMesh;
use crate::units::Units;

/// Parses OBJ bytes; `path` is used in error messages only.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<RawMesh, MeshLoadError> {
    let text = String::from_utf8_lossy(bytes);
    let syntax = |line: usize, message: String| MeshLoadError::ObjSyntax { path: path.to_path_buf(), line, message };
    let mut raw = RawMesh::default();
    // Line of each triangle's face, to name it if a forward index turns out out of range.
    let mut face_lines: Vec<usize> = Vec::new();
    // Resolved 0-based indices as i64 until the vertex count is final.
    let mut faces: Vec<[i64; 3]> = Vec::new();
    let mut corners: Vec<i64> = Vec::with_capacity(8);

    let mut lines = text.lines().enumerate();
    let mut joined = String::new();
    while let Some((i, first)) = lines.next() {
        let line_no = i + 1;
        // Join `\`-continued lines; report errors at the first line of the statement.
        let mut stmt: &str = first;
        if first.trim_end().ends_with('\\') {
            joined.clear();
            let mut cur = first;
            loop {
                let t = cur.trim_end();
                match t.strip_suffix('\\') {
                    Some(head) => {
                        joined.push_str(head);
                        joined.push(' ');
                        match lines.next() {
                            Some((_, next)) => cur = next,
                            None => break,
                        }
                    }
                    None => {
                        joined.push_str(t);
                        break;
                    }
                }
            }
            stmt = &joined;
        }
        let stmt = stmt.split('#').next().unwrap_or("");
        let mut toks = stmt.split_whitespace();
        match toks.next() {
            Some("v") => {
                let mut v = [0.0; 3];
                for (k, c) in v.iter_mut().enumerate() {
                    let Some(tok) = toks.next() else {
                        return Err(syntax(line_no, format!("vertex has {k} coordinates, 3 needed")));
                    };
                    *c = match tok.parse::<f64>() {
                        Ok(x) if coordinate_ok(x) => x,
                        Ok(x) if x.is_finite() => {
                            return Err(syntax(
                                line_no,
                                format!(
                                    "coordinate {x:e} is beyond ±{MAX_ABS_COORDINATE:e}, the largest a mesh file may hold"
                                ),
                            ));
                        }
                        _ => return Err(syntax(line_no, format!("`{tok}` is not a finite number"))),
                    };
                }
                raw.vertices.push(v);
            }
            Some("f") => {
                corners.clear();
                let defined = raw.vertices.len() as i64;
                for tok in toks {
                    let idx_text = tok.split('/').next().unwrap_or("");
                    let idx: i64 =
                        idx_text.parse().map_err(|_| syntax(line_no, format!("`{tok}` is not a vertex index")))?;
                    let resolved = match idx {
                        0 => return Err(syntax(line_no, "vertex index 0 is invalid (OBJ indices start at 1)".into())),
                        i if i > 0 => i - 1,
                        i => {
                            let r = defined + i;
                            if r < 0 {
                                return Err(MeshLoadError::ObjIndexOutOfRange {
                                    path: path.to_path_buf(),
                                    line: line_no,
                                    index: idx,
                                    vertex_count: defined as usize,
                                });
                            }
                            r
                        }
                    };
                    corners.push(resolved);
                }
                if corners.len() < 3 {
                    return Err(syntax(line_no, format!("face has {} corners, at least 3 needed", corners.len())));
                }
                for k in 1..corners.len() - 1 {
                    faces.push([corners[0], corners[k], corners[k + 1]]);
                    face_lines.push(line_no);
                }
            }
            _ => {}
        }
    }
    let n = raw.vertices.len();
    if u32::try_from(n).is_err() {
        return Err(MeshLoadError::TooLarge { path: path.to_path_buf() });
    }
    raw.triangles.reserve(faces.len());
    for (f, line) in faces.iter().zip(&face_lines) {
        let mut t = [0u32; 3];
        for (slot, &i) in t.iter_mut().zip(f) {
            if i as usize >= n {
                return Err(MeshLoadError::ObjIndexOutOfRange {
                    path: path.to_path_buf(),
                    line: *line,
                    index: i + 1,
                    vertex_count: n,
                });
            }
            *slot = i as u32;
        }
        raw.triangles.push(t);
    }
    Ok(raw)
}

/// Writes `mesh` as OBJ (`v` and `f` lines) with coordinates in `units` (the mesh is in
/// metres), printed with enough digits to read back the same `f64`.
///
/// # Errors
/// [`MeshSaveError::Io`] when the file cannot be written.
pub fn save_obj(path: impl AsRef<Path>, mesh: &TriMesh, units: Units) -> Result<(), MeshSaveError> {
    let path = path.as_ref();
    let k = 1.0 / units.metres_per_unit();
    let mut s = format!("# written by lamina-mesh, units: {}\n", units.name());
    for v in mesh.vertices() {
        let _ = writeln!(s, "v {:e} {:e} {:e}", v[0] * k, v[1] * k, v[2] * k);
    }
    for t in mesh.triangles() {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(path, s).map_err(|e| MeshSaveError::Io { path: path.to_path_buf(), message: e.to_string() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_forms_and_negative_indices_works() {
        let text = "# quad\nv 0 0 0\nv 1 0 0 1\nv 1 1 0 0.5 0.5 0.5\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
                    f 1/1/1 2//1 3/1 4\nf -4 -2 \\\n -1\ng x\ns off\n";
        let raw = parse(text.as_bytes(), Path::new("q.obj")).unwrap();
        assert_eq!(raw.vertices.len(), 4);
        assert_eq!(raw.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 3]]);
    }

    #[test]
    fn obj_forward_reference_works() {
        let raw = parse(b"f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", Path::new("f.obj")).unwrap();
        assert_eq!(raw.triangles, vec![[0, 1, 2]]);
    }

    #[test]
    fn obj_index_zero_fails() {
        let e = parse(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", Path::new("z.obj")).unwrap_err();
        assert!(matches!(e, MeshLoadError::ObjSyntax { line: 4, .. }), "{e}");
    }

    #[test]
    fn obj_negative_out_of_range_fails() {
        let e = parse(b"v 0 0 0\nv 1 0 0\nf -1 -2 -3\n", Path::new("n.obj")).unwrap_err();
        assert!(matches!(e, MeshLoadError::ObjIndexOutOfRange { line: 3, index: -3, vertex_count: 2, .. }), "{e}");
    }

    #[test]
    fn obj_two_corner_face_fails() {
        let e = parse(b"v 0 0 0\nv 1 0 0\nf 1 2\n", Path::new("t.obj")).unwrap_err();
        assert!(matches!(e, MeshLoadError::ObjSyntax { line: 3, .. }), "{e}");
    }

    #[test]
    fn obj_short_vertex_fails() {
        let e = parse(b"v 0 0\n", Path::new("s.obj")).unwrap_err();
        assert!(matches!(e, MeshLoadError::ObjSyntax { line: 1, .. }), "{e}");
    }
}
