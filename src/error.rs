//! The error every layer uses for bad input: which field (of a scene file, or of an API
//! call's parameters), and why. Lives below the physics core so that the core can name the
//! field without importing the scene layer.

use thiserror::Error;

/// A rejected scene: which field, and why.
#[derive(Debug, Error, PartialEq)]
#[error("scene field `{field}`: {reason}")]
pub struct SceneError {
    pub field: String,
    pub reason: String,
}

impl SceneError {
    /// A TOML parse error of a scene whose table is `section`. A bad value (an unknown variant,
    /// a wrong type, an unknown key) is named by its key, found where the error points in
    /// `text`: `table.key`; otherwise (the error points at a table header) the key the message
    /// names (in backticks) becomes the field, `section: key`.
    pub fn from_toml(section: &str, e: &toml::de::Error, text: &str) -> Self {
        let msg = e.message().to_string();
        let located = e.span().and_then(|span| value_key(text, span.start));
        let named = msg.split('`').nth(1);
        let field = match (located, named) {
            // the error points at the table that lacks the key
            (Some((table, true)), Some(key)) if msg.starts_with("missing field") => format!("{table}.{key}"),
            (Some((key, _)), _) => key,
            (None, Some(key)) => format!("{section}: {key}"),
            (None, None) => section.into(),
        };
        SceneError { field, reason: msg }
    }
}

/// The dotted key (`table.key`) of the `key = value` line holding byte `at` of a TOML text, or
/// the table of a `[table]` header line (then `true`).
fn value_key(text: &str, at: usize) -> Option<(String, bool)> {
    let before = text.get(..at)?;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next()?.trim();
    if let Some(header) = line.strip_prefix('[') {
        let name = header.trim_start_matches('[').split(']').next()?.trim();
        return (!name.is_empty()).then(|| (name.to_string(), true));
    }
    let key = line.split_once('=')?.0.trim();
    if key.is_empty() {
        return None;
    }
    let table = before[..line_start].lines().rev().find_map(|l| l.trim().strip_prefix('[')?.strip_suffix(']').map(str::to_string));
    Some((table.map_or_else(|| key.to_string(), |t| format!("{t}.{key}")), false))
}
