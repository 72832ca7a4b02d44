//! Writes a [`Model`] as an XML model file (`docs/model-format.md`).
//!
//! Numbers are written in their shortest round-trip form (f64 for SI values, f32 for
//! texture coordinates), so reading the file back gives the same bits. The text is built in
//! a buffer and streamed to the file in large chunks; no document tree is built.

use super::error::ModelWriteError;
use super::format::{MODEL_FORMAT_VERSION, MODEL_UNITS, PPU_COMP_LEN, PPU_STRET_LEN_FACTOR, escape_attribute, names};
use crate::law::{PpuBilinearPair, PpuLinearSpring, SpringLaw};
use crate::model::{Model, ModelValidateError};
use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

/// Choices for writing a model file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ModelWriteOptions {
    /// Also write every bilinear spring as the paper's PPU pair (a `<ppu>` child with
    /// TurnLen, TurnForce and two linear springs). Informative only: the reader uses the
    /// spring's own law attributes when they are present. Default `true`; turn it off to
    /// make files of very large models about half as big.
    pub ppu_export: bool,
}

impl Default for ModelWriteOptions {
    fn default() -> Self {
        Self { ppu_export: true }
    }
}

/// Writes `model` to the file `path` (created or truncated) with default options.
///
/// # Errors
/// [`ModelWriteError::Invalid`] (and the other checks of [`model_to_string`]) before
/// anything is written; [`ModelWriteError::Io`] if the file cannot be written.
pub fn write_model(model: &Model, path: impl AsRef<Path>) -> Result<(), ModelWriteError> {
    write_model_with(model, path, ModelWriteOptions::default())
}

/// Writes `model` to the file `path` (created or truncated).
///
/// # Errors
/// As [`write_model`].
pub fn write_model_with(
    model: &Model,
    path: impl AsRef<Path>,
    options: ModelWriteOptions,
) -> Result<(), ModelWriteError> {
    let path = path.as_ref();
    check_writable(model)?;
    let io_error = |e: io::Error| ModelWriteError::Io { file: path.display().to_string(), message: e.to_string() };
    let mut file = File::create(path).map_err(io_error)?;
    emit(model, options, &mut file).map_err(io_error)
}

/// The XML text of `model`, with default options.
///
/// # Errors
/// [`ModelWriteError::Invalid`] if [`Model::validate`] fails or a surface grid names a
/// node that does not exist, [`ModelWriteError::NonFiniteTexcoord`],
/// [`ModelWriteError::UnrepresentableText`] for a NUL in a name or provenance string.
pub fn model_to_string(model: &Model) -> Result<String, ModelWriteError> {
    model_to_string_with(model, ModelWriteOptions::default())
}

/// The XML text of `model`.
///
/// # Errors
/// As [`model_to_string`].
pub fn model_to_string_with(model: &Model, options: ModelWriteOptions) -> Result<String, ModelWriteError> {
    check_writable(model)?;
    let mut bytes = Vec::new();
    emit(model, options, &mut bytes).expect("writing to a Vec cannot fail");
    Ok(String::from_utf8(bytes).expect("the writer emits UTF-8 only"))
}

/// Everything that would make the file unreadable, checked before a byte is written.
fn check_writable(model: &Model) -> Result<(), ModelWriteError> {
    model.validate().map_err(|reason| ModelWriteError::Invalid { reason })?;
    for (i, t) in model.nodes.texcoord.iter().enumerate() {
        if !t.iter().all(|c| c.is_finite()) {
            return Err(ModelWriteError::NonFiniteTexcoord { node: i as u32 });
        }
    }
    let n = model.nodes.len();
    for s in &model.surfaces {
        if let Some((columns, rows, grid)) = &s.grid
            && ((*columns as usize).checked_mul(*rows as usize) != Some(grid.len())
                || grid.iter().any(|&v| v as usize >= n))
        {
            return Err(ModelWriteError::Invalid {
                reason: ModelValidateError::BadSurface { surface: s.name.clone() },
            });
        }
    }
    let mut scratch = String::new();
    let mut text_ok = |what: &dyn Fn() -> String, s: &str| {
        scratch.clear();
        if escape_attribute(s, &mut scratch) {
            Ok(())
        } else {
            Err(ModelWriteError::UnrepresentableText { what: what() })
        }
    };
    text_ok(&|| "model name".into(), &model.name)?;
    for (i, (k, v)) in model.provenance.iter().enumerate() {
        text_ok(&|| format!("provenance key {i}"), k)?;
        text_ok(&|| format!("provenance value {i}"), v)?;
    }
    for (i, l) in model.layers.iter().enumerate() {
        text_ok(&|| format!("layer {i} name"), &l.name)?;
    }
    for (i, s) in model.surfaces.iter().enumerate() {
        text_ok(&|| format!("surface {i} name"), &s.name)?;
    }
    Ok(())
}

