//! Output files that are whole or absent: every command writes its files
//! under temporary names in the output directory and renames them into
//! place together at the end ([`Outputs::commit`]). A failed write (a full
//! disk, a file-size limit) removes what was staged; SIGINT, SIGTERM or
//! SIGHUP ([`install_signal_handler`]) removes it too and exits. A set of
//! outputs is never left half-written, and files from an earlier run are
//! only replaced by complete new ones. Each committed run lists its files
//! in [`MANIFEST`]; a run removes the files of the run before it that it
//! did not write again (a drive of 10 frames after one of 30 leaves 10), so
//! that a directory holds one run's outputs, never a mix. Files hilcam did
//! not write are never touched.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Temporary files staged by every live [`Outputs`], removed by the signal
/// handler. Held while an [`Outputs`] commits, so that a signal lands
/// either before the renames (nothing new in place) or after (all of it).
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Set when a signal arrives while [`graceful`] is on.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// Installs the handler for SIGINT, SIGTERM and SIGHUP: it removes every
/// staged file and exits with status 130. With [`graceful`] on, the first
/// signal only sets [`interrupted`] (the command finishes what it has and
/// stops); a second one exits.
pub fn install_signal_handler() -> Result<(), String> {
    ctrlc::set_handler(|| {
        if GRACEFUL.load(Ordering::SeqCst) && !INTERRUPTED.swap(true, Ordering::SeqCst) {
            return;
        }
        let staged = STAGED.lock().unwrap_or_else(|p| p.into_inner());
        for p in staged.iter() {
            let _ = std::fs::remove_file(p);
        }
        eprintln!("error: interrupted; nothing partial left behind");
        std::process::exit(130);
    })
    .map_err(|e| format!("signal handler: {e}"))
}

/// Lets the running command stop by itself at the first signal (see
/// [`interrupted`]) instead of exiting at once.
pub fn graceful(on: bool) {
    GRACEFUL.store(on, Ordering::SeqCst);
}

/// A signal arrived while [`graceful`] was on.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// The file naming a directory's outputs: one name a line, those of the
/// last run committed into it.
pub const MANIFEST: &str = "hilcam-outputs.txt";

/// A set of files being written into one directory.
pub struct Outputs {
    dir: PathBuf,
    staged: Vec<(PathBuf, PathBuf)>,
    /// Names already put in place by [`Outputs::write_now`].
    now: std::cell::RefCell<Vec<String>>,
    /// Paths of [`Outputs::scratch`].
    scratch: Vec<PathBuf>,
}

impl Outputs {
    /// Creates `dir` if needed and checks that a file can be created in it,
    /// before any work is done.
    pub fn prepare(dir: &Path) -> Result<Outputs, String> {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let mut o = Outputs {
            dir: dir.to_path_buf(),
            staged: Vec::new(),
            now: Default::default(),
            scratch: Vec::new(),
        };
        o.create(".probe")?;
        o.discard();
        Ok(o)
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Starts the file `name`: written under a temporary name until
    /// [`Outputs::commit`].
    pub fn create(&mut self, name: &str) -> Result<StagedFile, String> {
        let target = self.dir.join(name);
        let tmp = self.dir.join(format!(".{name}.partial-{}", std::process::id()));
        STAGED.lock().unwrap_or_else(|p| p.into_inner()).push(tmp.clone());
        self.staged.push((tmp.clone(), target.clone()));
        let f = File::create(&tmp).map_err(|e| format!("{}: {e}", target.display()))?;
        Ok(StagedFile { f, path: target })
    }

    /// A path in the directory for a file another program writes (QEMU's
    /// UART log) that is not an output: removed when these outputs are
    /// dropped or committed, and by the signal handler.
    pub fn scratch(&mut self, name: &str) -> PathBuf {
        let tmp = self.dir.join(format!(".{name}.scratch-{}", std::process::id()));
        STAGED.lock().unwrap_or_else(|p| p.into_inner()).push(tmp.clone());
        self.scratch.push(tmp.clone());
        tmp
    }

    /// Writes the whole file `name`.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<(), String> {
        self.create(name)?.write_all(bytes)
    }

