use crate::CoreError;
use sha2::{Digest, Sha256};
use std::io::{BufWriter, Read, Write};
use std::path::Path;

/// Writes a file so that readers only ever see the old file or the complete
/// new one: the content goes to a temporary file in the same directory, then
/// is renamed over the target. This holds when the process is killed at any
/// point (the kernel keeps what was written); it does not fsync, so after a
/// power loss a file may be empty, which the resuming commands detect by
/// verifying files before they skip them.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<(), CoreError> {
    atomic_write_with(path, |w| w.write_all(bytes))
}

/// Reads a value cached as JSON (measured once, e.g. per video); `None`
/// when the file is missing. A file that is not one (`what`) is an error
/// that says how to get rid of it.
pub fn read_json_cache<T: serde::de::DeserializeOwned>(
    path: &Path,
    what: &str,
) -> Result<Option<T>, CoreError> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(CoreError::io(path, e)),
    };
    serde_json::from_slice(&bytes).map(Some).map_err(|e| {
        CoreError::invalid(
            path,
            format!("not a {what} ({e}); delete it to measure again"),
        )
    })
}

/// Writes a value as JSON, atomically ([`atomic_write`]).
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), CoreError> {
    let json = serde_json::to_vec(value).map_err(|e| CoreError::invalid(path, e.to_string()))?;
    atomic_write(path, &json)
}

/// Like [`atomic_write`], with the content produced by a closure writing to a
/// buffered stream. On any error the temporary file is removed.
pub fn atomic_write_with(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), CoreError> {
    // Whole, so that a stop (Ctrl-C) finds the file written or not begun.
    crate::inflight::guarded(|| atomic_write_unguarded(path, fill))
}

fn atomic_write_unguarded(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), CoreError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(|e| CoreError::io(dir, e))?;
    // The temporary name starts with the target's, so a resuming run can
    // tell whose leftover it is (see `stale_temp_files`).
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(".tmp")
        .tempfile_in(dir)
        // tempfile's error names the random temporary file; the user
        // asked for `path`, so name that, with the OS's reason alone.
        .map_err(|e| CoreError::io(path, std::io::Error::from(e.kind())))?;
    // Removed by the binary's Ctrl-C handler if the run stops here.
    let _listed = crate::inflight::InFlight::new(tmp.path());
    // tempfile creates 0600; datasets are shared, so use what a plain
    // create would give (0666 less the usual umask 022).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(tmp.path(), std::fs::Permissions::from_mode(0o644))
            .map_err(|e| CoreError::io(path, e))?;
    }
    {
        let mut w = BufWriter::new(tmp.as_file());
        fill(&mut w).map_err(|e| CoreError::io(path, e))?;
        w.flush().map_err(|e| CoreError::io(path, e))?;
    }
    tmp.persist(path)
        .map_err(|e| CoreError::io(path, e.error))?;
    Ok(())
}

/// Checks, before long work starts, that a file can later be written at
/// `path` as [`atomic_write`] writes it: its folder is created if needed
/// and a temporary file is made there and removed. A folder at `path`
/// itself is an error.
pub fn check_writable(path: &Path) -> Result<(), CoreError> {
    // `out.json/` names a folder, though its last component reads as a
    // file name: the write would fail after the work.
    if path.is_dir() || path.as_os_str().as_encoded_bytes().ends_with(b"/") {
        return Err(CoreError::invalid(path, "is a folder; give a file name"));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if let Err(e) = std::fs::create_dir_all(dir) {
        // `a/m.json` where `a` is a file: "File exists" would not say so.
        if let Some(file) = dir.ancestors().find(|a| a.is_file()) {
            return Err(CoreError::invalid(
                path,
                format!("{} is a file, not a folder", file.display()),
            ));
        }
        return Err(CoreError::io(path, e));
    }
    tempfile::Builder::new()
        .prefix(".eyereplay-check.")
        .tempfile_in(dir)
        .map(drop)
        .map_err(|e| CoreError::io(path, std::io::Error::from(e.kind())))
}

/// Whether two paths name one file: an existing file reached both ways
/// (links, `./`, `..`), or, for one not there yet, the same name in the
/// same folder.
pub fn same_file(a: &Path, b: &Path) -> bool {
    fn resolved(p: &Path) -> Option<std::path::PathBuf> {
        if let Ok(full) = p.canonicalize() {
            return Some(full);
        }
        let parent = match p.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        Some(parent.canonicalize().ok()?.join(p.file_name()?))
    }
    a == b || matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y)
}