/// Text buffer that streams to `sink` in chunks.
struct Out<'w, W: Write> {
    buf: String,
    sink: &'w mut W,
    float: zmij::Buffer,
    int: itoa::Buffer,
}

const CHUNK: usize = 1 << 18;

impl<W: Write> Out<'_, W> {
    fn s(&mut self, s: &str) {
        self.buf.push_str(s);
    }

    /// ` name="value"` for an f64 (finite: checked by `validate`).
    fn f64(&mut self, name: &str, v: f64) {
        self.buf.push(' ');
        self.buf.push_str(name);
        self.buf.push_str("=\"");
        self.buf.push_str(self.float.format(v));
        self.buf.push('"');
    }

    fn f32(&mut self, name: &str, v: f32) {
        self.buf.push(' ');
        self.buf.push_str(name);
        self.buf.push_str("=\"");
        self.buf.push_str(self.float.format(v));
        self.buf.push('"');
    }

    fn int(&mut self, name: &str, v: u64) {
        self.buf.push(' ');
        self.buf.push_str(name);
        self.buf.push_str("=\"");
        self.buf.push_str(self.int.format(v));
        self.buf.push('"');
    }

    /// A bare integer followed by `sep`, for index lists.
    fn bare_int(&mut self, v: u64, sep: char) {
        self.buf.push_str(self.int.format(v));
        self.buf.push(sep);
    }

    fn text(&mut self, name: &str, v: &str) {
        self.buf.push(' ');
        self.buf.push_str(name);
        self.buf.push_str("=\"");
        escape_attribute(v, &mut self.buf);
        self.buf.push('"');
    }

    fn flush_if_full(&mut self) -> io::Result<()> {
        if self.buf.len() >= CHUNK { self.flush() } else { Ok(()) }
    }

    fn flush(&mut self) -> io::Result<()> {
        self.sink.write_all(self.buf.as_bytes())?;
        self.buf.clear();
        Ok(())
    }
}

