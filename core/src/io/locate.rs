//! Turning byte offsets into file, line and column, after the fact.
//!
//! The reader tracks only byte offsets (cheap); when it fails, the input is scanned once
//! more up to the offset to count lines. For [`crate::model::Model::validate`] failures,
//! which name an element by its ordinal, the input is scanned for that element.

use super::error::ModelReadError;
use quick_xml::events::Event;
use quick_xml::reader::Reader;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Where model text comes from, so it can be read a second time.
pub(crate) enum Source<'a> {
    /// In-memory text.
    Text(&'a str),
    /// A file.
    File(&'a Path),
}

impl Source<'_> {
    fn name(&self) -> String {
        match self {
            Source::Text(_) => "<string>".to_string(),
            Source::File(p) => p.display().to_string(),
        }
    }

    fn open(&self) -> Option<Box<dyn BufRead + '_>> {
        match self {
            Source::Text(t) => Some(Box::new(t.as_bytes())),
            Source::File(p) => lamina_input::open_regular(p, &super::MODEL_FILE)
                .ok()
                .map(|(f, _)| Box::new(BufReader::new(f)) as Box<dyn BufRead>),
        }
    }
}

/// Fills in the file name, line and column of `err` from its byte offset.
pub(crate) fn fill_location(source: &Source<'_>, err: &mut ModelReadError) {
    if let ModelReadError::Io { file, .. } = err {
        *file = source.name();
        return;
    }
    let Some(loc) = err.location_mut() else { return };
    loc.file = source.name();
    let (line, column) = match source.open() {
        Some(input) => line_column(input, loc.byte_offset),
        None => (0, 0),
    };
    loc.line = line;
    loc.column = column;
}

/// 1-based line and column (in characters) of byte `offset` of `input`.
fn line_column(mut input: impl Read, offset: u64) -> (u32, u32) {
    let (mut line, mut column) = (1u32, 1u32);
    let mut left = offset;
    let mut chunk = vec![0u8; 1 << 16];
    while left > 0 {
        let want = chunk.len().min(left as usize);
        let n = match input.read(&mut chunk[..want]) {
            Ok(0) | Err(_) => break,
            Ok(n) => n,
        };
        for &b in &chunk[..n] {
            if b == b'\n' {
                line = line.saturating_add(1);
                column = 1;
            } else if b & 0xC0 != 0x80 {
                // Count UTF-8 lead bytes only: one per character.
                column = column.saturating_add(1);
            }
        }
        left -= n as u64;
    }
    (line, column)
}

/// Byte offset of the `ordinal`-th (0-based) element named `name` in document order.
pub(crate) fn element_offset(source: &Source<'_>, name: &str, ordinal: u64) -> Option<u64> {
    let mut reader = Reader::from_reader(source.open()?);
    let mut buf = Vec::new();
    let mut seen = 0u64;
    loop {
        let start = reader.buffer_position();
        match reader.read_event_into(&mut buf).ok()? {
            Event::Start(e) | Event::Empty(e) if e.name().as_ref() == name => {
                if seen == ordinal {
                    return Some(start);
                }
                seen += 1;
            }
            Event::Eof => return None,
            _ => {}
        }
        buf.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_column_counts_characters_works() {
        let text = "ab\ncé d\n";
        assert_eq!(line_column(text.as_bytes(), 0), (1, 1));
        assert_eq!(line_column(text.as_bytes(), 3), (2, 1));
        // 'c' (1 byte) + 'é' (2 bytes) + ' ' = 4 bytes into line 2: column 4.
        assert_eq!(line_column(text.as_bytes(), 7), (2, 4));
    }
}
