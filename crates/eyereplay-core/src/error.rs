use std::path::PathBuf;

/// Errors of the core types and file helpers.
#[derive(Debug, thiserror::Error)]
pub enum CoreError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: line {line}: {message}")]
    Parse {
        path: PathBuf,
        line: u64,
        message: String,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("trajectory: {0}")]
    Trajectory(String),
    /// An option or setting out of range (one line naming it).
    #[error("{0}")]
    Setting(String),
    /// The work was asked to stop ([`crate::cancel`]).
    #[error("stopped on request")]
    Stopped,
}

impl CoreError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        CoreError::Io {
            path: path.into(),
            source,
        }
    }
    pub fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        CoreError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// The first `shown` of `items` joined by `sep`, then how many more: a
/// list in a one-line message, however many items there are (a wrong
/// `session_frames` once named all 10,000 sessions).
pub fn first_few(items: &[String], shown: usize, sep: &str) -> String {
    let mut text = items
        .iter()
        .take(shown)
        .cloned()
        .collect::<Vec<_>>()
        .join(sep);
    if items.len() > shown {
        text.push_str(&format!("{sep}and {} more", items.len() - shown));
    }
    text
}

/// A number as an error message shows it: plain where it is of a readable
/// size, in exponent form where it is not (`1e308` was printed as 309
/// digits).
pub fn show_number(v: f64) -> String {
    if v == 0.0 || (1e-4..1e9).contains(&v.abs()) || !v.is_finite() {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

#[cfg(test)]
mod show_number_tests {
    #[test]
    fn numbers_are_shown_plain_or_with_an_exponent() {
        use super::show_number;
        assert_eq!(show_number(2.5), "2.5");
        assert_eq!(show_number(-10.0), "-10");
        assert_eq!(show_number(1e308), "1e308");
        assert_eq!(show_number(-3e-7), "-3e-7");
        assert_eq!(show_number(f64::NAN), "NaN");
        assert_eq!(show_number(0.0), "0");
    }

    #[test]
    fn a_long_list_is_cut_to_its_first_few() {
        use super::first_few;
        let items: Vec<String> = (1..=5).map(|i| format!("s{i}")).collect();
        assert_eq!(first_few(&items, 3, "; "), "s1; s2; s3; and 2 more");
        assert_eq!(first_few(&items[..3], 3, ", "), "s1, s2, s3");
        assert_eq!(first_few(&[], 3, ", "), "");
    }
}
