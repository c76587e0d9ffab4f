//! Writing output safely: never a half-written file that looks complete, never two
//! processes writing one folder, never an output written over an input, never a run that
//! cannot fit on the disk.
//!
//! - [`Pending`]: a file written under a temporary name unique to the process
//!   (`<name>.<pid>-<n>.partial`) and renamed when complete; removed on every error path,
//!   on drop, and — through [`remove_all_pending`], which the command-line tool calls from
//!   its interrupt handler — on Ctrl-C or `kill`.
//! - [`FolderLock`]: an advisory lock on an output folder, released by the operating system
//!   when the process ends, however it ends.
//! - [`Staging`]: the files of one run written together into a hidden folder and moved
//!   into place only when all are complete, so a failed run leaves the previous one whole.
//! - [`refuse_same_file`] and [`check_free_space`]; [`at`] names the path and operation
//!   of every OS error.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Temporary files of this process not yet complete.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static SERIAL: AtomicU64 = AtomicU64::new(0);

fn registry() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(|e| e.into_inner())
}

/// Remove every temporary file and staging folder this process has not completed (for an
/// interrupt handler; the process is about to exit).
pub fn remove_all_pending() {
    for p in registry().drain(..) {
        if p.is_dir() {
            let _ = std::fs::remove_dir_all(p);
        } else {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// `e` with the path and the operation that met it: `creating folder out/x: File exists`.
pub fn at(path: &Path, operation: &str, e: std::io::Error) -> std::io::Error {
    std::io::Error::new(e.kind(), format!("{operation} {}: {e}", path.display()))
}

/// Prefix of the staging folders inside an output folder.
const STAGING: &str = ".fpkbench-staging-";

/// A set of files written together into one output folder (a run's log, report and
/// figures): each is written into a hidden staging folder inside it, and only when every
/// one is complete are they moved into place, and the previous run's files of the set
/// that this run did not write are removed. After any failure before that (a full disk,
/// an error, Ctrl-C, a kill) the folder holds the previous run's files untouched, never a
/// mix. Hold the folder's [`FolderLock`] while staging: a staging folder found at the
/// start is a dead process's and is removed.
#[derive(Debug)]
pub struct Staging {
    dir: PathBuf,
    staging: PathBuf,
}

impl Staging {
    /// Start staging into `dir` (created if missing).
    pub fn new(dir: &Path) -> std::io::Result<Staging> {
        std::fs::create_dir_all(dir).map_err(|e| at(dir, "creating the output folder", e))?;
        if let Ok(entries) = std::fs::read_dir(dir) {
            for e in entries.flatten() {
                if e.file_name().to_string_lossy().starts_with(STAGING) {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let staging = dir.join(format!(
            "{STAGING}{}-{}",
            std::process::id(),
            SERIAL.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir(&staging).map_err(|e| at(&staging, "creating the staging folder", e))?;
        registry().push(staging.clone());
        Ok(Staging {
            dir: dir.to_path_buf(),
            staging,
        })
    }

    /// Where to write the files (by their final names).
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The folder the files end up in.
    pub fn dest(&self) -> &Path {
        &self.dir
    }

    /// Move every staged file into the folder, and remove the files named in `set` that
    /// this run did not write (a previous run's figure that no longer applies); the final
    /// paths, in name order.
    pub fn commit(self, set: &[String]) -> std::io::Result<Vec<PathBuf>> {
        let mut names: Vec<std::ffi::OsString> = std::fs::read_dir(&self.staging)
            .map_err(|e| at(&self.staging, "reading the staging folder", e))?
            .map(|e| e.map(|e| e.file_name()))
            .collect::<Result<_, _>>()
            .map_err(|e| at(&self.staging, "reading the staging folder", e))?;
        names.sort();
        let mut out = Vec::new();
        for n in &names {
            let dest = self.dir.join(n);
            std::fs::rename(self.staging.join(n), &dest).map_err(|e| at(&dest, "moving into place", e))?;
            out.push(dest);
        }
        for stale in set.iter().filter(|s| !names.iter().any(|n| n == s.as_str())) {
            let p = self.dir.join(stale);
            match std::fs::remove_file(&p) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(at(&p, "removing the stale", e)),
                _ => {}
            }
        }
        Ok(out)
        // Drop removes the (now empty) staging folder.
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.staging);
        registry().retain(|p| p != &self.staging);
    }
}

/// A file being written to a temporary name beside its destination.
#[derive(Debug)]
pub struct Pending {
    tmp: PathBuf,
    dest: PathBuf,
}

impl Pending {
    /// Prepare to write `dest`: its folder is created, and `dest` must not be a directory.
    pub fn new(dest: &Path) -> std::io::Result<Pending> {
        if dest.is_dir() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "is a directory, not a file name",
            ));
        }
        if let Some(dir) = dest.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| at(dir, "creating the folder", e))?;
        }
        let mut name = dest.as_os_str().to_owned();
        name.push(format!(
            ".{}-{}.partial",
            std::process::id(),
            SERIAL.fetch_add(1, Ordering::Relaxed)
        ));
        let tmp = PathBuf::from(name);
        registry().push(tmp.clone());
        Ok(Pending {
            tmp,
            dest: dest.to_path_buf(),
        })
    }

    /// Where to write until [`commit`](Self::commit).
    pub fn path(&self) -> &Path {
        &self.tmp
    }

    /// The final name.
    pub fn dest(&self) -> &Path {
        &self.dest
    }

    /// Move the complete file to its final name (the temporary file is removed if that fails).
    pub fn commit(self) -> std::io::Result<()> {
        std::fs::rename(&self.tmp, &self.dest)
        // Drop removes the temporary file if the rename failed, and unregisters it.
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.tmp);
        registry().retain(|p| p != &self.tmp);
    }
}