    /// Writes the whole file `name` and renames it into place at once
    /// (for outputs that arrive one by one, like received frames).
    pub fn write_now(&self, name: &str, bytes: &[u8]) -> Result<(), String> {
        let mut one = Outputs {
            dir: self.dir.clone(),
            staged: Vec::new(),
            now: Default::default(),
            scratch: Vec::new(),
        };
        one.write(name, bytes)?;
        one.rename_into_place()?;
        self.now.borrow_mut().push(name.to_string());
        Ok(())
    }

    /// Syncs every staged file to disk and renames them into place; then
    /// removes what the directory's previous run wrote and this one did
    /// not, and lists this run's files in [`MANIFEST`]. On an error the
    /// files not yet renamed are removed.
    pub fn commit(mut self) -> Result<(), String> {
        let mut names: Vec<String> = self.now.borrow().clone();
        names.extend(
            self.staged
                .iter()
                .filter_map(|(_, t)| t.file_name()?.to_str().map(str::to_string)),
        );
        self.rename_into_place()?;
        let manifest = self.dir.join(MANIFEST);
        if let Ok(old) = std::fs::read_to_string(&manifest) {
            for stale in old.lines().filter(|n| !n.starts_with('#') && !names.iter().any(|m| m == n)) {
                // Only plain names this crate wrote into this directory.
                if !stale.is_empty() && !stale.contains('/') && stale != MANIFEST {
                    let _ = std::fs::remove_file(self.dir.join(stale));
                }
            }
        }
        let mut list = String::from("# the files of the last hilcam run in this directory\n");
        for n in &names {
            list.push_str(n);
            list.push('\n');
        }
        let mut m = Outputs {
            dir: self.dir.clone(),
            staged: Vec::new(),
            now: Default::default(),
            scratch: Vec::new(),
        };
        m.write(MANIFEST, list.as_bytes())?;
        m.rename_into_place()
    }

    /// Syncs every staged file to disk and renames them into place. On an
    /// error the files not yet renamed are removed.
    fn rename_into_place(&mut self) -> Result<(), String> {
        for (tmp, target) in &self.staged {
            File::open(tmp)
                .and_then(|f| f.sync_all())
                .map_err(|e| format!("{}: {e}", target.display()))?;
        }
        let mut staged = STAGED.lock().unwrap_or_else(|p| p.into_inner());
        let files = std::mem::take(&mut self.staged);
        let mut result = Ok(());
        for (tmp, target) in &files {
            if result.is_ok() {
                result = std::fs::rename(tmp, target).map_err(|e| format!("{}: {e}", target.display()));
            }
            if result.is_err() {
                let _ = std::fs::remove_file(tmp);
            }
            staged.retain(|p| p != tmp);
        }
        result
    }

    /// Removes every staged file (and every scratch file).
    pub fn discard(&mut self) {
        let mut staged = STAGED.lock().unwrap_or_else(|p| p.into_inner());
        let scratch = self.scratch.drain(..).map(|p| (p, PathBuf::new()));
        for (tmp, _) in self.staged.drain(..).chain(scratch) {
            let _ = std::fs::remove_file(&tmp);
            staged.retain(|p| *p != tmp);
        }
    }
}

impl Drop for Outputs {
    fn drop(&mut self) {
        self.discard();
    }
}

/// A file being written (unbuffered: every write error is seen where it
/// happens; callers buffer or write large pieces).
pub struct StagedFile {
    f: File,
    path: PathBuf,
}

impl StagedFile {
    /// Appends bytes. Errors name the file.
    pub fn write_all(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.f
            .write_all(bytes)
            .map_err(|e| format!("{}: {e}", self.path.display()))
    }
}

impl Write for StagedFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.f.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}
