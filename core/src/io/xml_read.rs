//! Reads XML model files (`docs/model-format.md`) into a [`Model`].
//!
//! A streaming pass over quick-xml events, no document tree: memory is the model plus a
//! read buffer. Each element is checked as it arrives (numbers, indices, counts, section
//! order); [`Model::validate`] runs at the end. Errors carry the byte offset of the
//! offending element or attribute; the public entry points turn it into file, line and
//! column (see [`super::locate`]).

use super::error::ModelReadError;
use super::format::{MODEL_FORMAT_VERSION, MODEL_UNITS, names};
use super::locate::{Source, element_offset, fill_location};
use super::xml_attrs::{
    Item, Slot, at, float32, float64, gather, index_below, integer, optional_f64, required, required_f64, unknown_value,
};
use crate::law::{Bilinear, PpuBilinearPair, PpuLinearSpring, SpringLaw};
use crate::model::{Cell, CellKind, Layer, Model, ModelValidateError, NodeKind, Surface, Tissue};
use lamina_input::FileReadError;
use quick_xml::errors::{Error as XmlError, SyntaxError};
use quick_xml::events::{BytesStart, Event};
use quick_xml::name::QName;
use quick_xml::reader::Reader;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Reads the model file at `path`.
///
/// # Errors
/// [`ModelReadError::Io`] if the file cannot be read, [`ModelReadError::Refused`] if it is
/// not a regular file, is larger than [`MODEL_FILE`](super::MODEL_FILE)'s cap or needs more memory than is
/// available; otherwise the first problem found, with file, line and column (the variants
/// of [`ModelReadError`]).
pub fn read_model(path: impl AsRef<Path>) -> Result<Model, ModelReadError> {
    let path = path.as_ref();
    let source = Source::File(path);
    let (file, size) = lamina_input::open_regular(path, &super::MODEL_FILE).map_err(|e| match e {
        FileReadError::Io { message, .. } => ModelReadError::Io { file: path.display().to_string(), message },
        refused => ModelReadError::Refused(refused),
    })?;
    let parsed = parse(BufReader::with_capacity(1 << 20, file.take(super::MODEL_FILE.max_bytes)), size);
    finish(parsed, &source)
}

/// Reads a model from XML text (error locations name the file `<string>`).
///
/// # Errors
/// As [`read_model`].
pub fn model_from_str(text: &str) -> Result<Model, ModelReadError> {
    finish(parse(text.as_bytes(), text.len() as u64), &Source::Text(text))
}

/// Runs [`Model::validate`] and turns byte offsets into file, line and column.
fn finish(parsed: Result<Model, ModelReadError>, source: &Source<'_>) -> Result<Model, ModelReadError> {
    let mut err = match parsed {
        Ok(model) => match model.validate() {
            Ok(()) => return Ok(model),
            Err(reason) => {
                let offset = invalid_element(&model, &reason).and_then(|(name, n)| element_offset(source, name, n));
                ModelReadError::Invalid { at: at(offset.unwrap_or(0)), reason }
            }
        },
        Err(e) => e,
    };
    fill_location(source, &mut err);
    Err(err)
}

/// The element a validation failure points at: element name and ordinal.
fn invalid_element(model: &Model, reason: &ModelValidateError) -> Option<(&'static str, u64)> {
    match reason {
        ModelValidateError::BadNode { node } => Some((names::NODE, *node as u64)),
        ModelValidateError::BadSpringEnds { spring } | ModelValidateError::BadSpringParameters { spring } => {
            Some((names::SPRING, *spring as u64))
        }
        ModelValidateError::BadSurface { surface } => {
            model.surfaces.iter().position(|s| &s.name == surface).map(|i| (names::SURFACE, i as u64))
        }
        ModelValidateError::BadCell { cell } => Some((names::CELL, *cell as u64)),
        ModelValidateError::BadLayer { .. } | ModelValidateError::RaggedArrays => Some((names::ROOT, 0)),
    }
}

/// Smallest plausible size of one list element in bytes, to bound preallocation by the
/// input size rather than by a `count` attribute that could be anything.
pub const MIN_ELEMENT_BYTES: u64 = 16;

/// Where the parser is in the document.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ctx {
    Root,
    Provenance,
    Entry,
    Layers,
    Layer,
    Materials,
    Material,
    Nodes,
    Node,
    Springs,
    Spring,
    Ppu,
    PpuFirst,
    PpuSecond,
    Surfaces,
    Surface,
    Triangles,
    Grid,
    Cells,
    Cell,
}

