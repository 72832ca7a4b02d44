//! Attribute access for the XML model reader: collecting an element's attributes with
//! their byte offsets, and parsing numbers, indices and keywords into located errors.

use super::error::{ModelReadError, SourceLocation};
use quick_xml::XmlVersion;
use quick_xml::events::BytesStart;
use std::borrow::Cow;
use std::fmt;

/// A location known only by its byte offset (file, line, column are filled in later).
pub(super) fn at(byte_offset: u64) -> SourceLocation {
    SourceLocation { byte_offset, ..SourceLocation::default() }
}

/// What an error message calls the element being read, e.g. `node 17` or `spring 3 ppu`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Item {
    pub(super) kind: &'static str,
    pub(super) n: Option<u64>,
    pub(super) sub: &'static str,
}

impl Item {
    pub(super) fn new(kind: &'static str, n: u64) -> Self {
        Self { kind, n: Some(n), sub: "" }
    }

    pub(super) fn plain(kind: &'static str) -> Self {
        Self { kind, n: None, sub: "" }
    }
}

impl fmt::Display for Item {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.kind)?;
        if let Some(n) = self.n {
            write!(f, " {n}")?;
        }
        f.write_str(self.sub)
    }
}

/// One attribute value with the byte offset of its name.
pub(super) type Slot<'b> = Option<(Cow<'b, str>, u64)>;

/// Collects the attributes named in `wanted` (anything else is an error), each with the
/// byte offset of its name.
pub(super) fn gather<'b, const N: usize>(
    e: &'b BytesStart<'_>,
    start: u64,
    wanted: [&'static str; N],
    item: Item,
) -> Result<[Slot<'b>; N], ModelReadError> {
    let mut slots: [Slot<'b>; N] = std::array::from_fn(|_| None);
    let content: &str = e;
    let base = content.as_ptr() as usize;
    // quick-xml's duplicate check hashes every key; a filled slot says the same for less.
    for attr in e.attributes().with_checks(false) {
        let attr = attr.map_err(|err| ModelReadError::Syntax { at: at(start), message: err.to_string() })?;
        let key: &str = attr.key.as_ref();
        // The tag's text starts after `<`; the key borrows from it.
        let rel = (key.as_ptr() as usize).checked_sub(base).filter(|&d| d <= content.len()).unwrap_or(0);
        let off = start + 1 + rel as u64;
        let Some(k) = wanted.iter().position(|w| *w == key) else {
            return Err(ModelReadError::UnknownAttribute {
                at: at(off),
                item: item.to_string(),
                attribute: key.to_string(),
            });
        };
        if slots[k].is_some() {
            return Err(ModelReadError::Syntax { at: at(off), message: format!("attribute '{key}' appears twice") });
        }
        let value = attr
            .normalized_value(XmlVersion::Implicit1_0)
            .map_err(|err| ModelReadError::Syntax { at: at(off), message: err.to_string() })?;
        slots[k] = Some((value, off));
    }
    Ok(slots)
}

pub(super) fn required<'s, 'b>(
    slot: &'s Slot<'b>,
    name: &'static str,
    item: Item,
    start: u64,
) -> Result<(Cow<'s, str>, u64), ModelReadError> {
    match slot {
        Some((v, off)) => Ok((Cow::Borrowed(v.as_ref()), *off)),
        None => Err(ModelReadError::MissingAttribute { at: at(start), item: item.to_string(), attribute: name }),
    }
}

pub(super) fn required_f64(slot: &Slot<'_>, name: &'static str, item: Item, start: u64) -> Result<f64, ModelReadError> {
    let (v, off) = required(slot, name, item, start)?;
    float64(&v, off, item, name)
}

pub(super) fn optional_f64(slot: &Slot<'_>, item: Item, name: &'static str) -> Result<Option<f64>, ModelReadError> {
    slot.as_ref().map(|(v, off)| float64(v, *off, item, name)).transpose()
}

pub(super) fn unknown_value(
    off: u64,
    item: Item,
    attribute: &'static str,
    value: &str,
    allowed: &'static str,
) -> ModelReadError {
    ModelReadError::UnknownValue { at: at(off), item: item.to_string(), attribute, value: value.to_string(), allowed }
}

pub(super) fn bad_number(off: u64, item: Item, attribute: &'static str, value: &str) -> ModelReadError {
    ModelReadError::BadNumber { at: at(off), item: item.to_string(), attribute, value: value.to_string() }
}

pub(super) fn float64(v: &str, off: u64, item: Item, attribute: &'static str) -> Result<f64, ModelReadError> {
    let x: f64 = v.trim_ascii().parse().map_err(|_| bad_number(off, item, attribute, v))?;
    if !x.is_finite() {
        return Err(ModelReadError::NonFinite { at: at(off), item: item.to_string(), attribute, value: v.to_string() });
    }
    Ok(x)
}

pub(super) fn float32(v: &str, off: u64, item: Item, attribute: &'static str) -> Result<f32, ModelReadError> {
    let x: f32 = v.trim_ascii().parse().map_err(|_| bad_number(off, item, attribute, v))?;
    if !x.is_finite() {
        return Err(ModelReadError::NonFinite { at: at(off), item: item.to_string(), attribute, value: v.to_string() });
    }
    Ok(x)
}

pub(super) fn integer(v: &str, off: u64, item: Item, attribute: &'static str) -> Result<u64, ModelReadError> {
    v.trim_ascii().parse().map_err(|_| bad_number(off, item, attribute, v))
}

pub(super) fn index_below(
    v: &str,
    off: u64,
    item: Item,
    attribute: &'static str,
    count: u64,
) -> Result<u64, ModelReadError> {
    let index = integer(v, off, item, attribute)?;
    if index >= count {
        return Err(ModelReadError::IndexOutOfRange { at: at(off), item: item.to_string(), attribute, index, count });
    }
    Ok(index)
}
