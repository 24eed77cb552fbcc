//! Reading the files of one scene load within its [`LoadLimits`]: the one place where the
//! loaders touch the file system for reading.
//!
//! * The file type is checked on the path's metadata (following symbolic links) before the
//!   file is opened, and again on the open handle: a FIFO is refused without being opened
//!   (opening one for reading would wait for a writer), as are devices, sockets and
//!   directories.
//! * At most the declared size (a glTF buffer's `byteLength`) or the file's size at open
//!   time is read, through [`Read::take`], and never more than
//!   [`LoadLimits::max_file_bytes`]; a file that is larger, or declares more, is refused
//!   before a byte is read. The bytes of all files of one load count against
//!   [`LoadLimits::max_total_bytes`] (atomically: meshes and textures are read in parallel).
//! * Files the scene names must lie in the scene file's folder tree: the path is resolved
//!   (`..`, symbolic links) and compared with the folder's canonical path, unless
//!   [`LoadLimits::allow_outside_scene_dir`] is set. Refusals name the path, never the
//!   file's content.

use std::fs::{File, Metadata};
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::limits::LoadLimits;
use crate::error::{RenderError, Result};

/// The reading side of one scene load: its limits, the scene file and its folder, and the
/// bytes read so far.
#[derive(Debug)]
pub(crate) struct SceneFiles {
    limits: LoadLimits,
    /// The file the load started from.
    scene_file: PathBuf,
    /// Canonical folder of the scene file (`None` when it cannot be resolved: then nothing
    /// outside the scene file itself is read unless allowed).
    root: Option<PathBuf>,
    /// Bytes read so far by this load.
    total: AtomicU64,
}