impl Ctx {
    fn name(self) -> &'static str {
        match self {
            Ctx::Root => names::ROOT,
            Ctx::Provenance => names::PROVENANCE,
            Ctx::Entry => names::ENTRY,
            Ctx::Layers => names::LAYERS,
            Ctx::Layer => names::LAYER,
            Ctx::Materials => names::MATERIALS,
            Ctx::Material => names::MATERIAL,
            Ctx::Nodes => names::NODES,
            Ctx::Node => names::NODE,
            Ctx::Springs => names::SPRINGS,
            Ctx::Spring => names::SPRING,
            Ctx::Ppu => names::PPU,
            Ctx::PpuFirst => names::PPU_FIRST,
            Ctx::PpuSecond => names::PPU_SECOND,
            Ctx::Surfaces => names::SURFACES,
            Ctx::Surface => names::SURFACE,
            Ctx::Triangles => names::TRIANGLES,
            Ctx::Grid => names::GRID,
            Ctx::Cells => names::CELLS,
            Ctx::Cell => names::CELL,
        }
    }
}

/// What the event loop does after a start tag.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Next {
    /// Read on.
    Continue,
    /// The element is a `<ppu>` export next to the spring's own law: informative, skipped
    /// to its end tag without looking at its attributes.
    SkipInformative,
}

/// Sections of the root in the order they must appear (rank = position + 1).
const SECTIONS: [&str; 7] =
    [names::PROVENANCE, names::LAYERS, names::MATERIALS, names::NODES, names::SPRINGS, names::SURFACES, names::CELLS];
/// Sections that must be present.
const REQUIRED_SECTIONS: [&str; 3] = [names::LAYERS, names::NODES, names::SPRINGS];

/// The law attributes shared by springs (`turn-length`) and materials (`turn-strain`).
struct LawAttrs {
    law: usize,
    stiffness: usize,
    k1: usize,
    k2: usize,
    turn: usize,
    kc: usize,
}

/// Law family and parameters as read: for materials `turn` is a strain, for springs a length.
#[derive(Clone, Copy, Debug)]
enum LawParams {
    Linear(f64),
    Bilinear { k1: f64, k2: f64, turn: f64, kc: f64 },
}

/// Per-layer defaults from `<materials>`.
#[derive(Clone, Copy, Debug, Default)]
struct Material {
    law: Option<LawParams>,
    damping: Option<f64>,
}

/// A spring whose end tag has not been seen yet (it may hold a `<ppu>` child).
struct PendingSpring {
    ordinal: u64,
    start: u64,
    a: u32,
    b: u32,
    rest: Option<f64>,
    layer: u16,
    damping: Option<f64>,
    law: Option<LawParams>,
    ppu_at: Option<u64>,
    ppu_turn: (f64, f64),
    ppu_first: Option<PpuLinearSpring>,
    ppu_second: Option<PpuLinearSpring>,
}

/// A surface whose end tag has not been seen yet.
struct PendingSurface {
    surface: Surface,
    has_triangles: bool,
    /// Triangle count, or columns × rows for the grid.
    declared: u64,
    tokens: Vec<u32>,
}

struct Parser {
    model: Model,
    stack: Vec<Ctx>,
    root_seen: bool,
    root_done: bool,
    /// Rank of the last section opened (0: none).
    last_section: usize,
    /// Which of [`REQUIRED_SECTIONS`] have been read.
    seen: [bool; 3],
    /// Count declared by the current list section, and elements found in it so far.
    declared: u64,
    found: u64,
    materials: Vec<Material>,
    material_set: Vec<bool>,
    spring: Option<PendingSpring>,
    surface: Option<PendingSurface>,
    size_hint: u64,
}

/// Parses a whole document. Error locations hold byte offsets only.
fn parse<R: BufRead>(input: R, size_hint: u64) -> Result<Model, ModelReadError> {
    let mut reader = Reader::from_reader(input);
    {
        let config = reader.config_mut();
        config.expand_empty_elements = false;
        config.check_end_names = true;
        config.trim_text(false);
    }
    let mut p = Parser {
        model: Model::default(),
        stack: Vec::with_capacity(8),
        root_seen: false,
        root_done: false,
        last_section: 0,
        seen: [false; 3],
        declared: 0,
        found: 0,
        materials: Vec::new(),
        material_set: Vec::new(),
        spring: None,
        surface: None,
        size_hint,
    };
    let mut buf = Vec::with_capacity(4096);
    loop {
        let start = reader.buffer_position();
        let event = match reader.read_event_into(&mut buf) {
            Ok(event) => event,
            Err(e) => return Err(p.xml_error(e, reader.error_position())),
        };
        match event {
            Event::Start(e) => {
                if p.start(&e, start)? == Next::SkipInformative {
                    buf.clear();
                    if let Err(e) = reader.read_to_end_into(QName(names::PPU), &mut buf) {
                        return Err(p.xml_error(e, reader.error_position()));
                    }
                    p.stack.pop();
                }
            }
            Event::Empty(e) => {
                p.start(&e, start)?;
                p.end(start)?;
            }
            Event::End(_) => p.end(start)?,
            Event::Text(t) => p.text(&t, start)?,
            Event::CData(t) => {
                if !t.trim_ascii().is_empty() {
                    return Err(p.unexpected_text(start));
                }
            }
            Event::GeneralRef(_) => return Err(p.unexpected_text(start)),
            Event::Eof => break,
            Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
        }
        buf.clear();
    }
    p.eof(reader.buffer_position())
}

