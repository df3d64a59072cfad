//! Result files written whole or not at all: a file is written under a temporary name in
//! its own folder and renamed into place when complete, so a reader (or a run killed
//! halfway) never sees half a `summary.json`, plot, network or checkpoint, and an older
//! file stays whole until the new one replaces it.
//!
//! The temporary name is `.<name>.<pid>.partial<.ext>`: hidden, in the same folder (a
//! rename within one file system is atomic), and ending in the final extension, because a
//! plotting back-end picks the image format from it. A write that fails or panics removes
//! its temporary file; a killed process leaves it behind, under a name no reader opens.

use std::io;
use std::path::{Path, PathBuf};

/// A file being written: write to [`AtomicFile::path`], then [`AtomicFile::commit`].
/// Dropped uncommitted, it removes what was written.
///
/// ```
/// # fn main() -> std::io::Result<()> {
/// use ghm::report::atomic::AtomicFile;
///
/// let dir = std::env::temp_dir().join(format!("ghm-doc-atomic-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let path = dir.join("summary.json");
/// std::fs::write(&path, "old")?;
/// let file = AtomicFile::new(&path);
/// std::fs::write(file.path(), "new")?;
/// assert_eq!(std::fs::read_to_string(&path)?, "old"); // not yet in place
/// file.commit()?;
/// assert_eq!(std::fs::read_to_string(&path)?, "new");
/// assert_eq!(std::fs::read_dir(&dir)?.count(), 1); // no temporary file left
/// std::fs::remove_dir_all(&dir)?;
/// # Ok(())
/// # }
/// ```
#[derive(Debug)]
pub struct AtomicFile {
    temporary: PathBuf,
    target: PathBuf,
    committed: bool,
}

impl AtomicFile {
    /// A file to be written at `target`, through a temporary file beside it.
    pub fn new(target: &Path) -> AtomicFile {
        AtomicFile {
            temporary: temporary_path(target),
            target: target.to_path_buf(),
            committed: false,
        }
    }

    /// Where to write the contents.
    pub fn path(&self) -> &Path {
        &self.temporary
    }

    /// Flushes the temporary file to disk and renames it to the target, replacing any file
    /// there.
    pub fn commit(mut self) -> io::Result<()> {
        std::fs::File::open(&self.temporary)?.sync_all()?;
        std::fs::rename(&self.temporary, &self.target)?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

/// The temporary name of `target`: `.<stem>.<pid>.partial.<ext>` in its folder.
fn temporary_path(target: &Path) -> PathBuf {
    let stem = target
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = target
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let name = format!(".{stem}.{}.partial{ext}", std::process::id());
    target.with_file_name(name)
}

/// Writes `contents` to `path` atomically (see the [module documentation](self)).
pub fn write(path: &Path, contents: impl AsRef<[u8]>) -> io::Result<()> {
    let file = AtomicFile::new(path);
    std::fs::write(file.path(), contents)?;
    file.commit()
}

/// Whether `name` is the temporary name of a file being written (by this or another
/// process).
pub fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.contains(".partial")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dropped_write_leaves_the_old_file_and_no_temporary() {
        let dir = std::env::temp_dir().join(format!("ghm-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("trajectory.png");
        write(&path, "old").unwrap();
        {
            let file = AtomicFile::new(&path);
            assert!(file.path().to_string_lossy().ends_with(".png"));
            std::fs::write(file.path(), "half").unwrap();
        }
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["trajectory.png"]);
        assert!(is_temporary(
            &temporary_path(&path).file_name().unwrap().to_string_lossy()
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
