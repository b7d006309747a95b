//! Reading and parsing JSON documents (scenes, pipelines, a scene's `model` section): the
//! size and encoding checks of a file, and parse errors that carry the JSON path, line and
//! column.

use crate::ProblemError;
use std::path::Path;

/// Parses scene text into the serde mirror; syntax and shape errors carry line, column and path.
/// Largest scene or pipeline file read: 16 MiB. A scene is a few hundred bytes of keys (node
/// data lives in the files it names), so anything larger is a wrong file, and the limit keeps
/// `linpd validate /dev/urandom` from reading forever.
pub const MAX_JSON_BYTES: u64 = 16 << 20;

/// Reads a scene or pipeline file: a regular file (not a device, FIFO or directory) of at most
/// [`MAX_JSON_BYTES`], in UTF-8 (a leading byte order mark is skipped).
pub fn read_json_file(path: &Path) -> Result<String, ProblemError> {
    use std::io::Read;
    let err = |source| ProblemError::Io { path: path.display().to_string(), source };
    let other = |m: String| err(std::io::Error::new(std::io::ErrorKind::InvalidInput, m));
    let meta = std::fs::metadata(path).map_err(err)?;
    if !meta.is_file() {
        return Err(other("not a regular file (a scene or pipeline is a JSON file)".into()));
    }
    if meta.len() > MAX_JSON_BYTES {
        return Err(other(format!(
            "{} bytes, more than a scene or pipeline file may hold ({MAX_JSON_BYTES})",
            meta.len()
        )));
    }
    // `take`: a file that grows while it is read still stops at the limit
    let mut bytes = Vec::new();
    std::fs::File::open(path).and_then(|f| f.take(MAX_JSON_BYTES + 1).read_to_end(&mut bytes)).map_err(err)?;
    if bytes.len() as u64 > MAX_JSON_BYTES {
        return Err(other(format!("more than {MAX_JSON_BYTES} bytes, more than a scene or pipeline file may hold")));
    }
    // a UTF-8 byte order mark (written by some Windows editors) is not part of the document
    let body = bytes.strip_prefix(UTF8_BOM).map_or(0, |_| UTF8_BOM.len());
    let text = String::from_utf8(bytes).map_err(|e| {
        other(format!(
            "not UTF-8 text (invalid byte at offset {}): a scene or pipeline is a JSON file",
            e.utf8_error().valid_up_to()
        ))
    })?;
    Ok(text[body..].to_string())
}

/// The UTF-8 byte order mark, skipped at the start of a scene or pipeline file.
const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// Parses one JSON document (scene or pipeline) into `T`; syntax and shape errors carry line,
/// column and path, and text after the document is an error (not silently ignored).
pub fn parse_json<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, ProblemError> {
    parse_json_at(text, "", (1, 1))
}

/// [`parse_json`] of a section of a document: `text` starts at line and column `at` of the
/// document, under the JSON path `prefix` (`model`), and errors say so.
pub(crate) fn parse_json_at<T: serde::de::DeserializeOwned>(
    text: &str,
    prefix: &str,
    at: (usize, usize),
) -> Result<T, ProblemError> {
    // a position in `text` as a position in the document
    let place = |line: usize, column: usize| (at.0 + line - 1, if line == 1 { at.1 + column - 1 } else { column });
    let under = |path: String| match (prefix, path.as_str()) {
        ("", _) => path,
        (p, ".") => p.to_string(),
        (p, _) => format!("{p}.{path}"),
    };
    let de = &mut serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut *de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let (line, column) = place(inner.line(), inner.column());
        ProblemError::Parse {
            path: under(known_path(&path)),
            message: strip_position(&inner.to_string()),
            line,
            column,
        }
    })?;
    de.end().map_err(|e| {
        let (line, column) = place(e.line(), e.column());
        ProblemError::Parse {
            path: under(".".into()),
            message: "trailing text after the JSON document".into(),
            line,
            column,
        }
    })?;
    Ok(value)
}

/// A JSON object with the top-level keys of a pipeline file (`scene` and `levels`) and none of
/// a scene's (`model`).
pub(crate) fn is_pipeline(text: &str) -> bool {
    match serde_json::from_str::<serde_json::Value>(text) {
        Ok(serde_json::Value::Object(m)) => {
            m.contains_key("scene") && m.contains_key("levels") && !m.contains_key("model")
        }
        _ => false,
    }
}

/// serde_path_to_error writes `?` for a key it has not read yet (a syntax error between two
/// keys); keep the known part of the path (`.` for the document).
fn known_path(path: &str) -> String {
    let p = path.strip_suffix('?').unwrap_or(path).trim_end_matches('.');
    if p.is_empty() {
        ".".into()
    } else {
        p.into()
    }
}

/// serde_json appends " at line L column C" to messages; we print position separately.
fn strip_position(msg: &str) -> String {
    match msg.rfind(" at line ") {
        Some(i) => msg[..i].to_string(),
        None => msg.to_string(),
    }
}
