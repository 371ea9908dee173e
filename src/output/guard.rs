//! Guards at the file boundary: bounded reads of input files, and one lock per result
//! directory so two commands never write the same results at once.

use std::io::Read;
use std::path::{Path, PathBuf};

use crate::{Error, Result};

/// Largest text input (study, materials and species files) magopt reads, bytes.
pub const MAX_TEXT_INPUT: u64 = 4 << 20;

/// Reads a text file of at most `limit` bytes; a larger file, a device or a FIFO is an input
/// error naming the file and the limit (never an unbounded read).
pub fn read_text_limited(path: &Path, limit: u64, what: &str) -> Result<String> {
    String::from_utf8(read_limited(path, limit, what)?)
        .map_err(|_| Error::input(format!("{what} '{}' is not UTF-8 text", path.display())))
}

/// Reads a file of at most `limit` bytes (see [`read_text_limited`]).
pub fn read_limited(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>> {
    let shown = path.display();
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::input(format!(
            "{what} '{shown}' is not a regular file"
        )));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut bytes))
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(Error::input(format!(
            "{what} '{shown}' is larger than {} MiB (the limit for this kind of file)",
            limit >> 20
        )));
    }
    Ok(bytes)
}

/// A result directory held by this process: `DIR/.magopt.lock` holds its process id (and,
/// for a shard's lock, a note after it) and is removed when the lock is dropped. A lock left
/// by a process that no longer runs is taken over.
#[derive(Debug)]
pub struct DirLock {
    path: PathBuf,
}

impl DirLock {
    /// Takes the lock of `dir` (which must exist), or says which process holds it.
    pub fn acquire(dir: &Path) -> Result<Self> {
        Self::acquire_named(dir, ".magopt.lock", "")
    }

    /// Takes the lock file `name` in `dir` (shards of one optimization each hold their own),
    /// writing `note` (one word, see [`lock_note`]) after the process id.
    pub fn acquire_named(dir: &Path, name: &str, note: &str) -> Result<Self> {
        let path = dir.join(name);
        for _ in 0..2 {
            let created = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path);
            match created {
                Ok(mut file) => {
                    use std::io::Write;
                    // one write, so that a reader sees all of it or nothing
                    let text = format!("{} {note}", std::process::id());
                    let _ = file.write_all(text.trim_end().as_bytes());
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let holder = read_lock(&path);
                    match holder.split_whitespace().next().map(str::parse::<u32>) {
                        Some(Ok(pid)) if alive(pid) => {
                            return Err(Error::input(format!(
                                "'{}' is in use by magopt process {pid} (lock {}): wait for it \
                                 to finish, or choose another --out",
                                dir.display(),
                                path.display()
                            )))
                        }
                        // the holder is gone (killed): take the lock over
                        _ => {
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(e) => return Err(Error::io(&path, e)),
            }
        }
        Err(Error::input(format!(
            "'{}': could not take the lock {}",
            dir.display(),
            path.display()
        )))
    }
}

impl DirLock {
    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// A lock file's text (empty if it cannot be read; at most 4 KiB are read).
fn read_lock(path: &Path) -> String {
    read_text_limited(path, 4096, "lock").unwrap_or_default()
}

/// The note a lock file carries after its process id, if any.
pub fn lock_note(path: &Path) -> Option<String> {
    read_lock(path)
        .split_whitespace()
        .nth(1)
        .map(str::to_string)
}

/// Keeps a lock file's modification time fresh (every [`HEARTBEAT`]) while it lives, so that
/// processes on other machines sharing the directory can tell a running holder from a dead
/// one (a process id means nothing across machines).
#[derive(Debug)]
pub struct Heartbeat {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// How often a [`Heartbeat`] touches its file.
pub const HEARTBEAT: std::time::Duration = std::time::Duration::from_secs(5);

impl Heartbeat {
    /// Starts touching `path`.
    pub fn start(path: &Path) -> Self {
        use std::sync::atomic::Ordering;
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let (flag, path) = (stop.clone(), path.to_path_buf());
        let thread = std::thread::spawn(move || {
            while !flag.load(Ordering::Relaxed) {
                if let Ok(file) = std::fs::OpenOptions::new().append(true).open(&path) {
                    let _ = file.set_modified(std::time::SystemTime::now());
                }
                std::thread::park_timeout(HEARTBEAT);
            }
        });
        Self {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Heartbeat {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            t.thread().unpark();
            let _ = t.join();
        }
    }
}

/// Seconds since `path` was last modified (None if it does not exist).
pub fn age_s(path: &Path) -> Option<f64> {
    let modified = std::fs::metadata(path).and_then(|m| m.modified()).ok()?;
    Some(
        std::time::SystemTime::now()
            .duration_since(modified)
            .map_or(0.0, |d| d.as_secs_f64()),
    )
}

impl Drop for DirLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Whether a process with this id runs (Linux: /proc; elsewhere assumed alive).
fn alive(pid: u32) -> bool {
    if cfg!(target_os = "linux") {
        Path::new(&format!("/proc/{pid}")).exists()
    } else {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_on_a_directory_is_refused_and_a_dead_holder_is_replaced() {
        let dir = std::env::temp_dir().join(format!("magopt-lock-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let lock = DirLock::acquire(&dir).unwrap();
        let e = DirLock::acquire(&dir).unwrap_err().to_string();
        assert!(e.contains("in use by magopt process"), "{e}");
        drop(lock);
        // a lock file naming a process that does not exist is taken over
        std::fs::write(dir.join(".magopt.lock"), "4294967295").unwrap();
        let again = DirLock::acquire(&dir).unwrap();
        drop(again);
        assert!(!dir.join(".magopt.lock").exists());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn reads_are_bounded_and_devices_refused() {
        let e = read_text_limited(Path::new("/dev/zero"), 1024, "study file")
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a regular file"), "{e}");
        let file = std::env::temp_dir().join(format!("magopt-big-{}", std::process::id()));
        std::fs::write(&file, vec![b'a'; 3 << 20]).unwrap();
        let e = read_text_limited(&file, 1 << 20, "study file")
            .unwrap_err()
            .to_string();
        assert!(e.contains("larger than 1 MiB"), "{e}");
        std::fs::remove_file(file).ok();
    }
}
