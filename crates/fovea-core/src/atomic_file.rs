//! Writing a file so that it is complete or absent, never cut short under its final name.
//!
//! Every file the toolkit writes (images, statistics, reports, sequence frames, manifests,
//! videos) goes through [`write_atomic`] (bytes in memory), [`write_atomic_with`] (a writer
//! that streams) or [`write_atomic_via`] (another program or library writes a path). Each
//!
//! 1. creates a fresh temporary file in the destination's folder (`.NAME.PID-N.tmp`, hidden,
//!    so the rename below stays inside one file system),
//! 2. writes it and flushes every buffer, checking each error (a `BufWriter` dropped without
//!    `flush` loses the error of its last write: a full disk went unnoticed that way),
//! 3. `fsync`s it (`File::sync_all`: the data is on the disk before the name points at it),
//! 4. renames it onto the destination (atomic on POSIX: readers see the old file or the new
//!    one) and, best effort, `fsync`s the folder so the rename itself survives a crash.
//!
//! On any error the temporary file is removed and the destination is left as it was; the
//! error ([`WriteError`]) names the destination and the operating system's reason, in one
//! line: `cannot write out/r.png: No space left on device (os error 28)`.

use std::fs::OpenOptions;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// A file could not be written: the destination and why.
///
/// The reason is part of the message (and not a `source`), so that a chain of contexts
/// prints it once.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {}", crate::error::printable(&.path.display().to_string()), .reason)]
pub struct WriteError {
    /// The destination (the final name, not the temporary one).
    pub path: PathBuf,
    /// What went wrong (the operating system's message, or the encoder's).
    pub reason: io::Error,
}

impl WriteError {
    /// A write error on `path` for `reason`.
    pub fn new(path: impl Into<PathBuf>, reason: io::Error) -> Self {
        Self {
            path: path.into(),
            reason,
        }
    }
}

/// Writes `bytes` to `path` through a temporary file, flushed, synced and renamed into place.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes `path` by streaming through `write` (behind a buffer), then flushes, syncs and
/// renames the temporary file into place. An error of `write` (or of the flush) removes the
/// temporary file and leaves `path` untouched.
pub fn write_atomic_with<F>(path: &Path, write: F) -> Result<(), WriteError>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let tmp = temporary_path(path).map_err(|e| WriteError::new(path, e))?;
    let result = (|| {
        let file = OpenOptions::new().write(true).create_new(true).open(&tmp)?;
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        // `into_inner` flushes and returns the flush's error (a dropped BufWriter would not).
        w.into_inner().map_err(|e| e.into_error())?.sync_all()
    })();
    commit(path, &tmp, result)
}

/// Lets `write` create and fill a temporary path in `path`'s folder (e.g. another program
/// such as ffmpeg, or a library that only writes to paths), then syncs it and renames it onto
/// `path`. `write` must create the file itself (it does not exist when `write` is called);
/// its error, or a missing file, removes whatever it left and returns the error named after
/// `path`.
pub fn write_atomic_via<F>(path: &Path, write: F) -> Result<(), WriteError>
where
    F: FnOnce(&Path) -> io::Result<()>,
{
    let tmp = temporary_path(path).map_err(|e| WriteError::new(path, e))?;
    let result = write(&tmp).and_then(|()| OpenOptions::new().write(true).open(&tmp)?.sync_all());
    commit(path, &tmp, result)
}

/// After `result` (the temporary file `tmp` written and synced): renames `tmp` onto `path`,
/// or on any error removes `tmp` and returns the error named after `path`.
fn commit(path: &Path, tmp: &Path, result: io::Result<()>) -> Result<(), WriteError> {
    if let Err(e) = result.and_then(|()| std::fs::rename(tmp, path)) {
        // Nothing may be left behind; a failure to remove it changes nothing the caller
        // could act on beyond the error already returned.
        let _ = std::fs::remove_file(tmp);
        return Err(WriteError::new(path, e));
    }
    sync_folder(path);
    Ok(())
}

