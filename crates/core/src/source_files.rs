//! Reading the files a user writes (rig and experiment TOML, `--ss` JSON): bytes to text, and
//! every complaint as one line naming the file, the line and the key.
//!
//! Text is UTF-8 with or without a byte-order mark; an invalid byte is reported by line and
//! column. TOML errors keep the parser's position but drop its multi-line source excerpt, and
//! an unknown key is answered with the nearest known one. Values that parse but make no sense
//! (a negative mass) are located afterwards with [`toml_line`].

use std::io::Read;
use std::path::Path;

/// Where the files a caller names are read from: the file system ([`Disk`]), or anything else
/// that can open a path for reading, such as the embedded article records
/// ([`crate::emulator::article::Embedded`]) or a front end's reader that notes every file a
/// command reads so that no output of the command replaces one. Every reader of user files in
/// this crate has a form taking `&dyn Files`; the plain form reads from [`Disk`].
pub trait Files: Sync {
    /// A stream of the bytes of the file at `path`.
    fn open(&self, path: &Path) -> std::io::Result<Box<dyn Read + Send + '_>>;
}

/// The file system.
#[derive(Debug, Clone, Copy, Default)]
pub struct Disk;

impl Files for Disk {
    fn open(&self, path: &Path) -> std::io::Result<Box<dyn Read + Send + '_>> {
        Ok(Box::new(std::fs::File::open(path)?))
    }
}

/// Why a user file cannot be used, in words that do not name the file (the caller puts its name
/// first): it cannot be read, it is too large, it is not text, or a value in it makes no sense.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum InputError {
    /// The file cannot be opened or read.
    #[error("cannot read: {0}")]
    Read(String),
    /// The file is larger than the limit for its kind.
    #[error("larger than {limit_mib} MiB, the limit for a text input")]
    TooLarge {
        /// The limit (MiB).
        limit_mib: u64,
    },
    /// A byte that is not UTF-8.
    #[error(
        "line {line}, column {column}: not UTF-8 text (byte 0x{byte:02X}); save the file as UTF-8"
    )]
    NotUtf8 {
        /// 1-based line.
        line: usize,
        /// 1-based column (characters).
        column: usize,
        /// The offending byte.
        byte: u8,
    },
    /// A value or structure that makes no sense, located in words (`line 3, key `A`: ...`).
    #[error("{0}")]
    Invalid(String),
}

/// A value of a named field that makes no sense: the field (a TOML key, a grid axis) and what is
/// wrong, in words that name it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct FieldError {
    /// The field (key) at fault.
    pub field: &'static str,
    /// What is wrong with it.
    pub message: String,
}

impl FieldError {
    /// The complaint `message` about `field`.
    pub fn new(field: &'static str, message: impl Into<String>) -> FieldError {
        FieldError {
            field,
            message: message.into(),
        }
    }
}

/// The UTF-8 byte-order mark that spreadsheet programs put at the start of text files.
pub const BOM: &[u8] = b"\xEF\xBB\xBF";

/// The text of a user file, a leading byte-order mark dropped. The error (without the file name,
/// which the caller puts first) is `cannot read: …` or `line L, column C: not UTF-8 text …`.
pub fn read_text(files: &dyn Files, path: &Path) -> Result<String, InputError> {
    decode(read_bounded(files, path)?)
}

/// The largest text file (rig, experiment, `--ss` model, partial result) read whole, in bytes.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// The bytes of a file of at most [`MAX_TEXT_BYTES`]; a special file such as `/dev/zero` that
/// never ends is stopped at the limit.
pub fn read_bounded(files: &dyn Files, path: &Path) -> Result<Vec<u8>, InputError> {
    let read = |e: std::io::Error| InputError::Read(e.to_string());
    let file = files.open(path).map_err(read)?;
    let mut bytes = Vec::new();
    file.take(MAX_TEXT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(read)?;
    if bytes.len() as u64 > MAX_TEXT_BYTES {
        return Err(InputError::TooLarge {
            limit_mib: MAX_TEXT_BYTES >> 20,
        });
    }
    Ok(bytes)
}

/// Bytes to text, a leading byte-order mark dropped; the error names the line and column of the
/// first invalid byte.
pub fn decode(mut bytes: Vec<u8>) -> Result<String, InputError> {
    if bytes.starts_with(BOM) {
        bytes.drain(..BOM.len());
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        let (line, column) = line_col(&bytes[..at]);
        InputError::NotUtf8 {
            line,
            column,
            byte: bytes[at],
        }
    })
}

