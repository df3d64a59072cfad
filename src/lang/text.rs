//! From a file's bytes to the text the parser reads: bytes that are not UTF-8 found (the
//! first one's byte offset is kept for the error), a byte-order mark dropped, and CRLF and
//! CR-only line endings made `\n`, so that every later `line:column` is right.

/// A file's bytes read as text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Decoded {
    /// The text, with each invalid sequence replaced by U+FFFD, not yet [`normalize`]d.
    pub text: String,
    /// The first byte that is not UTF-8, if any.
    pub invalid: Option<InvalidByte>,
}

/// The first byte of a file that is not part of valid UTF-8.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InvalidByte {
    /// Its offset in the file, from 0.
    pub offset: usize,
    /// Its value.
    pub byte: u8,
    /// Its offset in the [`normalize`]d text (where U+FFFD stands for it).
    pub normalized_offset: usize,
}

/// Reads bytes as UTF-8, replacing what is not.
///
/// ```
/// use ghm::lang::text::decode;
///
/// let d = decode(b"\xEF\xBB\xBFsample 1\r\n# caf\xE9\r\n".to_vec());
/// let bad = d.invalid.unwrap();
/// assert_eq!((bad.offset, bad.byte), (18, 0xE9));
/// // Without the BOM and the first CR, the text before it is 3 + 1 bytes shorter.
/// assert_eq!(bad.normalized_offset, 14);
/// ```
pub fn decode(bytes: Vec<u8>) -> Decoded {
    match String::from_utf8(bytes) {
        Ok(text) => Decoded {
            text,
            invalid: None,
        },
        Err(e) => {
            let offset = e.utf8_error().valid_up_to();
            let bytes = e.into_bytes();
            let text = String::from_utf8_lossy(&bytes).into_owned();
            // The valid prefix is the same in the lossy text.
            let normalized_offset = normalize(text.get(..offset).unwrap_or("")).len();
            Decoded {
                text,
                invalid: Some(InvalidByte {
                    offset,
                    byte: bytes.get(offset).copied().unwrap_or(0),
                    normalized_offset,
                }),
            }
        }
    }
}

/// The text without a leading byte-order mark, with CRLF and lone CR made `\n`.
///
/// ```
/// use ghm::lang::text::normalize;
///
/// assert_eq!(normalize("\u{FEFF}a\r\nb\rc\n"), "a\nb\nc\n");
/// ```
pub fn normalize(text: &str) -> String {
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
    if !text.contains('\r') {
        return text.to_string();
    }
    text.replace("\r\n", "\n").replace('\r', "\n")
}