/// A name in `path`'s folder that no other writer uses: `.NAME.PID-N.tmp`.
fn temporary_path(path: &Path) -> io::Result<PathBuf> {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            "the path names a folder, not a file",
        )
    })?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(
        ".{}-{}.tmp",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    ));
    Ok(path.with_file_name(tmp_name))
}

/// Whether `file_name` is one of this module's temporary names (`.NAME.PID-N.tmp`), e.g. left
/// by a process that was killed between creating and renaming it.
pub fn is_temporary_name(file_name: &str) -> bool {
    let Some(rest) = file_name
        .strip_prefix('.')
        .and_then(|r| r.strip_suffix(".tmp"))
    else {
        return false;
    };
    let Some((_, tag)) = rest.rsplit_once('.') else {
        return false;
    };
    let Some((pid, n)) = tag.split_once('-') else {
        return false;
    };
    !pid.is_empty()
        && !n.is_empty()
        && pid.bytes().all(|b| b.is_ascii_digit())
        && n.bytes().all(|b| b.is_ascii_digit())
}

/// `fsync` of `path`'s folder, so the rename is on the disk too (POSIX). Best effort: some
/// file systems refuse to sync a folder, and the file's data is already synced.
fn sync_folder(path: &Path) {
    #[cfg(unix)]
    {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if let Ok(d) = std::fs::File::open(dir) {
            let _ = d.sync_all();
        }
    }
    #[cfg(not(unix))]
    let _ = path;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!(
            "fovea-atomic-{tag}-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_nanos()
        ));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn writes_and_replaces_leaving_only_the_file() {
        let d = scratch("replace");
        let p = d.join("a.json");
        write_atomic(&p, b"first").unwrap();
        write_atomic(&p, b"second, longer").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second, longer");
        assert_eq!(names(&d), vec!["a.json".to_string()]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_failing_writer_leaves_the_old_file_and_no_temporary() {
        let d = scratch("fail");
        let p = d.join("frame.png");
        write_atomic(&p, b"old").unwrap();
        let e = write_atomic_with(&p, |w| {
            w.write_all(b"half of the new")?;
            Err(io::Error::other("encoder gave up"))
        })
        .unwrap_err();
        assert_eq!(e.path, p);
        let msg = e.to_string();
        assert!(msg.starts_with("cannot write "), "{msg}");
        assert!(
            msg.contains("frame.png") && msg.ends_with("encoder gave up"),
            "{msg}"
        );
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(names(&d), vec!["frame.png".to_string()]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_parent_that_is_a_file_is_an_error_naming_the_destination() {
        let d = scratch("parent");
        std::fs::write(d.join("plain"), b"x").unwrap();
        let p = d.join("plain").join("r.png");
        let e = write_atomic(&p, b"data").unwrap_err();
        assert_eq!(e.path, p);
        assert_eq!(e.to_string().lines().count(), 1);
        assert_eq!(names(&d), vec!["plain".to_string()]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn write_via_a_path_syncs_renames_and_cleans_up() {
        let d = scratch("via");
        let p = d.join("v.mp4");
        write_atomic_via(&p, |tmp| {
            assert!(tmp.parent() == Some(d.as_path()));
            assert!(is_temporary_name(
                tmp.file_name().unwrap().to_str().unwrap()
            ));
            std::fs::write(tmp, b"movie")
        })
        .unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"movie");
        // A program that leaves a partial file and fails: nothing remains.
        let q = d.join("w.mp4");
        let e = write_atomic_via(&q, |tmp| {
            std::fs::write(tmp, b"mov")?;
            Err(io::Error::other("ffmpeg exited with 1"))
        })
        .unwrap_err();
        assert!(e.to_string().ends_with("ffmpeg exited with 1"));
        // A program that writes nothing: an error, not an empty file.
        assert!(write_atomic_via(&q, |_| Ok(())).is_err());
        assert_eq!(names(&d), vec!["v.mp4".to_string()]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn temporary_names_are_recognised() {
        assert!(is_temporary_name(".frame_00001.png.1234-0.tmp"));
        assert!(!is_temporary_name("frame_00001.png"));
        assert!(!is_temporary_name(".frame.png.tmp"));
        assert!(!is_temporary_name(".x.12a-3.tmp"));
    }
}
