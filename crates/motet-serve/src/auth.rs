//! Who may use a server: anyone on this computer when it listens on a
//! loopback address; anyone with the token otherwise. The token is made
//! once, kept in the server's folder readable by its owner only, and shown
//! to the person the first time.

use std::io::Write;
use std::path::Path;

/// Length of a token, hex characters.
const TOKEN_HEX: usize = 32;

/// The server's token from `dir/token`, made if missing; `true` if it was
/// just made (so the person must be shown it).
pub fn load_or_make_token(dir: &Path) -> std::io::Result<(String, bool)> {
    let path = dir.join("token");
    if let Ok(t) = std::fs::read_to_string(&path) {
        let t = t.trim().to_string();
        if t.len() == TOKEN_HEX && t.chars().all(|c| c.is_ascii_hexdigit()) {
            return Ok((t, false));
        }
    }
    let mut raw = [0u8; TOKEN_HEX / 2];
    getrandom::fill(&mut raw).map_err(|e| std::io::Error::other(e.to_string()))?;
    let token: String = raw.iter().map(|b| format!("{b:02x}")).collect();
    let mut opts = std::fs::OpenOptions::new();
    opts.write(true).create(true).truncate(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        opts.mode(0o600);
    }
    let mut f = opts.open(&path)?;
    #[cfg(unix)]
    {
        // An existing file keeps its mode through `open`: set it.
        use std::os::unix::fs::PermissionsExt;
        f.set_permissions(std::fs::Permissions::from_mode(0o600))?;
    }
    writeln!(f, "{token}")?;
    Ok((token, true))
}

/// Whether `given` is the token, compared in time that does not depend on
/// where they differ.
pub fn token_matches(token: &str, given: &str) -> bool {
    let (a, b) = (token.as_bytes(), given.as_bytes());
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |d, (x, y)| d | (x ^ y)) == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_token_is_made_once_and_kept_private() {
        let dir = tempfile::tempdir().unwrap();
        let (t, made) = load_or_make_token(dir.path()).unwrap();
        assert!(made);
        assert_eq!(t.len(), TOKEN_HEX);
        let (again, made) = load_or_make_token(dir.path()).unwrap();
        assert_eq!((again.as_str(), made), (t.as_str(), false));
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(dir.path().join("token"))
                .unwrap()
                .permissions()
                .mode();
            assert_eq!(mode & 0o777, 0o600);
        }
        assert!(token_matches(&t, &t));
        assert!(!token_matches(&t, &t[1..]));
        let last = if t.ends_with('a') { "b" } else { "a" };
        assert!(!token_matches(
            &t,
            &format!("{}{last}", &t[..TOKEN_HEX - 1])
        ));
    }
}