impl Parser {
    fn parent_name(&self) -> &'static str {
        self.stack.last().map_or("document", |c| c.name())
    }

    fn xml_error(&self, e: XmlError, offset: u64) -> ModelReadError {
        match e {
            XmlError::Syntax(
                SyntaxError::InvalidBangMarkup
                | SyntaxError::UnclosedPI
                | SyntaxError::UnclosedXmlDecl
                | SyntaxError::UnclosedComment
                | SyntaxError::UnclosedDoctype
                | SyntaxError::UnclosedCData
                | SyntaxError::UnclosedTag
                | SyntaxError::UnclosedSingleQuotedAttributeValue
                | SyntaxError::UnclosedDoubleQuotedAttributeValue,
            ) => ModelReadError::Truncated { at: at(offset), open: self.parent_name().to_string() },
            XmlError::Io(io) => ModelReadError::Io { file: String::new(), message: io.to_string() },
            other => ModelReadError::Syntax { at: at(offset), message: other.to_string() },
        }
    }

    fn unexpected_text(&self, offset: u64) -> ModelReadError {
        ModelReadError::UnexpectedText { at: at(offset), parent: self.parent_name().to_string() }
    }

    fn eof(self, offset: u64) -> Result<Model, ModelReadError> {
        if let Some(top) = self.stack.last() {
            return Err(ModelReadError::Truncated { at: at(offset), open: top.name().to_string() });
        }
        if !self.root_seen {
            return Err(ModelReadError::MissingElement {
                at: at(offset),
                element: names::ROOT.to_string(),
                parent: "document".to_string(),
            });
        }
        Ok(self.model)
    }

    // ---- start tags -------------------------------------------------------------------

    fn start(&mut self, e: &BytesStart<'_>, start: u64) -> Result<Next, ModelReadError> {
        let qname = e.name();
        let name: &str = qname.as_ref();
        let top = self.stack.last().copied();
        let ctx = match (top, name) {
            (None, names::ROOT) => {
                if self.root_done {
                    return Err(ModelReadError::MisplacedElement {
                        at: at(start),
                        element: name.to_string(),
                        reason: "a document has one root element".to_string(),
                    });
                }
                self.root(e, start)?;
                Ctx::Root
            }
            (Some(Ctx::Root), _) if let Some(section) = SECTIONS.iter().find(|s| **s == name) => {
                self.section(e, start, section)?
            }
            (Some(Ctx::Provenance), names::ENTRY) => {
                self.entry(e, start)?;
                Ctx::Entry
            }
            (Some(Ctx::Layers), names::LAYER) => {
                self.layer(e, start)?;
                Ctx::Layer
            }
            (Some(Ctx::Materials), names::MATERIAL) => {
                self.material(e, start)?;
                Ctx::Material
            }
            (Some(Ctx::Nodes), names::NODE) => {
                self.node(e, start)?;
                Ctx::Node
            }
            (Some(Ctx::Springs), names::SPRING) => {
                self.spring(e, start)?;
                Ctx::Spring
            }
            (Some(Ctx::Spring), names::PPU) => {
                let informative = self.spring.as_ref().is_some_and(|s| s.law.is_some());
                self.ppu(e, start)?;
                self.stack.push(Ctx::Ppu);
                return Ok(if informative { Next::SkipInformative } else { Next::Continue });
            }
            (Some(Ctx::Ppu), names::PPU_FIRST) => self.ppu_spring(e, start, names::PPU_FIRST)?,
            (Some(Ctx::Ppu), names::PPU_SECOND) => self.ppu_spring(e, start, names::PPU_SECOND)?,
            (Some(Ctx::Surfaces), names::SURFACE) => {
                self.surface(e, start)?;
                Ctx::Surface
            }
            (Some(Ctx::Surface), names::TRIANGLES) => self.surface_list(e, start, names::TRIANGLES)?,
            (Some(Ctx::Surface), names::GRID) => self.surface_list(e, start, names::GRID)?,
            (Some(Ctx::Cells), names::CELL) => {
                self.cell(e, start)?;
                Ctx::Cell
            }
            _ => {
                return Err(ModelReadError::UnknownElement {
                    at: at(start),
                    element: name.to_string(),
                    parent: self.parent_name().to_string(),
                });
            }
        };
        self.stack.push(ctx);
        Ok(Next::Continue)
    }

    fn root(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::plain(names::ROOT);
        let [version, name, units] = gather(e, start, ["version", "name", "units"], item)?;
        let (v, off) = required(&version, "version", item, start)?;
        if v != MODEL_FORMAT_VERSION {
            return Err(unknown_value(off, item, "version", &v, "1"));
        }
        let (u, off) = required(&units, "units", item, start)?;
        if u != MODEL_UNITS {
            return Err(unknown_value(off, item, "units", &u, "SI (m, kg, s, N)"));
        }
        self.model.name = name.map(|(n, _)| n.into_owned()).unwrap_or_default();
        self.root_seen = true;
        Ok(())
    }

    fn section(&mut self, e: &BytesStart<'_>, start: u64, name: &'static str) -> Result<Ctx, ModelReadError> {
        let rank = SECTIONS.iter().position(|s| *s == name).map_or(0, |i| i + 1);
        if rank <= self.last_section {
            let reason = if rank == self.last_section {
                "this section appears twice".to_string()
            } else {
                format!("must come before <{}> (order: {})", SECTIONS[self.last_section - 1], SECTIONS.join(", "))
            };
            return Err(ModelReadError::MisplacedElement { at: at(start), element: name.to_string(), reason });
        }
        self.last_section = rank;
        let item = Item::plain(name);
        let ctx = match name {
            names::PROVENANCE => Ctx::Provenance,
            names::MATERIALS => Ctx::Materials,
            names::LAYERS => Ctx::Layers,
            names::NODES => Ctx::Nodes,
            names::SPRINGS => Ctx::Springs,
            names::CELLS => Ctx::Cells,
            _ => Ctx::Surfaces,
        };
        if matches!(ctx, Ctx::Provenance | Ctx::Materials) {
            gather(e, start, [], item)?;
            if ctx == Ctx::Materials {
                self.materials = vec![Material::default(); self.model.layers.len()];
                self.material_set = vec![false; self.model.layers.len()];
            }
            return Ok(ctx);
        }
        let [count] = gather(e, start, ["count"], item)?;
        let (c, off) = required(&count, "count", item, start)?;
        self.declared = integer(&c, off, item, "count")?;
        self.found = 0;
        let reserve = self.declared.min(self.size_hint / MIN_ELEMENT_BYTES) as usize;
        match ctx {
            Ctx::Layers => self.model.layers.reserve(reserve),
            Ctx::Nodes => {
                let n = &mut self.model.nodes;
                n.position.reserve(reserve);
                n.mass.reserve(reserve);
                n.kind.reserve(reserve);
                n.layer.reserve(reserve);
                n.texcoord.reserve(reserve);
            }
            Ctx::Springs => {
                let s = &mut self.model.springs;
                s.a.reserve(reserve);
                s.b.reserve(reserve);
                s.rest_length.reserve(reserve);
                s.law.reserve(reserve);
                s.damping.reserve(reserve);
                s.layer.reserve(reserve);
            }
            Ctx::Cells => self.model.cells.reserve(reserve),
            _ => self.model.surfaces.reserve(reserve),
        }
        Ok(ctx)
    }

    /// Checks an element's `index`: it must be the next one and below the section's count.
    fn own_index(&self, slot: &Slot<'_>, item: Item, start: u64, limit: u64) -> Result<(), ModelReadError> {
        let (v, off) = required(slot, "index", item, start)?;
        let index = integer(&v, off, item, "index")?;
        let count = self.declared.min(limit);
        if index >= count {
            return Err(ModelReadError::IndexOutOfRange {
                at: at(off),
                item: item.to_string(),
                attribute: "index",
                index,
                count,
            });
        }
        if index < self.found {
            return Err(ModelReadError::DuplicateIndex { at: at(off), item: item.kind.to_string(), index });
        }
        if index > self.found {
            return Err(ModelReadError::IndexOutOfOrder {
                at: at(off),
                item: item.kind.to_string(),
                expected: self.found,
                found: index,
            });
        }
        Ok(())
    }

    fn entry(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::new("provenance entry", self.model.provenance.len() as u64);
        let [key, value] = gather(e, start, ["key", "value"], item)?;
        let (k, _) = required(&key, "key", item, start)?;
        let (v, _) = required(&value, "value", item, start)?;
        self.model.provenance.push((k.into_owned(), v.into_owned()));
        Ok(())
    }

    fn layer(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::new(names::LAYER, self.found);
        let [index, name, tissue] = gather(e, start, ["index", "name", "tissue"], item)?;
        self.own_index(&index, item, start, u16::MAX as u64 + 1)?;
        let (name, _) = required(&name, "name", item, start)?;
        let (t, off) = required(&tissue, "tissue", item, start)?;
        let tissue = Tissue::from_name(&t).ok_or_else(|| unknown_value(off, item, "tissue", &t, names::TISSUES))?;
        self.model.layers.push(Layer { name: name.into_owned(), tissue });
        self.found += 1;
        Ok(())
    }

    fn material(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::plain(names::MATERIAL);
        const NAMES: [&str; 8] = ["layer", "law", "stiffness", "k1", "k2", "turn-strain", "k-compression", "damping"];
        let slots = gather(e, start, NAMES, item)?;
        let layer = self.layer_ref(&slots[0], item, start)?;
        let cols = LawAttrs { law: 1, stiffness: 2, k1: 3, k2: 4, turn: 5, kc: 6 };
        let law = law_params(&slots, &NAMES, &cols, item)?;
        let damping = optional_f64(&slots[7], item, "damping")?;
        let i = layer as usize;
        if self.material_set[i] {
            let off = slots[0].as_ref().map_or(start, |s| s.1);
            return Err(ModelReadError::DuplicateIndex { at: at(off), item: "material layer".into(), index: i as u64 });
        }
        self.material_set[i] = true;
        self.materials[i] = Material { law, damping };
        Ok(())
    }

    /// A `layer` attribute: required, below the number of layers.
    fn layer_ref(&self, slot: &Slot<'_>, item: Item, start: u64) -> Result<u16, ModelReadError> {
        let (v, off) = required(slot, "layer", item, start)?;
        let limit = self.model.layers.len().min(u16::MAX as usize + 1) as u64;
        Ok(index_below(&v, off, item, "layer", limit)? as u16)
    }

    fn node(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::new(names::NODE, self.found);
        const NAMES: [&str; 10] = ["index", "x", "y", "z", "mass", "kind", "layer", "u", "v", "w"];
        let s = gather(e, start, NAMES, item)?;
        self.own_index(&s[0], item, start, u32::MAX as u64 + 1)?;
        let mut position = [0.0; 3];
        for (k, p) in position.iter_mut().enumerate() {
            *p = required_f64(&s[1 + k], NAMES[1 + k], item, start)?;
        }
        let mass = required_f64(&s[4], "mass", item, start)?;
        let (k, off) = required(&s[5], "kind", item, start)?;
        let kind = NodeKind::from_name(&k).ok_or_else(|| unknown_value(off, item, "kind", &k, names::KINDS))?;
        let layer = self.layer_ref(&s[6], item, start)?;
        let mut texcoord = [0.0f32; 3];
        for (k, t) in texcoord.iter_mut().enumerate() {
            if let Some((v, off)) = &s[7 + k] {
                *t = float32(v, *off, item, NAMES[7 + k])?;
            }
        }
        let nodes = &mut self.model.nodes;
        nodes.position.push(position);
        nodes.mass.push(mass);
        nodes.kind.push(kind);
        nodes.layer.push(layer);
        nodes.texcoord.push(texcoord);
        self.found += 1;
        Ok(())
    }

    fn spring(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::new(names::SPRING, self.found);
        const NAMES: [&str; 12] = [
            "index",
            "a",
            "b",
            "rest-length",
            "layer",
            "damping",
            "law",
            "stiffness",
            "k1",
            "k2",
            "turn-length",
            "k-compression",
        ];
        let s = gather(e, start, NAMES, item)?;
        self.own_index(&s[0], item, start, u32::MAX as u64 + 1)?;
        let n = self.model.nodes.len() as u64;
        let (a, off) = required(&s[1], "a", item, start)?;
        let a = index_below(&a, off, item, "a", n)? as u32;
        let (b, off) = required(&s[2], "b", item, start)?;
        let b = index_below(&b, off, item, "b", n)? as u32;
        let rest = optional_f64(&s[3], item, "rest-length")?;
        let layer = self.layer_ref(&s[4], item, start)?;
        let damping = optional_f64(&s[5], item, "damping")?;
        let cols = LawAttrs { law: 6, stiffness: 7, k1: 8, k2: 9, turn: 10, kc: 11 };
        let law = law_params(&s, &NAMES, &cols, item)?;
        self.spring = Some(PendingSpring {
            ordinal: self.found,
            start,
            a,
            b,
            rest,
            layer,
            damping,
            law,
            ppu_at: None,
            ppu_turn: (0.0, 0.0),
            ppu_first: None,
            ppu_second: None,
        });
        Ok(())
    }

    fn ppu(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let Some(spring) = self.spring.as_mut() else { return Ok(()) };
        let item = Item { kind: names::SPRING, n: Some(spring.ordinal), sub: " ppu" };
        if spring.ppu_at.is_some() {
            return Err(ModelReadError::MisplacedElement {
                at: at(start),
                element: names::PPU.to_string(),
                reason: format!("{item} appears twice"),
            });
        }
        spring.ppu_at = Some(start);
        if spring.law.is_some() {
            // Informative export next to the spring's own law: not read (see `Next`).
            return Ok(());
        }
        let [turn_len, turn_force] = gather(e, start, ["TurnLen", "TurnForce"], item)?;
        spring.ppu_turn =
            (required_f64(&turn_len, "TurnLen", item, start)?, required_f64(&turn_force, "TurnForce", item, start)?);
        spring.ppu_at = Some(start);
        Ok(())
    }

    fn ppu_spring(&mut self, e: &BytesStart<'_>, start: u64, name: &'static str) -> Result<Ctx, ModelReadError> {
        let Some(spring) = self.spring.as_mut() else { return Ok(Ctx::PpuFirst) };
        let first = name == names::PPU_FIRST;
        let item = Item {
            kind: names::SPRING,
            n: Some(spring.ordinal),
            sub: if first { " ppu first" } else { " ppu second" },
        };
        let slot = if first { &mut spring.ppu_first } else { &mut spring.ppu_second };
        if slot.is_some() {
            return Err(ModelReadError::MisplacedElement {
                at: at(start),
                element: name.to_string(),
                reason: format!("{item} appears twice"),
            });
        }
        const NAMES: [&str; 5] = ["CompForce", "CompLen", "RestLen", "StretForce", "StretLen"];
        let s = gather(e, start, NAMES, item)?;
        let mut v = [0.0; 5];
        for k in 0..5 {
            v[k] = required_f64(&s[k], NAMES[k], item, start)?;
        }
        *slot = Some(PpuLinearSpring {
            comp_force: v[0],
            comp_len: v[1],
            rest_len: v[2],
            stret_force: v[3],
            stret_len: v[4],
        });
        Ok(if first { Ctx::PpuFirst } else { Ctx::PpuSecond })
    }

    fn surface(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::new(names::SURFACE, self.found);
        let [index, name] = gather(e, start, ["index", "name"], item)?;
        self.own_index(&index, item, start, u64::MAX)?;
        let (name, _) = required(&name, "name", item, start)?;
        self.surface = Some(PendingSurface {
            surface: Surface { name: name.into_owned(), triangles: Vec::new(), grid: None },
            has_triangles: false,
            declared: 0,
            tokens: Vec::new(),
        });
        Ok(())
    }

    fn surface_list(&mut self, e: &BytesStart<'_>, start: u64, name: &'static str) -> Result<Ctx, ModelReadError> {
        let ordinal = self.found;
        let Some(s) = self.surface.as_mut() else { return Ok(Ctx::Triangles) };
        let triangles = name == names::TRIANGLES;
        let item = Item { kind: names::SURFACE, n: Some(ordinal), sub: if triangles { " triangles" } else { " grid" } };
        let misplaced = |reason: &str| ModelReadError::MisplacedElement {
            at: at(start),
            element: name.to_string(),
            reason: format!("{item} {reason}"),
        };
        if triangles {
            if s.has_triangles {
                return Err(misplaced("appears twice"));
            }
            let [count] = gather(e, start, ["count"], item)?;
            let (c, off) = required(&count, "count", item, start)?;
            s.declared = integer(&c, off, item, "count")?;
            s.has_triangles = true;
            s.tokens.clear();
            s.tokens.reserve(s.declared.saturating_mul(3).min(self.size_hint / 2) as usize);
            Ok(Ctx::Triangles)
        } else {
            if !s.has_triangles {
                return Err(misplaced("must come after <triangles>"));
            }
            if s.surface.grid.is_some() {
                return Err(misplaced("appears twice"));
            }
            let [columns, rows] = gather(e, start, ["columns", "rows"], item)?;
            let (c, off) = required(&columns, "columns", item, start)?;
            let c = index_below(&c, off, item, "columns", u32::MAX as u64 + 1)? as u32;
            let (r, off) = required(&rows, "rows", item, start)?;
            let r = index_below(&r, off, item, "rows", u32::MAX as u64 + 1)? as u32;
            s.declared = c as u64 * r as u64;
            s.surface.grid = Some((c, r, Vec::new()));
            s.tokens.clear();
            s.tokens.reserve(s.declared.min(self.size_hint / 2) as usize);
            Ok(Ctx::Grid)
        }
    }

    fn cell(&mut self, e: &BytesStart<'_>, start: u64) -> Result<(), ModelReadError> {
        let item = Item::new(names::CELL, self.found);
        let [index, kind, layer, nodes] = gather(e, start, ["index", "kind", "layer", "nodes"], item)?;
        self.own_index(&index, item, start, u32::MAX as u64 + 1)?;
        let (k, off) = required(&kind, "kind", item, start)?;
        let kind = CellKind::from_name(&k).ok_or_else(|| unknown_value(off, item, "kind", &k, names::CELL_KINDS))?;
        let layer = self.layer_ref(&layer, item, start)?;
        let (list, off) = required(&nodes, "nodes", item, start)?;
        let n = self.model.nodes.len() as u64;
        let mut ids = [0u32; 8];
        let mut found = 0;
        for token in list.split_ascii_whitespace() {
            let v = index_below(token, off, item, "nodes", n)? as u32;
            if found < ids.len() {
                ids[found] = v;
            }
            found += 1;
        }
        let expected = kind.node_count();
        let cell = (found == expected).then(|| Cell::new(kind, layer, &ids[..expected])).flatten();
        let cell = cell.ok_or_else(|| ModelReadError::BadCellNodes {
            at: at(off),
            item: item.to_string(),
            kind: kind.name(),
            expected,
            found,
        })?;
        self.model.cells.push(cell);
        self.found += 1;
        Ok(())
    }

    // ---- text and end tags ------------------------------------------------------------

    fn text(&mut self, t: &str, start: u64) -> Result<(), ModelReadError> {
        let in_list = matches!(self.stack.last(), Some(Ctx::Triangles | Ctx::Grid));
        let bytes = t.as_bytes();
        let mut i = 0;
        while i < bytes.len() {
            while i < bytes.len() && bytes[i].is_ascii_whitespace() {
                i += 1;
            }
            if i == bytes.len() {
                break;
            }
            if !in_list {
                return Err(self.unexpected_text(start + i as u64));
            }
            let begin = i;
            while i < bytes.len() && !bytes[i].is_ascii_whitespace() {
                i += 1;
            }
            let ordinal = self.found;
            let n = self.model.nodes.len() as u64;
            if let Some(s) = self.surface.as_mut() {
                let item = Item {
                    kind: names::SURFACE,
                    n: Some(ordinal),
                    sub: if s.surface.grid.is_some() { " grid" } else { " triangles" },
                };
                let node = index_below(&t[begin..i], start + begin as u64, item, "", n)?;
                s.tokens.push(node as u32);
            }
        }
        Ok(())
    }

    fn end(&mut self, end: u64) -> Result<(), ModelReadError> {
        let Some(ctx) = self.stack.pop() else { return Ok(()) };
        match ctx {
            Ctx::Root => {
                for (k, section) in REQUIRED_SECTIONS.into_iter().enumerate() {
                    if !self.seen[k] {
                        return Err(ModelReadError::MissingElement {
                            at: at(end),
                            element: section.to_string(),
                            parent: names::ROOT.to_string(),
                        });
                    }
                }
                self.root_done = true;
            }
            Ctx::Layers | Ctx::Nodes | Ctx::Springs | Ctx::Surfaces | Ctx::Cells => {
                if self.found != self.declared {
                    return Err(ModelReadError::CountMismatch {
                        at: at(end),
                        section: ctx.name().to_string(),
                        declared: self.declared,
                        found: self.found,
                    });
                }
                self.mark_section(ctx.name());
            }
            Ctx::Spring => self.end_spring()?,
            Ctx::Ppu => {
                if let Some(s) = self.spring.as_ref().filter(|s| s.law.is_none()) {
                    for (present, name) in
                        [(s.ppu_first.is_some(), names::PPU_FIRST), (s.ppu_second.is_some(), names::PPU_SECOND)]
                    {
                        if !present {
                            return Err(ModelReadError::MissingElement {
                                at: at(end),
                                element: name.to_string(),
                                parent: names::PPU.to_string(),
                            });
                        }
                    }
                }
            }
            Ctx::Triangles | Ctx::Grid => {
                let ordinal = self.found;
                if let Some(s) = self.surface.as_mut() {
                    let triangles = ctx == Ctx::Triangles;
                    let expect = if triangles { s.declared.saturating_mul(3) } else { s.declared };
                    let found = s.tokens.len() as u64;
                    if found != expect {
                        return Err(ModelReadError::CountMismatch {
                            at: at(end),
                            section: format!("{} of surface {ordinal}", ctx.name()),
                            declared: s.declared,
                            found: if triangles { found / 3 } else { found },
                        });
                    }
                    if triangles {
                        s.surface.triangles = s.tokens.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
                    } else if let Some(grid) = s.surface.grid.as_mut() {
                        grid.2 = std::mem::take(&mut s.tokens);
                    }
                }
            }
            Ctx::Surface => {
                if let Some(s) = self.surface.take() {
                    if !s.has_triangles {
                        return Err(ModelReadError::MissingElement {
                            at: at(end),
                            element: names::TRIANGLES.to_string(),
                            parent: names::SURFACE.to_string(),
                        });
                    }
                    self.model.surfaces.push(s.surface);
                    self.found += 1;
                }
            }
            Ctx::Provenance | Ctx::Materials => self.mark_section(ctx.name()),
            Ctx::Entry | Ctx::Layer | Ctx::Material | Ctx::Node | Ctx::PpuFirst | Ctx::PpuSecond | Ctx::Cell => {}
        }
        Ok(())
    }

    fn end_spring(&mut self) -> Result<(), ModelReadError> {
        let Some(s) = self.spring.take() else { return Ok(()) };
        let item = Item::new(names::SPRING, s.ordinal);
        let material = self.materials.get(s.layer as usize).copied().unwrap_or_default();
        let missing = |attribute: &'static str| ModelReadError::MissingAttribute {
            at: at(s.start),
            item: item.to_string(),
            attribute,
        };
        let (law, rest) = match (s.law, s.ppu_at, s.ppu_first.zip(s.ppu_second)) {
            (Some(law), _, _) => (law_from_params(law, false, 0.0), s.rest.ok_or_else(|| missing("rest-length"))?),
            (None, Some(ppu_at), Some((first, second))) => {
                let pair = PpuBilinearPair { first, second, turn_len: s.ppu_turn.0, turn_force: s.ppu_turn.1 };
                let bad = |reason: String| ModelReadError::BadPpu { at: at(ppu_at), item: item.to_string(), reason };
                let (law, ppu_rest) = pair.to_bilinear().map_err(|e| bad(e.to_string()))?;
                if let Some(rest) = s.rest
                    && rest != ppu_rest
                {
                    return Err(bad(format!("RestLen {ppu_rest} differs from the spring's rest-length {rest}")));
                }
                (SpringLaw::Bilinear(law), ppu_rest)
            }
            _ => {
                let rest = s.rest.ok_or_else(|| missing("rest-length"))?;
                let law = material.law.ok_or_else(|| missing("law"))?;
                (law_from_params(law, true, rest), rest)
            }
        };
        let damping = s.damping.or(material.damping).ok_or_else(|| missing("damping"))?;
        let springs = &mut self.model.springs;
        springs.a.push(s.a);
        springs.b.push(s.b);
        springs.rest_length.push(rest);
        springs.law.push(law);
        springs.damping.push(damping);
        springs.layer.push(s.layer);
        self.found += 1;
        Ok(())
    }

    fn mark_section(&mut self, name: &str) {
        if let Some(k) = REQUIRED_SECTIONS.iter().position(|s| *s == name) {
            self.seen[k] = true;
        }
    }
}