/// What a non-regular file is, for messages.
fn kind_of(meta: &Metadata) -> &'static str {
    let ft = meta.file_type();
    if ft.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if ft.is_char_device() {
            return "a character device";
        }
        if ft.is_block_device() {
            return "a block device";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Refuses anything but a regular file.
fn check_regular(path: &Path, meta: &Metadata) -> Result<()> {
    if meta.is_file() {
        return Ok(());
    }
    Err(RenderError::Io {
        path: path.to_path_buf(),
        message: format!(
            "it is {}; only regular files are read as scene data",
            kind_of(meta)
        ),
    })
}

impl SceneFiles {
    /// The reader of a load that starts from `scene_file` (checks `limits`).
    pub(crate) fn new(scene_file: &Path, limits: &LoadLimits) -> Result<Self> {
        limits.validate()?;
        let folder = match scene_file.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        Ok(Self {
            limits: *limits,
            scene_file: scene_file.to_path_buf(),
            root: folder.canonicalize().ok(),
            total: AtomicU64::new(0),
        })
    }

    /// The limits in force.
    pub(crate) fn limits(&self) -> &LoadLimits {
        &self.limits
    }

    /// Checks that `path`, a file the scene names, lies in the scene file's folder tree (or
    /// that files outside it are allowed). A path that does not resolve (missing file) is an
    /// I/O error naming it.
    pub(crate) fn check_inside(&self, path: &Path) -> Result<()> {
        if self.limits.allow_outside_scene_dir {
            return Ok(());
        }
        let canonical = path.canonicalize().map_err(|e| RenderError::io(path, &e))?;
        match &self.root {
            Some(root) if canonical.starts_with(root) => Ok(()),
            root => Err(RenderError::BadInput {
                path: self.scene_file.clone(),
                what: format!(
                    "{} lies outside the scene's folder {}; files outside it are read only \
                     when LoadLimits::allow_outside_scene_dir is set",
                    path.display(),
                    root.as_deref()
                        .map_or_else(|| "(unresolved)".into(), |r| r.display().to_string())
                ),
            }),
        }
    }

    /// Opens `path` if it is a regular file: the handle and its size.
    fn open_regular(&self, path: &Path) -> Result<(File, u64)> {
        // Metadata first: a FIFO must not be opened (that would wait for a writer).
        let meta = std::fs::metadata(path).map_err(|e| RenderError::io(path, &e))?;
        check_regular(path, &meta)?;
        let file = File::open(path).map_err(|e| RenderError::io(path, &e))?;
        // Again on the handle, in case the path changed in between.
        let meta = file.metadata().map_err(|e| RenderError::io(path, &e))?;
        check_regular(path, &meta)?;
        Ok((file, meta.len()))
    }

    /// Counts `bytes` against the total of this load.
    fn reserve(&self, path: &Path, bytes: u64) -> Result<()> {
        let before = self.total.fetch_add(bytes, Ordering::Relaxed);
        let after = before.saturating_add(bytes);
        if after > self.limits.max_total_bytes {
            return Err(RenderError::ResourceLimit {
                what: format!(
                    "reading {} (all files of the scene together)",
                    path.display()
                ),
                needed: format!("{after} bytes"),
                limit: format!("max_total_bytes = {}", self.limits.max_total_bytes),
            });
        }
        Ok(())
    }

    /// Refuses a size above `max_file_bytes`; `declared` says whether the size is what the
    /// referring file declares.
    fn check_size(&self, path: &Path, bytes: u64, declared: bool) -> Result<()> {
        if bytes > self.limits.max_file_bytes {
            return Err(RenderError::ResourceLimit {
                what: format!("reading {}", path.display()),
                needed: format!(
                    "{bytes} bytes{}",
                    if declared { " (as declared)" } else { "" }
                ),
                limit: format!("max_file_bytes = {}", self.limits.max_file_bytes),
            });
        }
        Ok(())
    }

    /// Reads a regular file: at most `declared` bytes when given, else the whole file, within
    /// the limits. No containment check.
    fn read_bounded(&self, path: &Path, declared: Option<u64>) -> Result<Vec<u8>> {
        let (file, size) = self.open_regular(path)?;
        let want = match declared {
            Some(d) => {
                self.check_size(path, d, true)?;
                d.min(size)
            }
            None => {
                self.check_size(path, size, false)?;
                size
            }
        };
        self.reserve(path, want)?;
        let mut bytes = Vec::with_capacity(want as usize);
        file.take(want)
            .read_to_end(&mut bytes)
            .map_err(|e| RenderError::io(path, &e))?;
        Ok(bytes)
    }

    /// Reads the scene file itself (it may lie anywhere).
    pub(crate) fn read_scene_file(&self) -> Result<Vec<u8>> {
        self.read_bounded(&self.scene_file, None)
    }

    /// Reads a file the scene names: inside the scene's folder tree, a regular file, at most
    /// `declared` bytes when the scene declares its size.
    pub(crate) fn read(&self, path: &Path, declared: Option<u64>) -> Result<Vec<u8>> {
        self.check_inside(path)?;
        self.read_bounded(path, declared)
    }

    /// Opens a file the scene names for a streaming parser: checked like [`Self::read`], the
    /// reader stops at the file's size at open time.
    pub(crate) fn open(&self, path: &Path) -> Result<std::io::Take<File>> {
        self.check_inside(path)?;
        self.open_counted(path)
    }

    /// Opens the scene file itself for a streaming parser.
    pub(crate) fn open_scene_file(&self) -> Result<std::io::Take<File>> {
        self.open_counted(&self.scene_file.clone())
    }

    fn open_counted(&self, path: &Path) -> Result<std::io::Take<File>> {
        let (file, size) = self.open_regular(path)?;
        self.check_size(path, size, false)?;
        self.reserve(path, size)?;
        Ok(file.take(size))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused_and_sizes_are_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.obj");
        std::fs::write(&scene, b"0123456789").unwrap();
        let files = SceneFiles::new(&scene, &LoadLimits::default()).unwrap();
        assert_eq!(files.read_scene_file().unwrap(), b"0123456789");
        // At most the declared size.
        assert_eq!(files.read(&scene, Some(4)).unwrap(), b"0123");
        let e = files.read(dir.path(), None).unwrap_err().to_string();
        assert!(e.contains("directory"), "{e}");
        #[cfg(unix)]
        {
            let allowed = LoadLimits {
                allow_outside_scene_dir: true,
                ..Default::default()
            };
            let files = SceneFiles::new(&scene, &allowed).unwrap();
            let e = files
                .read(Path::new("/dev/zero"), None)
                .unwrap_err()
                .to_string();
            assert!(e.contains("character device"), "{e}");
        }
        let small = LoadLimits {
            max_file_bytes: 5,
            ..Default::default()
        };
        let files = SceneFiles::new(&scene, &small).unwrap();
        assert!(matches!(
            files.read_scene_file(),
            Err(RenderError::ResourceLimit { .. })
        ));
        let total = LoadLimits {
            max_total_bytes: 15,
            ..Default::default()
        };
        let files = SceneFiles::new(&scene, &total).unwrap();
        files.read_scene_file().unwrap();
        assert!(matches!(
            files.read(&scene, None),
            Err(RenderError::ResourceLimit { .. })
        ));
    }
}
