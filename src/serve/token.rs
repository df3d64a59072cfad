//! The API token: read from a file or the environment, kept only as its SHA-256 digest,
//! and compared with a presented one in constant time. Neither is ever printed.

use super::ServeError;
use sha2::{Digest, Sha256};
use std::path::Path;
use subtle::ConstantTimeEq;

/// The environment variable that may hold the token.
pub const TOKEN_ENV: &str = "GHM_SERVE_TOKEN";

/// The shortest token accepted.
pub const MIN_TOKEN_LEN: usize = 16;

/// The token of `--token-file` (its first line, trimmed), else of [`TOKEN_ENV`], else none.
pub fn read_token(file: Option<&Path>) -> Result<Option<String>, ServeError> {
    let token = match file {
        Some(path) => {
            let text = std::fs::read_to_string(path).map_err(|e| {
                ServeError::Token(format!(
                    "cannot read the token file {}: {e}",
                    path.display()
                ))
            })?;
            Some(text.lines().next().unwrap_or("").trim().to_string())
        }
        None => std::env::var(TOKEN_ENV)
            .ok()
            .map(|t| t.trim().to_string())
            .filter(|t| !t.is_empty()),
    };
    if let Some(t) = &token {
        if t.len() < MIN_TOKEN_LEN || t.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(ServeError::Token(format!(
                "the token must be at least {MIN_TOKEN_LEN} characters without blanks (e.g. \
                 `openssl rand -hex 32 > token`)"
            )));
        }
    }
    Ok(token)
}

/// The digest a presented token is compared with.
pub struct TokenCheck {
    digest: [u8; 32],
}

impl TokenCheck {
    /// The check of `token`.
    pub fn new(token: &str) -> TokenCheck {
        TokenCheck {
            digest: Sha256::digest(token.as_bytes()).into(),
        }
    }

    /// Whether `authorization` (the header's value) is `Bearer <the token>`. Digests of
    /// equal length are compared in constant time, so the time taken says nothing of how
    /// much of the token was right.
    pub fn accepts(&self, authorization: Option<&[u8]>) -> bool {
        let presented = authorization
            .and_then(|h| h.strip_prefix(b"Bearer "))
            .unwrap_or(b"");
        let digest: [u8; 32] = Sha256::digest(presented).into();
        bool::from(digest.ct_eq(&self.digest))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_token_itself_is_accepted() {
        let check = TokenCheck::new("0123456789abcdef-secret");
        assert!(check.accepts(Some(b"Bearer 0123456789abcdef-secret")));
        assert!(!check.accepts(Some(b"Bearer 0123456789abcdef-secreT")));
        assert!(!check.accepts(Some(b"0123456789abcdef-secret")));
        assert!(!check.accepts(Some(b"Bearer ")));
        assert!(!check.accepts(None));
    }

    #[test]
    fn a_short_token_is_refused() {
        let path = std::env::temp_dir().join(format!("ghm-token-{}", std::process::id()));
        std::fs::write(&path, "short\n").unwrap();
        let e = read_token(Some(&path)).unwrap_err();
        assert!(e.to_string().contains("at least 16"), "{e}");
        std::fs::write(&path, "0123456789abcdef-secret\nignored\n").unwrap();
        assert_eq!(
            read_token(Some(&path)).unwrap().as_deref(),
            Some("0123456789abcdef-secret")
        );
        std::fs::remove_file(&path).unwrap();
    }
}
