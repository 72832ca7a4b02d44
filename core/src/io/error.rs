//! What can go wrong reading or writing model files, and where in the file it went wrong.

use crate::model::ModelValidateError;
use std::fmt;

/// A place in a model file: the file, a 1-based line and column, and the byte offset.
///
/// The column counts Unicode characters from the start of the line (1 = first character).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SourceLocation {
    /// The file as it was named to the reader, or `<string>` for in-memory input.
    pub file: String,
    /// Line, 1-based.
    pub line: u32,
    /// Column in characters, 1-based.
    pub column: u32,
    /// Byte offset from the start of the file, 0-based.
    pub byte_offset: u64,
}

impl fmt::Display for SourceLocation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

/// Why a model file could not be read. Every variant but [`ModelReadError::Io`] says where
/// in the file the problem is; `item` names the thing being read, e.g. `node 17`,
/// `spring 3`, `layer 0`, `surface 1`.
///
/// The messages (`Display`) are listed in `docs/model-format.md`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelReadError {
    /// The file could not be opened or read.
    #[error("{file}: cannot read: {message}")]
    Io {
        /// File name.
        file: String,
        /// The operating system's message.
        message: String,
    },
    /// The file was not read: it is not a regular file (a FIFO, `/dev/zero`), is larger
    /// than [`MODEL_FILE`](super::MODEL_FILE)'s cap, or needs more memory than is available.
    #[error("{0}")]
    Refused(lamina_input::FileReadError),
    /// The text is not well-formed XML (or not UTF-8).
    #[error("{at}: not well-formed XML: {message}")]
    Syntax {
        /// Where.
        at: SourceLocation,
        /// The XML parser's message.
        message: String,
    },
    /// The document ends before every element is closed.
    #[error("{at}: the document ends inside '{open}' (truncated file?)")]
    Truncated {
        /// Where the input ends.
        at: SourceLocation,
        /// The innermost element still open, or what was being parsed.
        open: String,
    },
    /// An element this format does not know, or that may not appear inside its parent.
    #[error("{at}: unknown element <{element}> inside <{parent}>")]
    UnknownElement {
        /// Where the element starts.
        at: SourceLocation,
        /// Its name.
        element: String,
        /// The enclosing element (`document` at top level).
        parent: String,
    },
    /// A known element in the wrong place: a section out of order or repeated, or a
    /// second root element.
    #[error("{at}: element <{element}>: {reason}")]
    MisplacedElement {
        /// Where the element starts.
        at: SourceLocation,
        /// Its name.
        element: String,
        /// What rule it breaks.
        reason: String,
    },
    /// A required element is absent.
    #[error("{at}: {}", missing_element(.element, .parent))]
    MissingElement {
        /// Where its parent ends.
        at: SourceLocation,
        /// The missing element.
        element: String,
        /// The element it should have been in.
        parent: String,
    },
    /// Non-blank text where only elements may appear.
    #[error("{at}: unexpected text inside <{parent}>")]
    UnexpectedText {
        /// Where the text starts.
        at: SourceLocation,
        /// The enclosing element.
        parent: String,
    },
    /// An attribute the element does not have.
    #[error("{at}: {item}: unknown attribute '{attribute}'")]
    UnknownAttribute {
        /// Where the attribute starts.
        at: SourceLocation,
        /// The element, e.g. `node 17`.
        item: String,
        /// The attribute's name.
        attribute: String,
    },
    /// A required attribute is absent.
    #[error("{at}: {item}: missing attribute '{attribute}'")]
    MissingAttribute {
        /// Where the element starts.
        at: SourceLocation,
        /// The element, e.g. `node 17`.
        item: String,
        /// The attribute's name.
        attribute: &'static str,
    },
    /// An attribute or text value that should be a number is not one.
    #[error("{at}: {item}: {}", bad_number(.attribute, .value))]
    BadNumber {
        /// Where the value's attribute (or text token) starts.
        at: SourceLocation,
        /// The element, e.g. `node 17`.
        item: String,
        /// The attribute's name; empty for a number in element text (triangles, grid).
        attribute: &'static str,
        /// The value as written.
        value: String,
    },
    /// A number is NaN or infinite.
    #[error("{at}: {item}: attribute '{attribute}' = '{value}' is not finite")]
    NonFinite {
        /// Where the attribute starts.
        at: SourceLocation,
        /// The element, e.g. `node 17`.
        item: String,
        /// The attribute's name.
        attribute: &'static str,
        /// The value as written.
        value: String,
    },
    /// A keyword attribute (law, kind, tissue, units, version, role) has a value the
    /// format does not know.
    #[error("{at}: {item}: attribute '{attribute}' = '{value}' is not one of: {allowed}")]
    UnknownValue {
        /// Where the attribute starts.
        at: SourceLocation,
        /// The element, e.g. `node 17`.
        item: String,
        /// The attribute's name.
        attribute: &'static str,
        /// The value as written.
        value: String,
        /// The values allowed, for the message.
        allowed: &'static str,
    },
    /// An index (own index, node, layer) is not below the number of things it indexes.
    #[error("{at}: {item}: {}", index_out_of_range(.attribute, *.index, *.count))]
    IndexOutOfRange {
        /// Where the attribute starts.
        at: SourceLocation,
        /// The element, e.g. `spring 3`.
        item: String,
        /// The attribute's name; empty for a node index in element text (triangles, grid).
        attribute: &'static str,
        /// The index written.
        index: u64,
        /// How many there are (the index must be below this).
        count: u64,
    },
    /// An element's `index` names an element that came before it.
    #[error("{at}: {item} index {index} appears twice")]
    DuplicateIndex {
        /// Where the `index` attribute starts.
        at: SourceLocation,
        /// The element's kind, e.g. `node`.
        item: String,
        /// The repeated index.
        index: u64,
    },
    /// Elements are not listed in index order (an index is skipped).
    #[error("{at}: {item} index {found} out of order: index {expected} must come next")]
    IndexOutOfOrder {
        /// Where the `index` attribute starts.
        at: SourceLocation,
        /// The element's kind, e.g. `node`.
        item: String,
        /// The index that had to come next.
        expected: u64,
        /// The index written.
        found: u64,
    },
    /// A section's `count` differs from the number of elements in it.
    #[error("{at}: <{section}> declares count=\"{declared}\" but holds {found} elements")]
    CountMismatch {
        /// Where the section ends.
        at: SourceLocation,
        /// The section, e.g. `nodes`.
        section: String,
        /// The `count` attribute.
        declared: u64,
        /// Elements found.
        found: u64,
    },
    /// A spring given only as a PPU pair does not describe a bilinear law.
    #[error("{at}: {item}: PPU pair is not a bilinear law: {reason}")]
    BadPpu {
        /// Where the `ppu` element starts.
        at: SourceLocation,
        /// The spring, e.g. `spring 3`.
        item: String,
        /// Why.
        reason: String,
    },
    /// A cell's `nodes` attribute lists a number of nodes its kind does not have.
    #[error("{at}: {item}: a {kind} cell has {expected} nodes, attribute 'nodes' lists {found}")]
    BadCellNodes {
        /// Where the `nodes` attribute is.
        at: SourceLocation,
        /// The cell, e.g. `cell 3`.
        item: String,
        /// The cell's kind, e.g. `tetra`.
        kind: &'static str,
        /// Nodes a cell of that kind has.
        expected: usize,
        /// Nodes listed.
        found: usize,
    },
    /// Everything parsed, but [`crate::model::Model::validate`] rejects the model (zero
    /// mass, a spring from a node to itself, negative stiffness, turning length below the
    /// rest length, ...). `at` is the offending element when one is named.
    #[error("{at}: invalid model: {reason}")]
    Invalid {
        /// Where the offending element starts (the root element when none is named).
        at: SourceLocation,
        /// The validation failure.
        reason: ModelValidateError,
    },
}