/// Write `bytes` to `path` through a [`Pending`] file; errors name the file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let named = |e: std::io::Error| std::io::Error::new(e.kind(), format!("{}: {e}", path.display()));
    let p = Pending::new(path).map_err(named)?;
    std::fs::write(p.path(), bytes).map_err(named)?;
    p.commit().map_err(named)
}

/// An advisory lock on an output folder, held until dropped (or the process ends).
#[derive(Debug)]
pub struct FolderLock {
    _file: File,
}

impl FolderLock {
    /// Lock `dir` (created if missing) through its `.fpkbench.lock` file; refuses at once
    /// if another process holds it.
    pub fn acquire(dir: &Path) -> std::io::Result<FolderLock> {
        std::fs::create_dir_all(dir).map_err(|e| at(dir, "creating the output folder", e))?;
        let path = dir.join(".fpkbench.lock");
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(|e| at(&path, "opening the folder lock", e))?;
        match file.try_lock() {
            Ok(()) => Ok(FolderLock { _file: file }),
            Err(std::fs::TryLockError::WouldBlock) => Err(std::io::Error::new(
                std::io::ErrorKind::WouldBlock,
                format!(
                    "another fpkbench process is writing {} (it holds {}): wait for it to finish, \
                     or write elsewhere (-o / --out)",
                    dir.display(),
                    path.display()
                ),
            )),
            Err(std::fs::TryLockError::Error(e)) => Err(at(&path, "locking", e)),
        }
    }
}

/// Refuse to write `output` when it is the file `input` (under any name).
pub fn refuse_same_file(input: &Path, output: &Path) -> std::io::Result<()> {
    let same = match (std::fs::canonicalize(input), std::fs::canonicalize(output)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    if same {
        return Err(std::io::Error::new(
            std::io::ErrorKind::AlreadyExists,
            format!(
                "the output {} is the input {}: writing it would destroy the input; choose another output",
                output.display(),
                input.display()
            ),
        ));
    }
    Ok(())
}

/// Bytes free for an unprivileged user on the file system holding `dir` (or its nearest
/// existing ancestor); `None` where the platform does not say.
pub fn free_space(dir: &Path) -> Option<u64> {
    let mut d = dir;
    while !d.exists() {
        d = d.parent()?;
    }
    let d = if d.as_os_str().is_empty() { Path::new(".") } else { d };
    statvfs_available(d)
}

#[cfg(unix)]
fn statvfs_available(dir: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    let mut st = std::mem::MaybeUninit::<libc::statvfs>::uninit();
    // SAFETY: `c` is a valid NUL-terminated path and `st` a writable statvfs buffer.
    let rc = unsafe { libc::statvfs(c.as_ptr(), st.as_mut_ptr()) };
    if rc != 0 {
        return None;
    }
    // SAFETY: statvfs returned 0, so it filled `st`.
    let st = unsafe { st.assume_init() };
    // The field types differ between platforms (u32 on some).
    #[allow(clippy::unnecessary_cast)]
    Some((st.f_bavail as u64).saturating_mul(st.f_frsize as u64))
}

#[cfg(not(unix))]
fn statvfs_available(_dir: &Path) -> Option<u64> {
    None
}

/// Refuse to start writing about `bytes` under `dir` when the disk has less free space
/// (with a 5 % margin); the error says how much is needed and how to shorten.
pub fn check_free_space(dir: &Path, bytes: u64, what: &str) -> std::io::Result<()> {
    if let Some(free) = free_space(dir) {
        if bytes as f64 * 1.05 > free as f64 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::StorageFull,
                format!(
                    "{what} needs about {:.3} GB but only {:.3} GB are free under {}: shorten \
                     simulation.record_length, raise simulation.sample_interval, use fewer \
                     trajectories, or write elsewhere",
                    bytes as f64 / 1e9,
                    free as f64 / 1e9,
                    dir.display()
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_larger_than_the_free_disk_is_refused_with_both_sizes() {
        let dir = std::env::temp_dir();
        assert!(check_free_space(&dir, 1 << 20, "a small log").is_ok());
        if free_space(&dir).is_some() {
            let e = check_free_space(&dir, u64::MAX / 2, "the log").unwrap_err().to_string();
            assert!(
                e.contains("needs about") && e.contains("are free under") && e.contains("shorten"),
                "{e}"
            );
        }
    }

    #[test]
    fn pending_files_are_unique_and_removed_unless_committed() {
        let dir = tempfile::tempdir().unwrap();
        let dest = dir.path().join("x.txt");
        let (a, b) = (Pending::new(&dest).unwrap(), Pending::new(&dest).unwrap());
        assert_ne!(a.path(), b.path());
        std::fs::write(a.path(), "a").unwrap();
        std::fs::write(b.path(), "b").unwrap();
        drop(b);
        a.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&dest).unwrap(), "a");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
