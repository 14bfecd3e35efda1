//! The artifact cache: work that depends only on a file's content and on
//! the code that made it (an extraction, a carrier's measured geometry and
//! calibration, a source video's head poses) is stored under a name made of
//! the content's sha256 and the versions of that code. A renamed copy of a
//! video is not extracted twice; a new extractor or solver never reuses an
//! old result, because its version is in the name.

use crate::{sha256_file, CoreError};
use std::path::{Path, PathBuf};

/// Where cached artifacts live: `flag`, `$EYEREPLAY_CACHE`, or the
/// user's cache folder (`$XDG_CACHE_HOME/eyereplay`, else
/// `~/.cache/eyereplay`), never the current folder: the command line and
/// the Python package share it.
pub fn cache_dir(flag: Option<&Path>) -> PathBuf {
    cache_dir_with(flag, |k| std::env::var_os(k))
}

fn cache_dir_with(
    flag: Option<&Path>,
    env: impl Fn(&str) -> Option<std::ffi::OsString>,
) -> PathBuf {
    if let Some(p) = flag {
        return p.to_path_buf();
    }
    let set = |k: &str| env(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    if let Some(p) = set("EYEREPLAY_CACHE") {
        return p;
    }
    // XDG: a relative value is invalid and ignored.
    if let Some(p) = set("XDG_CACHE_HOME").filter(|p| p.is_absolute()) {
        return p.join("eyereplay");
    }
    let home = set("HOME").unwrap_or_else(std::env::temp_dir);
    home.join(".cache/eyereplay")
}

/// The name of one cached artifact: its kind (a folder of the cache), the
/// sha256 of the content it was made from, and every version it depends on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ArtifactKey {
    kind: String,
    sha256: String,
    /// `(tag, value)` in order, written `-{tag}{value}`.
    versions: Vec<(String, String)>,
    /// File name suffix after the first dot (`csv`, `c1.calibration.json`).
    ext: String,
}

impl ArtifactKey {
    /// The key of an artifact made from content whose sha256 is `sha256`.
    pub fn new(kind: &str, sha256: impl Into<String>, ext: &str) -> Self {
        ArtifactKey {
            kind: kind.to_string(),
            sha256: sha256.into(),
            versions: Vec::new(),
            ext: ext.to_string(),
        }
    }

    /// The key of an artifact made from `file` (hashed now).
    pub fn of_file(kind: &str, file: &Path, ext: &str) -> Result<Self, CoreError> {
        Ok(Self::new(kind, sha256_file(file)?, ext))
    }

    /// Adds a version the artifact depends on.
    pub fn version(mut self, tag: &str, value: impl std::fmt::Display) -> Self {
        self.versions.push((tag.to_string(), value.to_string()));
        self
    }

    /// The same key with another file suffix: a second artifact derived
    /// from the first (a carrier's calibration beside its measurement).
    pub fn with_ext(&self, ext: &str) -> Self {
        ArtifactKey {
            ext: ext.to_string(),
            ..self.clone()
        }
    }

    /// The sha256 of the content.
    pub fn sha256(&self) -> &str {
        &self.sha256
    }

    /// File name within its kind's folder.
    pub fn file_name(&self) -> String {
        let mut name = self.sha256.clone();
        for (tag, value) in &self.versions {
            name.push('-');
            name.push_str(tag);
            name.push_str(value);
        }
        name.push('.');
        name.push_str(&self.ext);
        name
    }
}

/// A cache folder of artifacts named by [`ArtifactKey`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ArtifactCache {
    root: PathBuf,
}

impl ArtifactCache {
    pub fn new(root: impl Into<PathBuf>) -> Self {
        ArtifactCache { root: root.into() }
    }