/// 1-based line and column (in characters) of the end of `prefix`.
pub fn line_col(prefix: &[u8]) -> (usize, usize) {
    let line = 1 + prefix.iter().filter(|&&b| b == b'\n').count();
    let start = prefix
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let column = 1 + String::from_utf8_lossy(&prefix[start..]).chars().count();
    (line, column)
}

/// One step of a path into a TOML document: a key, or an index into an array of tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Key<'a> {
    /// A key of a table.
    Name(&'a str),
    /// An element of an array (0-based).
    Index(usize),
}

/// The 1-based line where the value at `path` is written (the key's line), or, when the last
/// key is absent, the line of the deepest table on the path that exists.
pub fn toml_line(text: &str, path: &[Key]) -> Option<usize> {
    let doc = toml::de::DeTable::parse(text).ok()?;
    let mut table = doc.get_ref();
    let mut value: Option<&toml::Spanned<toml::de::DeValue>> = None;
    let mut line = None;
    for step in path {
        let next = match (step, value.map(|v| v.get_ref())) {
            (Key::Name(name), None | Some(toml::de::DeValue::Table(_))) => {
                if let Some(toml::de::DeValue::Table(t)) = value.map(|v| v.get_ref()) {
                    table = t;
                }
                table.get_key_value(*name).map(|(k, v)| (k.span().start, v))
            }
            (Key::Index(i), Some(toml::de::DeValue::Array(a))) => {
                a.get(*i).map(|v| (v.span().start, v))
            }
            _ => None,
        };
        let Some((start, v)) = next else { break };
        line = Some(line_col(&text.as_bytes()[..start]).0);
        value = Some(v);
    }
    line
}

/// A TOML error as one line: `line L, column C: message`, with an unknown key answered by the
/// nearest known one instead of the parser's list of every key.
pub fn toml_error(err: &toml::de::Error, text: &str) -> String {
    let at = err.span().map_or(String::new(), |s| {
        let start = s.start.min(text.len());
        let (line, column) = line_col(&text.as_bytes()[..start]);
        let key = if err.message().starts_with("duplicate key") {
            key_at(text, s)
        } else {
            key_before(text, start)
        };
        match key {
            Some(key) => format!("line {line}, column {column}, key `{}`: ", shown_key(key)),
            None => format!("line {line}, column {column}: "),
        }
    });
    format!("{at}{}", serde_message(err.message()))
}

/// A serde message in the words of a file's author, on one line: fields are keys, and an
/// unknown key gets the nearest known one instead of the list of every key.
pub fn serde_message(message: &str) -> String {
    let message = message.trim_end();
    match message.strip_prefix("unknown field ") {
        Some(rest) => unknown_key(rest),
        None => message
            .replace('\n', " ")
            .replace("missing field", "missing key"),
    }
}

/// The key of a `key = value` line when `offset` lies in the value.
fn key_before(text: &str, offset: usize) -> Option<&str> {
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let (key, _) = text[line_start..offset].split_once('=')?;
    let key = key.trim().trim_matches('"');
    (!key.is_empty() && !key.contains(['[', '#'])).then_some(key)
}

/// The key written at `span` (a duplicate key or table name, quotes dropped).
fn key_at(text: &str, span: std::ops::Range<usize>) -> Option<&str> {
    let key = text.get(span)?.trim().trim_matches(['"', '\'']);
    (!key.is_empty() && !key.contains(['\n', '=', '#'])).then_some(key)
}

/// `` `beta`, expected one of `a`, `b` `` (serde's words) to a message with a suggestion.
fn unknown_key(serde_words: &str) -> String {
    let names: Vec<&str> = serde_words.split('`').skip(1).step_by(2).collect();
    let Some((unknown, known)) = names.split_first() else {
        return format!("unknown key {serde_words}");
    };
    unknown_key_among(unknown, known)
}

