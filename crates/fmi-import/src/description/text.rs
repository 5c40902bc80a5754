//! The text helpers of the description reader: positions in the text, attribute lookup,
//! XML Schema value checks, and untrusted text clipped for messages.

/// 1-based line and column (in characters) of byte offset `pos` in `text`.
pub(crate) fn line_column(text: &str, pos: usize) -> (usize, usize) {
    let mut pos = pos.min(text.len());
    while !text.is_char_boundary(pos) {
        pos -= 1;
    }
    let before = &text[..pos];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[line_start..].chars().count() + 1)
}

/// A name usable as one file name in one folder: not empty, no separator, not `.`/`..`.
pub(crate) fn plain_file_name(s: &str) -> bool {
    !s.is_empty() && s != "." && s != ".." && !s.contains(['/', '\\', '\0', ':'])
}

/// `s` cut to its first `n` characters, marked if cut, for echoing untrusted text.
pub(crate) fn cut(s: &str, n: usize) -> String {
    match s.char_indices().nth(n) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

/// The attributes of one element, in document order, values unescaped.
pub(crate) type Attrs = Vec<(String, String)>;

pub(crate) fn attr<'s>(attrs: &'s Attrs, key: &str) -> Option<&'s str> {
    attrs.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

/// Whether `s` is a valid XML Schema boolean.
pub(crate) fn is_boolean(s: &str) -> bool {
    matches!(s, "true" | "false" | "1" | "0")
}

/// Whether `s` is a valid XML Schema double (including `INF`, `-INF`, `NaN`).
pub(crate) fn is_double(s: &str) -> bool {
    s.parse::<f64>().is_ok() || matches!(s, "INF" | "-INF" | "+INF" | "NaN")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_and_column() {
        assert_eq!(line_column("ab\ncd", 4), (2, 2));
        assert_eq!(line_column("ab", 0), (1, 1));
    }
}