/// Turns law parameters into a law; a material's turning point is a strain of `rest`.
fn law_from_params(p: LawParams, turn_is_strain: bool, rest: f64) -> SpringLaw {
    match p {
        LawParams::Linear(stiffness) => SpringLaw::Linear { stiffness },
        LawParams::Bilinear { k1, k2, turn, kc } => SpringLaw::Bilinear(Bilinear {
            k1,
            k2,
            turn_length: if turn_is_strain { rest * (1.0 + turn) } else { turn },
            k_compression: kc,
        }),
    }
}

/// Reads `law` and its parameters; parameters of the other family are rejected, and
/// parameters without `law` are an error.
fn law_params<const N: usize>(
    s: &[Slot<'_>; N],
    names_: &[&'static str; N],
    c: &LawAttrs,
    item: Item,
) -> Result<Option<LawParams>, ModelReadError> {
    let reject = |cols: &[usize]| -> Result<(), ModelReadError> {
        for &k in cols {
            if let Some((_, off)) = &s[k] {
                return Err(ModelReadError::UnknownAttribute {
                    at: at(*off),
                    item: item.to_string(),
                    attribute: names_[k].to_string(),
                });
            }
        }
        Ok(())
    };
    let Some((law, off)) = &s[c.law] else {
        // Parameters without a law: say the law is missing, at the first parameter.
        if let Some((_, poff)) = [c.stiffness, c.k1, c.k2, c.turn, c.kc].iter().find_map(|&k| s[k].as_ref()) {
            return Err(ModelReadError::MissingAttribute { at: at(*poff), item: item.to_string(), attribute: "law" });
        }
        return Ok(None);
    };
    // `start` for a missing parameter: point at the `law` attribute.
    let need = |k: usize| -> Result<f64, ModelReadError> {
        match &s[k] {
            Some((v, o)) => float64(v, *o, item, names_[k]),
            None => {
                Err(ModelReadError::MissingAttribute { at: at(*off), item: item.to_string(), attribute: names_[k] })
            }
        }
    };
    match law.as_ref() {
        names::LAW_LINEAR => {
            reject(&[c.k1, c.k2, c.turn, c.kc])?;
            Ok(Some(LawParams::Linear(need(c.stiffness)?)))
        }
        names::LAW_BILINEAR => {
            reject(&[c.stiffness])?;
            Ok(Some(LawParams::Bilinear { k1: need(c.k1)?, k2: need(c.k2)?, turn: need(c.turn)?, kc: need(c.kc)? }))
        }
        other => Err(unknown_value(*off, item, "law", other, names::LAWS)),
    }
}