impl ModelReadError {
    /// The location of the error, or `None` for [`ModelReadError::Io`].
    pub fn location(&self) -> Option<&SourceLocation> {
        match self {
            Self::Io { .. } | Self::Refused(_) => None,
            Self::Syntax { at, .. }
            | Self::Truncated { at, .. }
            | Self::UnknownElement { at, .. }
            | Self::MisplacedElement { at, .. }
            | Self::MissingElement { at, .. }
            | Self::UnexpectedText { at, .. }
            | Self::UnknownAttribute { at, .. }
            | Self::MissingAttribute { at, .. }
            | Self::BadNumber { at, .. }
            | Self::NonFinite { at, .. }
            | Self::UnknownValue { at, .. }
            | Self::IndexOutOfRange { at, .. }
            | Self::DuplicateIndex { at, .. }
            | Self::IndexOutOfOrder { at, .. }
            | Self::CountMismatch { at, .. }
            | Self::BadPpu { at, .. }
            | Self::BadCellNodes { at, .. }
            | Self::Invalid { at, .. } => Some(at),
        }
    }

    /// Mutable location, for the reader to fill in file, line and column once known.
    pub(crate) fn location_mut(&mut self) -> Option<&mut SourceLocation> {
        match self {
            Self::Io { .. } | Self::Refused(_) => None,
            Self::Syntax { at, .. }
            | Self::Truncated { at, .. }
            | Self::UnknownElement { at, .. }
            | Self::MisplacedElement { at, .. }
            | Self::MissingElement { at, .. }
            | Self::UnexpectedText { at, .. }
            | Self::UnknownAttribute { at, .. }
            | Self::MissingAttribute { at, .. }
            | Self::BadNumber { at, .. }
            | Self::NonFinite { at, .. }
            | Self::UnknownValue { at, .. }
            | Self::IndexOutOfRange { at, .. }
            | Self::DuplicateIndex { at, .. }
            | Self::IndexOutOfOrder { at, .. }
            | Self::CountMismatch { at, .. }
            | Self::BadPpu { at, .. }
            | Self::BadCellNodes { at, .. }
            | Self::Invalid { at, .. } => Some(at),
        }
    }