fn emit<W: Write>(model: &Model, options: ModelWriteOptions, sink: &mut W) -> io::Result<()> {
    let mut o =
        Out { buf: String::with_capacity(CHUNK + 4096), sink, float: zmij::Buffer::new(), int: itoa::Buffer::new() };
    o.s("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- Lamina model file; format: docs/model-format.md -->\n<");
    o.s(names::ROOT);
    o.text("version", MODEL_FORMAT_VERSION);
    o.text("name", &model.name);
    o.text("units", MODEL_UNITS);
    o.s(">\n");

    if !model.provenance.is_empty() {
        o.s("  <provenance>\n");
        for (k, v) in &model.provenance {
            o.s("    <entry");
            o.text("key", k);
            o.text("value", v);
            o.s("/>\n");
        }
        o.s("  </provenance>\n");
    }

    o.s("  <layers");
    o.int("count", model.layers.len() as u64);
    o.s(">\n");
    for (i, l) in model.layers.iter().enumerate() {
        o.s("    <layer");
        o.int("index", i as u64);
        o.text("name", &l.name);
        o.text("tissue", l.tissue.name());
        o.s("/>\n");
    }
    o.s("  </layers>\n");

    let nodes = &model.nodes;
    o.s("  <nodes");
    o.int("count", nodes.len() as u64);
    o.s(">\n");
    for i in 0..nodes.len() {
        let p = nodes.position[i];
        o.s("    <node");
        o.int("index", i as u64);
        o.f64("x", p[0]);
        o.f64("y", p[1]);
        o.f64("z", p[2]);
        o.f64("mass", nodes.mass[i]);
        o.text("kind", nodes.kind[i].name());
        o.int("layer", nodes.layer[i] as u64);
        let t = nodes.texcoord[i];
        if t.iter().any(|c| c.to_bits() != 0) {
            o.f32("u", t[0]);
            o.f32("v", t[1]);
            o.f32("w", t[2]);
        }
        o.s("/>\n");
        o.flush_if_full()?;
    }
    o.s("  </nodes>\n");

    let springs = &model.springs;
    o.s("  <springs");
    o.int("count", springs.len() as u64);
    o.s(">\n");
    for i in 0..springs.len() {
        let rest = springs.rest_length[i];
        o.s("    <spring");
        o.int("index", i as u64);
        o.int("a", springs.a[i] as u64);
        o.int("b", springs.b[i] as u64);
        o.f64("rest-length", rest);
        o.int("layer", springs.layer[i] as u64);
        o.f64("damping", springs.damping[i]);
        match &springs.law[i] {
            SpringLaw::Linear { stiffness } => {
                o.text("law", names::LAW_LINEAR);
                o.f64("stiffness", *stiffness);
                o.s("/>\n");
            }
            SpringLaw::Bilinear(b) => {
                o.text("law", names::LAW_BILINEAR);
                o.f64("k1", b.k1);
                o.f64("k2", b.k2);
                o.f64("turn-length", b.turn_length);
                o.f64("k-compression", b.k_compression);
                match options.ppu_export.then(|| ppu_export(b, rest)).flatten() {
                    Some(pair) => {
                        o.s(">\n      <ppu");
                        o.f64("TurnLen", pair.turn_len);
                        o.f64("TurnForce", pair.turn_force);
                        o.s(">\n");
                        ppu_spring(&mut o, names::PPU_FIRST, &pair.first);
                        ppu_spring(&mut o, names::PPU_SECOND, &pair.second);
                        o.s("      </ppu>\n    </spring>\n");
                    }
                    None => o.s("/>\n"),
                }
            }
        }
        o.flush_if_full()?;
    }
    o.s("  </springs>\n");

    if !model.surfaces.is_empty() {
        o.s("  <surfaces");
        o.int("count", model.surfaces.len() as u64);
        o.s(">\n");
        for (i, s) in model.surfaces.iter().enumerate() {
            o.s("    <surface");
            o.int("index", i as u64);
            o.text("name", &s.name);
            o.s(">\n      <triangles");
            o.int("count", s.triangles.len() as u64);
            o.s(">\n");
            for t in &s.triangles {
                o.s("        ");
                o.bare_int(t[0] as u64, ' ');
                o.bare_int(t[1] as u64, ' ');
                o.bare_int(t[2] as u64, '\n');
                o.flush_if_full()?;
            }
            o.s("      </triangles>\n");
            if let Some((columns, rows, grid)) = &s.grid {
                o.s("      <grid");
                o.int("columns", *columns as u64);
                o.int("rows", *rows as u64);
                o.s(">\n");
                for row in grid.chunks((*columns as usize).max(1)) {
                    o.s("        ");
                    for (j, &v) in row.iter().enumerate() {
                        o.bare_int(v as u64, if j + 1 == row.len() { '\n' } else { ' ' });
                    }
                    o.flush_if_full()?;
                }
                o.s("      </grid>\n");
            }
            o.s("    </surface>\n");
        }
        o.s("  </surfaces>\n");
    }
    if !model.cells.is_empty() {
        o.s("  <cells");
        o.int("count", model.cells.len() as u64);
        o.s(">\n");
        for (i, c) in model.cells.iter().enumerate() {
            o.s("    <cell");
            o.int("index", i as u64);
            o.text("kind", c.kind.name());
            o.int("layer", c.layer as u64);
            o.s(" nodes=\"");
            let nodes = c.nodes();
            for (k, &v) in nodes.iter().enumerate() {
                o.bare_int(v as u64, if k + 1 == nodes.len() { '"' } else { ' ' });
            }
            o.s("/>\n");
            o.flush_if_full()?;
        }
        o.s("  </cells>\n");
    }
    o.s("</lamina-model>\n");
    o.flush()
}

/// The PPU pair written for a bilinear spring, or `None` when it has no finite PPU form
/// (e.g. zero turning length, or forces that overflow f64).
fn ppu_export(law: &crate::law::Bilinear, rest: f64) -> Option<PpuBilinearPair> {
    let pair = PpuBilinearPair::from_bilinear(law, rest, PPU_COMP_LEN, PPU_STRET_LEN_FACTOR * law.turn_length).ok()?;
    let s = [pair.first, pair.second];
    let all = s.iter().flat_map(|p| [p.comp_force, p.comp_len, p.rest_len, p.stret_force, p.stret_len]);
    all.chain([pair.turn_len, pair.turn_force]).all(f64::is_finite).then_some(pair)
}

fn ppu_spring<W: Write>(o: &mut Out<'_, W>, name: &str, s: &PpuLinearSpring) {
    o.s("        <");
    o.s(name);
    o.f64("CompForce", s.comp_force);
    o.f64("CompLen", s.comp_len);
    o.f64("RestLen", s.rest_len);
    o.f64("StretForce", s.stret_force);
    o.f64("StretLen", s.stret_len);
    o.s("/>\n");
}
