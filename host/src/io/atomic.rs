//! Atomic file output: write to a temporary file in the destination's folder, flush it to disk,
//! then rename it over the destination, so an interrupted run never leaves a half-written file.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The step of an atomic write that failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriteStep {
    /// Creating the destination's folder.
    CreateFolder,
    /// Creating the temporary file beside the destination.
    CreateTemporary,
    /// Writing or flushing the bytes.
    Write,
    /// Syncing the temporary file to disk.
    Sync,
    /// Renaming the finished temporary file over the destination.
    Rename,
}

impl std::fmt::Display for WriteStep {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            WriteStep::CreateFolder => "cannot create folder",
            WriteStep::CreateTemporary => "cannot create a temporary file",
            WriteStep::Write => "write failed",
            WriteStep::Sync => "sync failed",
            WriteStep::Rename => "cannot move the finished file into place",
        })
    }
}

/// An atomic write that failed; the destination keeps its previous content.
#[derive(Debug, thiserror::Error)]
#[error("{}: {step}", path.display())]
pub struct AtomicWriteError {
    /// The file (or, for [`WriteStep::CreateFolder`] and [`WriteStep::CreateTemporary`], the
    /// folder) the step failed on.
    pub path: PathBuf,
    /// The step that failed.
    pub step: WriteStep,
    /// The operating system's error.
    #[source]
    pub source: std::io::Error,
}

/// A folder that could not be created, with what it was for.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot create {what}", path.display())]
pub struct CreateFolderError {
    /// The folder.
    pub path: PathBuf,
    /// What it was for (`folder`, `checkpoint folder`, `output folder`).
    pub what: &'static str,
    /// The operating system's error.
    #[source]
    pub source: std::io::Error,
}

/// Creates the folder `path` and its parents; `what` says in the error what it was for.
pub fn create_folder(path: &Path, what: &'static str) -> Result<(), CreateFolderError> {
    std::fs::create_dir_all(path).map_err(|source| CreateFolderError {
        path: path.to_path_buf(),
        what,
        source,
    })
}

/// Maps an I/O error of `step` on `at` to an [`AtomicWriteError`].
fn fail(at: &Path, step: WriteStep) -> impl FnOnce(std::io::Error) -> AtomicWriteError + '_ {
    move |source| AtomicWriteError {
        path: at.to_path_buf(),
        step,
        source,
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write(path: &Path, bytes: &[u8]) -> Result<(), AtomicWriteError> {
    write_with(path, |f| f.write_all(bytes))
}

/// Writes to `path` atomically through `fill`, which gets a buffered writer.
pub fn write_with(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), AtomicWriteError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(fail(dir, WriteStep::CreateFolder))?;
    let mut builder = tempfile::Builder::new();
    builder.prefix(".sinew-tmp-");
    // A finished output is an ordinary file: readable by others as the umask allows, not the
    // owner-only mode a temporary file starts with.
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    let mut tmp = builder
        .tempfile_in(dir)
        .map_err(fail(dir, WriteStep::CreateTemporary))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w).map_err(fail(path, WriteStep::Write))?;
        w.flush().map_err(fail(path, WriteStep::Write))?;
    }
    tmp.as_file()
        .sync_all()
        .map_err(fail(path, WriteStep::Sync))?;
    tmp.persist(path)
        .map_err(|e| fail(path, WriteStep::Rename)(e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_whole_file_and_leaves_no_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/out.bin");
        write(&p, b"first version, longer").unwrap();
        write(&p, b"second").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"second");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&p).unwrap().permissions().mode();
            assert_ne!(
                mode & 0o044,
                0,
                "{mode:o}: the group or others cannot read it"
            );
        }
        let names: Vec<_> = std::fs::read_dir(p.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("out.bin")]);
    }

    #[test]
    fn failed_fill_keeps_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.bin");
        write(&p, b"old").unwrap();
        let err = write_with(&p, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("disk full"))
        });
        let err = err.unwrap_err();
        assert_eq!(err.step, WriteStep::Write);
        assert_eq!(err.path, p);
        assert!(err.to_string().contains("out.bin"));
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
    }
}
