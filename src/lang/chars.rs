//! Words for characters a syntax error stops at when their look does not say what is wrong:
//! invisible ones (a zero-width space pasted with copied text), odd spaces, control
//! characters, and letters outside ASCII, which names may not use.

/// What a syntax error says about the character it stopped at: the headline and the help.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Unexpected {
    /// E.g. ``invisible character U+200B (zero width space)``.
    pub what: String,
    /// What to do about it.
    pub help: &'static str,
}

/// A description of `c` if it is invisible, an odd space, a control character or a
/// non-ASCII letter; `None` for a character that shows what it is.
///
/// ```
/// use ghm::lang::chars::unexpected;
///
/// let zwsp = unexpected('\u{200B}').unwrap();
/// assert_eq!(zwsp.what, "invisible character U+200B (zero width space)");
/// assert_eq!(unexpected('\u{7}').unwrap().what, "control character U+0007");
/// assert!(unexpected('Δ').unwrap().what.contains("non-ASCII letter `Δ` (U+0394)"));
/// assert_eq!(unexpected('×'), None);
/// ```
pub fn unexpected(c: char) -> Option<Unexpected> {
    const DELETE: &str = "delete it: it may have come with copied text (retype the line if unsure)";
    let code = format!("U+{:04X}", u32::from(c));
    if let Some(name) = space_name(c) {
        return Some(Unexpected {
            what: format!("space character {code} ({name})"),
            help: "replace it with a plain space",
        });
    }
    if let Some(name) = invisible_name(c) {
        return Some(Unexpected {
            what: format!("invisible character {code} ({name})"),
            help: DELETE,
        });
    }
    if c.is_control() {
        let what = match control_name(c) {
            Some(name) => format!("control character {code} ({name})"),
            None => format!("control character {code}"),
        };
        return Some(Unexpected { what, help: DELETE });
    }
    if c.is_alphabetic() && !c.is_ascii() {
        return Some(Unexpected {
            what: format!("non-ASCII letter `{c}` ({code}): names must be ASCII"),
            help: "names are ASCII letters, digits and `_`, starting with a letter or `_` \
                   (e.g. `delta_w`, `temperature`); other letters may appear in \
                   descriptions, units and comments",
        });
    }
    None
}

fn space_name(c: char) -> Option<&'static str> {
    Some(match c {
        '\u{00A0}' => "no-break space",
        '\u{1680}' => "ogham space mark",
        '\u{2000}' => "en quad",
        '\u{2001}' => "em quad",
        '\u{2002}' => "en space",
        '\u{2003}' => "em space",
        '\u{2004}' => "three-per-em space",
        '\u{2005}' => "four-per-em space",
        '\u{2006}' => "six-per-em space",
        '\u{2007}' => "figure space",
        '\u{2008}' => "punctuation space",
        '\u{2009}' => "thin space",
        '\u{200A}' => "hair space",
        '\u{2028}' => "line separator",
        '\u{2029}' => "paragraph separator",
        '\u{202F}' => "narrow no-break space",
        '\u{205F}' => "medium mathematical space",
        '\u{3000}' => "ideographic space",
        _ => return None,
    })
}

fn invisible_name(c: char) -> Option<&'static str> {
    Some(match c {
        '\u{00AD}' => "soft hyphen",
        '\u{034F}' => "combining grapheme joiner",
        '\u{061C}' => "arabic letter mark",
        '\u{180E}' => "mongolian vowel separator",
        '\u{200B}' => "zero width space",
        '\u{200C}' => "zero width non-joiner",
        '\u{200D}' => "zero width joiner",
        '\u{200E}' => "left-to-right mark",
        '\u{200F}' => "right-to-left mark",
        '\u{202A}' => "left-to-right embedding",
        '\u{202B}' => "right-to-left embedding",
        '\u{202C}' => "pop directional formatting",
        '\u{202D}' => "left-to-right override",
        '\u{202E}' => "right-to-left override",
        '\u{2060}' => "word joiner",
        '\u{2061}' => "function application",
        '\u{2062}' => "invisible times",
        '\u{2063}' => "invisible separator",
        '\u{2064}' => "invisible plus",
        '\u{2066}' => "left-to-right isolate",
        '\u{2067}' => "right-to-left isolate",
        '\u{2068}' => "first strong isolate",
        '\u{2069}' => "pop directional isolate",
        '\u{FE00}'..='\u{FE0F}' => "variation selector",
        '\u{FEFF}' => "zero width no-break space, a byte-order mark not at the file's start",
        _ => return None,
    })
}

fn control_name(c: char) -> Option<&'static str> {
    Some(match c {
        '\0' => "null",
        '\u{8}' => "backspace",
        '\u{B}' => "vertical tab",
        '\u{C}' => "form feed",
        '\u{1B}' => "escape",
        '\u{7F}' => "delete",
        _ => return None,
    })
}