/// "unknown key `K`" with the closest known key, or the list of the known keys; the unknown
/// key shown at most [`MAX_KEY_CHARS`] characters long.
pub fn unknown_key_among(unknown: &str, known: &[&str]) -> String {
    let shown = shown_key(unknown);
    match suggest(unknown, known) {
        Some(best) => format!("unknown key `{shown}`; did you mean `{best}`?"),
        None => format!(
            "unknown key `{shown}`; the known keys are {}",
            known.join(", ")
        ),
    }
}

/// The most characters of a key a message shows, and the longest key a suggestion is sought
/// for: every known key is far shorter.
pub const MAX_KEY_CHARS: usize = 64;

/// A key as a message shows it: at most [`MAX_KEY_CHARS`] characters, a longer one cut, with
/// its length.
pub fn shown_key(key: &str) -> std::borrow::Cow<'_, str> {
    shown_text(key, MAX_KEY_CHARS)
}

/// `text` cut to its first `max_chars` characters, saying how long it was, so a message about
/// a huge argument stays one readable line.
pub fn shown_text(text: &str, max_chars: usize) -> std::borrow::Cow<'_, str> {
    match text.char_indices().nth(max_chars) {
        None => text.into(),
        Some((cut, _)) => format!("{}… ({} bytes)", &text[..cut], text.len()).into(),
    }
}

/// The most characters of a value or an assignment a message shows.
pub const MAX_VALUE_CHARS: usize = 128;

/// The known name closest to `unknown`: one that extends it by a unit suffix (`beta` →
/// `beta_bar`), shares its stem with another unit (`mass_g` → `mass_kg`), or is at most a
/// third of its length in edits away. None for a key longer than 4 × [`MAX_KEY_CHARS`]
/// bytes, which no edit brings near a known key (the edits cost its length squared).
pub fn suggest<'a>(unknown: &str, known: &[&'a str]) -> Option<&'a str> {
    if unknown.len() > 4 * MAX_KEY_CHARS {
        return None;
    }
    let lower = unknown.to_ascii_lowercase();
    let stem = |s: &str| s.rsplit_once('_').map_or(s.to_string(), |(a, _)| a.into());
    let score = |k: &str| -> Option<usize> {
        if k.starts_with(&format!("{lower}_")) || stem(k) == stem(&lower) {
            return Some(0);
        }
        let d = edit_distance(&lower, k);
        (d <= lower.len() / 3).then_some(d)
    };
    known
        .iter()
        .filter_map(|k| score(k).map(|s| (s, *k)))
        .min_by_key(|(s, _)| *s)
        .map(|(_, k)| k)
}

/// Levenshtein distance between two strings (in characters).
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substitute = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substitute.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// A `--set` value as TOML (number, bool, quoted string, array, inline table), or a bare word
/// as a string.
pub fn parse_value(raw: &str) -> toml::Value {
    let doc = format!("v = {raw}");
    match doc.parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(raw.into())),
        Err(_) => toml::Value::String(raw.to_string()),
    }
}