    /// The 1-based line of the error, or `None` for [`ModelReadError::Io`].
    pub fn line(&self) -> Option<u32> {
        self.location().map(|l| l.line)
    }
}

/// Why a model could not be written.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelWriteError {
    /// The file could not be created or written.
    #[error("{file}: cannot write: {message}")]
    Io {
        /// File name.
        file: String,
        /// The operating system's message.
        message: String,
    },
    /// The model fails [`crate::model::Model::validate`]; the file would not read back.
    #[error("refusing to write an invalid model: {reason}")]
    Invalid {
        /// The validation failure.
        reason: ModelValidateError,
    },
    /// A node's texture coordinate is NaN or infinite.
    #[error("node {node}: texture coordinate is not finite")]
    NonFiniteTexcoord {
        /// Node index.
        node: u32,
    },
    /// A name or provenance string holds a NUL character, which XML cannot carry.
    #[error("{what} contains a NUL character, which XML cannot hold")]
    UnrepresentableText {
        /// Which string, e.g. `provenance key 2`.
        what: String,
    },
}

/// Why a VTK file (or a series of them) could not be written.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum VtuWriteError {
    /// A file could not be created or written.
    #[error("{file}: cannot write: {message}")]
    Io {
        /// File name.
        file: String,
        /// The operating system's message.
        message: String,
    },
    /// The positions given are not one per model node.
    #[error("{found} positions given for a model of {expected} nodes")]
    PositionCount {
        /// Nodes in the model.
        expected: usize,
        /// Positions given.
        found: usize,
    },
    /// A frame's time is NaN, infinite, or earlier than the previous frame's.
    #[error("frame {frame}: time is not finite or goes backwards")]
    BadTime {
        /// Frame number, 0-based.
        frame: usize,
    },
}

/// [`ModelReadError::MissingElement`]'s message after the location.
fn missing_element(element: &str, parent: &str) -> String {
    if parent == "document" {
        format!("the document has no <{element}> element")
    } else {
        format!("<{parent}> lacks the required element <{element}>")
    }
}

/// [`ModelReadError::BadNumber`]'s message after the item (`attribute` empty: element text).
fn bad_number(attribute: &str, value: &str) -> String {
    if attribute.is_empty() {
        format!("'{value}' is not a number")
    } else {
        format!("attribute '{attribute}' = '{value}' is not a number")
    }
}

/// [`ModelReadError::IndexOutOfRange`]'s message after the item (`attribute` empty: element
/// text).
fn index_out_of_range(attribute: &str, index: u64, count: u64) -> String {
    if attribute.is_empty() {
        format!("node index {index} is out of range (must be below {count})")
    } else {
        format!("attribute '{attribute}' = {index} is out of range (must be below {count})")
    }
}