/// Leftover temporary files of `target` in its folder (from a process that
/// was killed while writing it): `.NAME.*.tmp` and `.NAME.*.part`.
pub fn stale_temp_files(target: &Path) -> Vec<std::path::PathBuf> {
    let (Some(dir), Some(name)) = (target.parent(), target.file_name()) else {
        return Vec::new();
    };
    // `s.mp4`'s folder is "", which read_dir cannot open.
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let prefix = format!(".{}.", name.to_string_lossy());
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<_> = rd
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            let n = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            n.starts_with(&prefix) && (n.ends_with(".tmp") || n.ends_with(".part"))
        })
        .collect();
    v.sort();
    v
}

/// Hex SHA-256 of a byte slice.
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

/// Hex SHA-256 of a file, streamed.
pub fn sha256_file(path: &Path) -> Result<String, CoreError> {
    let mut f = std::fs::File::open(path).map_err(|e| CoreError::io(path, e))?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = f.read(&mut buf).map_err(|e| CoreError::io(path, e))?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Ok(hex::encode(h.finalize()))
}

/// The first `dir/rel` that is a file, for `dir` the current folder, the
/// running binary's folder, and each of their ancestors: how eyereplay finds
/// the checkout's `.cache/models`, `.cache/faces`, `examples/default.toml`
/// and helper scripts when run from anywhere inside it.
pub fn find_upwards(rel: &Path) -> Option<std::path::PathBuf> {
    let starts = [std::env::current_dir().ok(), std::env::current_exe().ok()];
    starts
        .into_iter()
        .flatten()
        .flat_map(|s| s.ancestors().map(|d| d.join(rel)).collect::<Vec<_>>())
        .find(|p| p.is_file())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_file_is_told_by_any_of_its_paths() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("sub")).unwrap();
        std::fs::write(d.join("a.csv"), b"x").unwrap();
        std::os::unix::fs::symlink(d.join("a.csv"), d.join("link.csv")).unwrap();
        let a = d.join("a.csv");
        assert!(same_file(&a, &d.join("sub/../a.csv")));
        assert!(same_file(&a, &d.join("link.csv")));
        // Not there yet: the same name in the same folder.
        assert!(same_file(&d.join("new.mp4"), &d.join("sub/../new.mp4")));
        assert!(!same_file(&a, &d.join("new.mp4")));
        assert!(!same_file(&d.join("sub/new.mp4"), &d.join("new.mp4")));
    }

    #[test]
    fn writability_is_checked_without_leaving_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("sub/out.csv");
        check_writable(&target).unwrap();
        // The folder is made, nothing is left in it.
        assert_eq!(
            std::fs::read_dir(dir.path().join("sub")).unwrap().count(),
            0
        );
        let e = check_writable(dir.path()).unwrap_err().to_string();
        assert!(e.contains("is a folder"), "{e}");
        // A file where a folder should be: the error names the target.
        std::fs::write(dir.path().join("f"), b"x").unwrap();
        let inside = dir.path().join("f/out.csv");
        let e = check_writable(&inside).unwrap_err().to_string();
        assert!(e.contains("f/out.csv"), "{e}");
        // A name with a trailing slash is a folder's, whatever it reads as.
        let slash = std::path::PathBuf::from(format!("{}/new.json/", dir.path().display()));
        let e = check_writable(&slash).unwrap_err().to_string();
        assert!(e.contains("is a folder; give a file name"), "{e}");
    }

    #[test]
    fn sha256_of_abc_matches_fips_180_2_vector() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn written_files_are_world_readable_and_temp_names_are_attributable() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("a.csv");
        atomic_write(&target, b"x").unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&target).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o644);
        }
        std::fs::write(dir.path().join(".a.csv.123.part"), b"").unwrap();
        std::fs::write(dir.path().join(".a.csv.x1y2.tmp"), b"").unwrap();
        std::fs::write(dir.path().join(".ab.csv.1.tmp"), b"").unwrap();
        let stale = stale_temp_files(&target);
        assert_eq!(stale.len(), 2, "{stale:?}");
    }

    #[test]
    fn failed_write_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.csv");
        let r = atomic_write_with(&target, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("disk full"))
        });
        assert!(r.is_err());
        assert!(!target.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