    /// The cache at `flag`, `$EYEREPLAY_CACHE` or the user's cache folder
    /// ([`cache_dir`]).
    pub fn at(flag: Option<&Path>) -> Self {
        Self::new(cache_dir(flag))
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Where the artifact of `key` is (or will be) stored.
    pub fn path(&self, key: &ArtifactKey) -> PathBuf {
        self.root.join(&key.kind).join(key.file_name())
    }

    /// The artifact of `key` when cached: `read` loads it (`Ok(None)` for a
    /// file it rejects, e.g. of an older format); else `make` computes it,
    /// `write` stores it, and it is read back so a first run and a rerun
    /// return the very same value.
    pub fn get_or_make<T, E: From<CoreError>>(
        &self,
        key: &ArtifactKey,
        read: impl Fn(&Path) -> Result<Option<T>, E>,
        make: impl FnOnce() -> Result<T, E>,
        write: impl FnOnce(&Path, &T) -> Result<(), E>,
    ) -> Result<T, E> {
        let path = self.path(key);
        if let Some(v) = read(&path)? {
            return Ok(v);
        }
        let v = make()?;
        write(&path, &v)?;
        read(&path)?.ok_or_else(|| {
            CoreError::invalid(&path, "cache file vanished right after it was written").into()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cache_folder_follows_the_flag_then_the_environment() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |k: &str| {
                pairs
                    .iter()
                    .find(|(a, _)| *a == k)
                    .map(|(_, v)| std::ffi::OsString::from(v))
            }
        };
        let all = env(&[
            ("EYEREPLAY_CACHE", "/e"),
            ("XDG_CACHE_HOME", "/x"),
            ("HOME", "/h"),
        ]);
        assert_eq!(cache_dir_with(Some(Path::new("/f")), all), Path::new("/f"));
        assert_eq!(cache_dir_with(None, all), Path::new("/e"));
        let xdg = env(&[("XDG_CACHE_HOME", "/x"), ("HOME", "/h")]);
        assert_eq!(cache_dir_with(None, xdg), Path::new("/x/eyereplay"));
        // A relative XDG_CACHE_HOME is ignored, as the spec says.
        let rel = env(&[("XDG_CACHE_HOME", "x"), ("HOME", "/h")]);
        assert_eq!(cache_dir_with(None, rel), Path::new("/h/.cache/eyereplay"));
        let empty = env(&[("EYEREPLAY_CACHE", ""), ("HOME", "/h")]);
        assert_eq!(
            cache_dir_with(None, empty),
            Path::new("/h/.cache/eyereplay")
        );
    }

    #[test]
    fn names_carry_content_and_every_version() {
        let cache = ArtifactCache::new("/c");
        let key = ArtifactKey::new("extract", "ab12", "csv")
            .version("v", "0.1.0")
            .version("r", 3);
        assert_eq!(cache.path(&key), Path::new("/c/extract/ab12-v0.1.0-r3.csv"));
        assert_eq!(
            key.with_ext("c2.calibration.json").file_name(),
            "ab12-v0.1.0-r3.c2.calibration.json"
        );
    }

    #[test]
    fn same_content_same_key_whatever_the_file_name() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.mp4"), dir.path().join("b.mp4"));
        std::fs::write(&a, b"abc").unwrap();
        std::fs::write(&b, b"abc").unwrap();
        let ka = ArtifactKey::of_file("extract", &a, "csv").unwrap();
        // sha256("abc"), as `sha256sum` prints it.
        assert_eq!(
            ka.sha256(),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(ka, ArtifactKey::of_file("extract", &b, "csv").unwrap());
    }

    #[test]
    fn made_once_then_read() {
        let dir = tempfile::tempdir().unwrap();
        let cache = ArtifactCache::new(dir.path());
        let key = ArtifactKey::new("n", "00", "json").version("v", 1);
        let made = std::cell::Cell::new(0);
        let read = |p: &Path| -> Result<Option<u32>, CoreError> {
            crate::read_json_cache(p, "number cache")
        };
        let write = |p: &Path, v: &u32| crate::write_json(p, v);
        for _ in 0..2 {
            let v = cache
                .get_or_make(
                    &key,
                    read,
                    || {
                        made.set(made.get() + 1);
                        Ok(7)
                    },
                    write,
                )
                .unwrap();
            assert_eq!(v, 7);
        }
        assert_eq!(made.get(), 1);
    }
}
