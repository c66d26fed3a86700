//! An error as one line: the message, then each cause the message does not
//! already contain. Library errors often include their source in their own
//! text; printing the whole chain as well would say everything twice.

pub fn error_text(e: &anyhow::Error) -> String {
    let mut text = e.to_string();
    for cause in e.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text.push_str(": ");
            text.push_str(&cause);
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot read {path}: {source}")]
    struct Telling {
        path: &'static str,
        source: std::io::Error,
    }

    #[test]
    fn each_cause_once() {
        let io = || std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        // (error, expected text)
        let cases = [
            (
                anyhow::Error::new(Telling {
                    path: "a.toml",
                    source: io(),
                }),
                "cannot read a.toml: no such file",
            ),
            (
                anyhow::Error::new(Telling {
                    path: "a.toml",
                    source: io(),
                })
                .context("machine a"),
                "machine a: cannot read a.toml: no such file",
            ),
            (
                anyhow::Error::new(io()).context("cannot read b.toml"),
                "cannot read b.toml: no such file",
            ),
        ];
        for (e, want) in cases {
            assert_eq!(error_text(&e), want);
        }
    }
}