/// `value` as the type of `current` (an integer where a float is wanted becomes that float);
/// the error is the type `value` has.
pub fn typed_like(current: &toml::Value, value: toml::Value) -> Result<toml::Value, &'static str> {
    match (current, value) {
        (toml::Value::Float(_), toml::Value::Integer(i)) => Ok(toml::Value::Float(i as f64)),
        (c, v) if c.type_str() == v.type_str() => Ok(v),
        (_, v) => Err(v.type_str()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_unknown_key_is_shown_cut_and_gets_no_suggestion() {
        let known = ["beta_bar", "mass_kg"];
        let words = |unknown: &str| {
            let listed: Vec<String> = known.iter().map(|k| format!("`{k}`")).collect();
            format!("`{unknown}`, expected one of {}", listed.join(", "))
        };
        // 200 000 characters: the message stays short, and names the length
        let long = format!("beta_bar{}", "x".repeat(199_992));
        let message = unknown_key(&words(&long));
        assert!(message.len() < 300, "{} bytes", message.len());
        assert!(message.contains("… (200000 bytes)"), "{message}");
        assert!(!message.contains("did you mean"), "{message}");
        assert_eq!(suggest(&long, &known), None);
        // a key of exactly the shown length is shown whole, one more character is cut
        let exact = "k".repeat(MAX_KEY_CHARS);
        assert_eq!(shown_key(&exact), exact.as_str());
        let over = "é".repeat(MAX_KEY_CHARS + 1);
        assert_eq!(
            shown_key(&over),
            format!("{}… ({} bytes)", "é".repeat(MAX_KEY_CHARS), over.len())
        );
        // an ordinary typo still gets its suggestion
        assert_eq!(suggest("beta_bra", &known), Some("beta_bar"));
    }

    #[test]
    fn bom_is_dropped_and_bad_bytes_are_located() {
        assert_eq!(decode(b"\xEF\xBB\xBFa = 1".to_vec()).unwrap(), "a = 1");
        let e = decode(b"a = 1\nb = \"\xE9\"\n".to_vec()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "line 2, column 6: not UTF-8 text (byte 0xE9); save the file as UTF-8"
        );
    }

    #[test]
    fn toml_line_follows_tables_and_arrays_of_tables() {
        let text = "a = 1\n\n[s]\nx = 2\n\n[[d]]\nk = 3\n\n[[d]]\nm = 4\nk = 5\n";
        let at = |p: &[Key]| toml_line(text, p);
        assert_eq!(at(&[Key::Name("a")]), Some(1));
        assert_eq!(at(&[Key::Name("s"), Key::Name("x")]), Some(4));
        assert_eq!(
            at(&[Key::Name("d"), Key::Index(1), Key::Name("k")]),
            Some(11)
        );
        // an absent key: the deepest table that exists
        assert_eq!(at(&[Key::Name("s"), Key::Name("y")]), Some(3));
        assert_eq!(at(&[Key::Name("zz")]), None);
    }

    #[test]
    fn unknown_keys_get_the_nearest_known_one() {
        let known = ["beta_bar", "mass_kg", "kp", "c12_m5_per_ns"];
        assert_eq!(suggest("beta", &known), Some("beta_bar"));
        assert_eq!(suggest("mass_g", &known), Some("mass_kg"));
        assert_eq!(suggest("Mass_kg", &known), Some("mass_kg"));
        assert_eq!(suggest("c12_m5_per_Ns", &known), Some("c12_m5_per_ns"));
        assert_eq!(suggest("viscosity", &known), None);
        assert_eq!(suggest("E", &["A", "B"]), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }

    #[test]
    fn a_bad_value_names_its_key() {
        let text = "a = 1\nbeta_bar = \"x\"\n";
        assert_eq!(key_before(text, 17), Some("beta_bar"));
        assert_eq!(key_before(text, 6), None);
    }

    #[test]
    fn a_duplicate_key_or_table_is_named_with_its_line() {
        let error = |text: &str| {
            let e = toml::from_str::<toml::Table>(text).unwrap_err();
            toml_error(&e, text)
        };
        assert_eq!(
            error("kp = 25.0\nbeta_bar = 100\nkp = 30.0\n"),
            "line 3, column 1, key `kp`: duplicate key"
        );
        assert_eq!(
            error("a = 1\n\"kp\" = 2\nkp = 3\n"),
            "line 3, column 1, key `kp`: duplicate key"
        );
        assert_eq!(
            error("[rig]\nkp = 1.0\n\n[rig]\nkp = 2.0\n"),
            "line 4, column 2, key `rig`: duplicate key"
        );
    }

    #[test]
    fn toml_errors_are_one_line_with_position() {
        #[derive(Debug, serde::Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct T {
            beta_bar: f64,
        }
        let text = "\nbeta = 165\n";
        let e = toml::from_str::<T>(text).unwrap_err();
        assert_eq!(
            toml_error(&e, text),
            "line 2, column 1: unknown key `beta`; did you mean `beta_bar`?"
        );
    }
}
