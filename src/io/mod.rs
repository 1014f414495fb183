//! Files <-> signals: WAV (hound) and CSV readers and writers, the sidecar, and atomic output.

pub mod csv;
pub mod sidecar;
pub mod wav;

use std::borrow::Cow;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Errors of the file layer.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// OS-level failure.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: String,
        /// What failed.
        message: String,
    },
    /// Content that cannot be used, with where it is.
    #[error("{path}: {message}")]
    Format {
        /// File.
        path: String,
        /// What is wrong and where (line, field).
        message: String,
    },
}

impl DataError {
    pub(crate) fn io(path: &Path, e: impl std::fmt::Display) -> Self {
        Self::Io { path: path.display().to_string(), message: e.to_string() }
    }
    pub(crate) fn format(path: &Path, message: impl Into<String>) -> Self {
        Self::Format { path: path.display().to_string(), message: message.into() }
    }
}

/// Identity of a file: (device, inode) on Unix, the canonical path elsewhere.
#[derive(Clone, Debug, PartialEq, Eq)]
enum FileId {
    #[cfg(unix)]
    Inode(u64, u64),
    #[cfg(not(unix))]
    Path(PathBuf),
}

fn file_id(path: &Path) -> Option<FileId> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        let m = std::fs::metadata(path).ok()?;
        Some(FileId::Inode(m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        std::fs::canonicalize(path).ok().map(FileId::Path)
    }
}

/// Every file this process has read as an input; outputs are checked against them.
static INPUTS: std::sync::Mutex<Vec<(FileId, PathBuf)>> = std::sync::Mutex::new(Vec::new());

/// Starts a new run: forgets the inputs of the previous one (a library user calling several jobs in one
/// process may well write one job's output over an earlier job's input).
pub fn begin_run() {
    INPUTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clear();
}

/// Records `path` as an input of this run: no output may then replace it (by name, symlink or hard link).
pub fn register_input(path: &Path) {
    if let Some(id) = file_id(path) {
        let mut inputs = INPUTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if !inputs.iter().any(|(i, _)| *i == id) {
            inputs.push((id, path.to_path_buf()));
        }
    }
}

/// Refuses an output path that is one of this run's inputs.
///
/// # Errors
/// [`DataError::Io`] naming both paths.
pub fn check_output(dest: &Path) -> Result<(), DataError> {
    let Some(id) = file_id(dest) else { return Ok(()) }; // a file that does not exist is no input
    let inputs = INPUTS.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    match inputs.iter().find(|(i, _)| *i == id) {
        Some((_, input)) => Err(DataError::io(
            dest,
            format!("refusing to overwrite an input of this run ({}): choose another output path", input.display()),
        )),
        None => Ok(()),
    }
}

/// Temporary files of this process not yet renamed into place (removed on SIGINT, SIGTERM, SIGHUP).
static TEMPS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// What the binary runs once before this process creates its first temporary file (its signal handler):
/// a run that writes no file (most `simulate` and `diagnose` calls) then starts no handler thread, and a
/// host that embeds the library (the Python bindings) keeps its own handlers.
static BEFORE_FIRST_TEMP: std::sync::OnceLock<fn()> = std::sync::OnceLock::new();
static FIRST_TEMP: std::sync::Once = std::sync::Once::new();

/// Sets the hook [`prepare_temporaries`] runs once (the binary installs its SIGINT/SIGTERM/SIGHUP handler
/// there); a second call is ignored.
pub fn before_first_temporary(hook: fn()) {
    let _ = BEFORE_FIRST_TEMP.set(hook);
}

/// Runs the hook of [`before_first_temporary`] the first time it is called: call it before creating a
/// temporary file, so that an interrupt from then on removes it.
pub fn prepare_temporaries() {
    FIRST_TEMP.call_once(|| {
        if let Some(hook) = BEFORE_FIRST_TEMP.get() {
            hook();
        }
    });
}

/// Records a temporary file that [`remove_temporaries`] must delete if the process is interrupted.
pub fn register_temp(path: &Path) {
    prepare_temporaries();
    TEMPS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(path.to_path_buf());
}

/// Forgets a temporary file (renamed into place or removed).
pub fn unregister_temp(path: &Path) {
    TEMPS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).retain(|p| p != path);
}

/// Deletes every temporary file still open: called from the binary's signal handler.
pub fn remove_temporaries() {
    for p in TEMPS.lock().unwrap_or_else(std::sync::PoisonError::into_inner).drain(..) {
        let _ = std::fs::remove_file(p);
    }
}

/// Removes `NAME.<pid>.tmp` siblings of `dest` left by processes that no longer run (a killed run; on
/// Linux, where /proc tells which processes live).
fn sweep_stale_temps(dest: &Path) {
    let (Some(dir), Some(name)) = (dest.parent(), dest.file_name().and_then(|n| n.to_str())) else { return };
    let dir = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(name)).and_then(|r| r.strip_prefix('.')) else {
            continue;
        };
        let pid = rest.strip_suffix(".tmp").or_else(|| rest.strip_suffix(".tmp.png"));
        if let Some(pid) = pid.and_then(|p| p.parse::<u32>().ok()) {
            if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
}

/// A file being written under a temporary name next to its destination; `commit` renames it into place,
/// dropping it without `commit` removes it (no half-written output is ever left under the final name).
pub struct AtomicFile {
    tmp: PathBuf,
    dest: PathBuf,
    done: bool,
}

impl AtomicFile {
    /// Reserves `dest`, writing to `dest.<pid>.tmp`.
    ///
    /// # Errors
    /// `dest` is an input of this run ([`check_output`]), or the temporary file cannot be created (missing
    /// directory, no permission).
    pub fn create(dest: &Path) -> Result<(Self, std::fs::File), DataError> {
        check_output(dest)?;
        sweep_stale_temps(dest);
        let mut name = dest.file_name().map(|n| n.to_os_string()).unwrap_or_default();
        name.push(format!(".{}.tmp", std::process::id()));
        let tmp = dest.with_file_name(name);
        prepare_temporaries();
        let file = std::fs::File::create(&tmp).map_err(|e| DataError::io(dest, format!("cannot write: {e}")))?;
        register_temp(&tmp);
        Ok((Self { tmp, dest: dest.to_path_buf(), done: false }, file))
    }

    /// Path of the temporary file.
    pub fn temp_path(&self) -> &Path {
        &self.tmp
    }

    /// Renames the finished temporary file to its destination.
    ///
    /// # Errors
    /// The rename fails.
    pub fn commit(mut self) -> Result<(), DataError> {
        std::fs::rename(&self.tmp, &self.dest).map_err(|e| DataError::io(&self.dest, e))?;
        unregister_temp(&self.tmp);
        self.done = true;
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.done {
            let _ = std::fs::remove_file(&self.tmp);
            unregister_temp(&self.tmp);
        }
    }
}

/// Writes `bytes` to a temporary file for `dest`, not yet renamed: commit the guard to put it in place.
///
/// # Errors
/// Creating or writing fails.
pub fn write_uncommitted(dest: &Path, bytes: &[u8]) -> Result<AtomicFile, DataError> {
    let (guard, mut f) = AtomicFile::create(dest)?;
    f.write_all(bytes).and_then(|_| f.sync_all()).map_err(|e| DataError::io(dest, e))?;
    Ok(guard)
}

/// Writes `bytes` to `dest` atomically.
///
/// # Errors
/// Creating, writing or renaming fails.
pub fn write_atomic(dest: &Path, bytes: &[u8]) -> Result<(), DataError> {
    let (guard, mut f) = AtomicFile::create(dest)?;
    f.write_all(bytes).and_then(|_| f.sync_all()).map_err(|e| DataError::io(dest, e))?;
    drop(f);
    guard.commit()
}

/// Multi-channel signal: read from a file (each channel owned), or lent by a caller that holds the samples
/// (the Python bindings' numpy arrays: no copy).
#[derive(Clone, Debug)]
pub struct Recording<'a> {
    /// Channels of samples (as stored: physical units for float/CSV, integer WAV scaled to [-1, 1); a channel
    /// not asked for is empty), kept as f32 so that a long multi-channel recording needs about the memory of
    /// its file. A lent channel is copied only where it must change (`--sensitivity`).
    pub channels: Vec<Cow<'a, [f32]>>,
    /// Sample rate in Hz (`None` when a CSV has no time column and none was given).
    pub sample_rate_hz: Option<f64>,
    /// Channel names (CSV header or "ch1", ...).
    pub names: Vec<String>,
    /// Physical unit of each channel when known (from gearvib's sidecar), else empty.
    pub units: Vec<String>,
    /// What the reader noticed and the analysis should report (a foreign sidecar ignored, a sidecar whose
    /// sample rate or frame count disagrees with the file).
    pub warnings: Vec<String>,
}

impl Recording<'_> {
    /// The same recording with every channel lent from this one (no sample copied).
    pub fn lent(&self) -> Recording<'_> {
        Recording {
            channels: self.channels.iter().map(|c| Cow::Borrowed(&**c)).collect(),
            sample_rate_hz: self.sample_rate_hz,
            names: self.names.clone(),
            units: self.units.clone(),
            warnings: self.warnings.clone(),
        }
    }
}

/// Reads a WAV or CSV file by its extension.
///
/// # Errors
/// [`DataError`] naming the file and what is wrong.
pub fn read_recording(path: &Path) -> Result<Recording<'static>, DataError> {
    read_recording_channels(path, None)
}

/// [`read_recording`] keeping only the 0-based channels in `keep` (WAV: the others are not even decoded and
/// stay empty; CSV: all are parsed, the others dropped).
///
/// # Errors
/// As [`read_recording`].
pub fn read_recording_channels(path: &Path, keep: Option<&[usize]>) -> Result<Recording<'static>, DataError> {
    register_input(path);
    register_input(&sidecar::path_of(path));
    // a pipe would block the read and a device never end (the readers' bounds are for files)
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        return Err(DataError::io(path, "not a regular file (a device, pipe or directory)"));
    }
    match extension(path).as_deref() {
        Some("wav") => {
            // the sidecar first: a device or a damaged one is refused before the signal is read
            let side = sidecar::read(path)?;
            let mut rec = wav::read_channels(path, keep)?;
            apply_sidecar(path, side, &mut rec)?;
            Ok(rec)
        }
        Some("csv") | Some("txt") | Some("tsv") => {
            let mut rec = csv::read(path)?;
            if let Some(k) = keep {
                for (i, c) in rec.channels.iter_mut().enumerate() {
                    if !k.contains(&i) {
                        *c = Cow::Owned(Vec::new());
                    }
                }
            }
            Ok(rec)
        }
        _ if path.as_os_str() == "-" => Err(DataError::format(
            path,
            "a recording is not read from standard input (its sample rate, sidecar and size are a file's): save it as a .wav or .csv file and give its path",
        )),
        _ => Err(DataError::format(path, "unknown extension: expected .wav or .csv")),
    }
}

/// Lower-case extension.
pub fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// An integer WAV written by gearvib stores value / full_scale; its sidecar `FILE.json` states
/// `full_scale`, which restores physical units, and names the channels. A sidecar whose sample rate or
/// frame count disagrees with the WAV is warned about (the WAV's header is used); a foreign JSON file of
/// the sidecar's name leaves the samples as read, with its warning.
///
/// # Errors
/// A `full_scale` that is not a positive number whose scaled samples stay within 32-bit float range.
fn apply_sidecar(path: &Path, found: sidecar::Found, rec: &mut Recording<'_>) -> Result<(), DataError> {
    let side = match found {
        sidecar::Found::None => return Ok(()),
        sidecar::Found::Foreign(w) => {
            rec.warnings.push(w);
            return Ok(());
        }
        sidecar::Found::Sidecar(s) => *s,
    };
    let side_path = sidecar::path_of(path);
    if let Some(fs) = side.full_scale {
        // integer samples are in [-1, 1]: any positive full scale up to f32::MAX keeps them finite
        if !(fs.is_finite() && fs > 0.0 && fs <= f64::from(f32::MAX)) {
            return Err(DataError::format(
                &side_path,
                format!("full_scale {fs:e}: a full scale is a positive number within 32-bit float range"),
            ));
        }
        for c in &mut rec.channels {
            if !c.is_empty() {
                c.to_mut().iter_mut().for_each(|x| *x = (f64::from(*x) * fs) as f32);
            }
        }
    }
    if let Some(header) = rec.sample_rate_hz {
        if !(side.sample_rate_hz.is_finite() && (side.sample_rate_hz - header).abs() <= 1e-6 * header) {
            rec.warnings.push(format!(
                "{}: the sidecar states a sample rate of {} Hz, the WAV header {header} Hz: the header's rate is used; check which is right",
                side_path.display(),
                // a damaged rate of 1e300 printed as 300 digits
                if side.sample_rate_hz == 0.0 || (1e-3..1e9).contains(&side.sample_rate_hz.abs()) {
                    side.sample_rate_hz.to_string()
                } else {
                    format!("{:e}", side.sample_rate_hz)
                }
            ));
        }
    }
    let frames = rec.channels.iter().map(|c| c.len()).max().unwrap_or(0) as u64;
    if side.frames != frames {
        rec.warnings.push(format!(
            "{}: the sidecar states {} frames, the WAV holds {frames}: the file may be truncated or not the one the sidecar describes",
            side_path.display(),
            side.frames
        ));
    }
    if side.channels.len() != rec.channels.len() {
        rec.warnings.push(format!(
            "{}: the sidecar names {} channel(s), the WAV holds {}: names and units are taken in order",
            side_path.display(),
            side.channels.len(),
            rec.channels.len()
        ));
    }
    for (name, c) in rec.names.iter_mut().zip(&side.channels) {
        name.clone_from(&c.name);
    }
    rec.units = side.channels.iter().map(|c| c.unit.clone()).collect();
    rec.units.resize(rec.names.len(), String::new());
    Ok(())
}

/// A signal file being written under a temporary name, by its extension: a WAV (`.wav`) or a CSV with a
/// time column (`.csv`).
pub enum SignalOut {
    /// A WAV file (float or integer samples).
    Wav(wav::WavOut),
    /// A CSV file with headers "name [unit]".
    Csv(csv::CsvOut),
}

impl SignalOut {
    /// Creates `path` for `channels` at `fs` Hz: a WAV in `format` (its rate is `fs` in whole Hz) or a CSV
    /// whose headers name each channel with its unit in brackets.
    ///
    /// # Errors
    /// An extension other than .wav or .csv, more than 65535 WAV channels, the file cannot be created.
    pub fn create(
        path: &Path,
        channels: &[sidecar::ChannelInfo],
        fs: f64,
        format: wav::WavSampleFormat,
    ) -> Result<Self, DataError> {
        match extension(path).as_deref() {
            Some("wav") => {
                let nch =
                    u16::try_from(channels.len()).map_err(|_| DataError::format(path, "more than 65535 channels"))?;
                Ok(Self::Wav(wav::WavOut::create(path, nch, fs as u32, format)?))
            }
            Some("csv") => {
                let names: Vec<String> = channels
                    .iter()
                    .map(|c| if c.unit.is_empty() { c.name.clone() } else { format!("{} [{}]", c.name, c.unit) })
                    .collect();
                Ok(Self::Csv(csv::CsvOut::create(path, &names, fs)?))
            }
            _ => Err(DataError::format(path, "unknown extension: expected .wav or .csv")),
        }
    }

    /// Appends interleaved frames.
    ///
    /// # Errors
    /// Writing fails.
    pub fn write(&mut self, interleaved: &[f64]) -> Result<(), DataError> {
        match self {
            Self::Wav(w) => w.write(interleaved),
            Self::Csv(c) => c.write(interleaved),
        }
    }

    /// Finishes the file, still under its temporary name: the guard that puts it in place and the samples
    /// clipped at integer full scale (0 for float WAV and CSV).
    ///
    /// # Errors
    /// Flushing fails.
    pub fn finish(self) -> Result<(AtomicFile, u64), DataError> {
        match self {
            Self::Wav(w) => w.finish(),
            Self::Csv(c) => Ok((c.finish()?, 0)),
        }
    }
}

/// Puts a finished signal and its sidecar `info` in place as a pair: both temporaries written, then the
/// signal renamed and the sidecar last; a sidecar that cannot be put in place takes the signal with it (an
/// integer WAV without its full scale would read wrong).
///
/// # Errors
/// Either file cannot be written or renamed.
pub fn commit_with_sidecar(path: &Path, signal: AtomicFile, info: &sidecar::Sidecar) -> Result<(), DataError> {
    let side = sidecar::write(path, info)?;
    signal.commit()?;
    side.commit().inspect_err(|_| {
        let _ = std::fs::remove_file(path);
    })
}

/// Writes `rec` to `path` by its extension, atomically: a float WAV (f32, the sample rate must be a whole
/// number of Hz) with a sidecar `path.json` naming each channel and its unit, or a CSV with a `time_s`
/// column and headers "name [unit]". [`read_recording`] gives the same samples, names and units back.
///
/// # Errors
/// No channel, channels of different lengths or empty, no or a bad sample rate, a WAV rate that is not a
/// whole number, an unknown extension, an output that is an input of this run, or the write failing.
pub fn write_recording(path: &Path, rec: &Recording<'_>) -> Result<(), DataError> {
    let frames = rec.channels.first().map_or(0, |c| c.len());
    if frames == 0 || rec.channels.iter().any(|c| c.len() != frames) {
        return Err(DataError::format(path, "a recording to write needs channels of one length, at least one sample"));
    }
    let fs = rec
        .sample_rate_hz
        .filter(|f| f.is_finite() && *f > 0.0)
        .ok_or_else(|| DataError::format(path, "a recording to write needs a positive sample rate in Hz"))?;
    let channels: Vec<sidecar::ChannelInfo> = (0..rec.channels.len())
        .map(|c| sidecar::ChannelInfo {
            name: rec.names.get(c).cloned().unwrap_or_else(|| format!("ch{}", c + 1)),
            unit: rec.units.get(c).cloned().unwrap_or_default(),
            description: String::new(),
        })
        .collect();
    let is_wav = extension(path).as_deref() == Some("wav");
    let rate = if is_wav {
        if (fs.round() - fs).abs() > 1e-9 * fs || fs.round() > f64::from(u32::MAX) {
            return Err(DataError::format(path, format!("a WAV stores a whole number of Hz, not {fs}: write a .csv")));
        }
        fs.round()
    } else {
        if let Some(c) = channels.iter().position(|c| (c.name.clone() + &c.unit).contains([',', '\n', '\r', '"'])) {
            return Err(DataError::format(
                path,
                format!("channel {} name or unit holds a comma, quote or line break", c + 1),
            ));
        }
        fs
    };
    let mut out = SignalOut::create(path, &channels, rate, wav::WavSampleFormat::Float32)?;
    // frames interleaved a block at a time: the memory of one block, not of the recording
    let mut buf = Vec::with_capacity(channels.len() * 65536);
    for start in (0..frames).step_by(65536) {
        buf.clear();
        for i in start..(start + 65536).min(frames) {
            buf.extend(rec.channels.iter().map(|c| f64::from(c[i])));
        }
        out.write(&buf)?;
    }
    let (guard, _) = out.finish()?;
    if !is_wav {
        return guard.commit();
    }
    let info = sidecar::Sidecar {
        file: path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        scene: String::new(),
        scene_file: String::new(),
        sample_rate_hz: fs,
        frames: frames as u64,
        duration_s: frames as f64 / fs,
        channels,
        format: "f32".into(),
        full_scale: None,
        clipped_samples: 0,
        noise_rms: 0.0,
        seed: 0,
        speed_change: None,
        base_hz: 0.0,
        period_s: 0.0,
        evaluation: "samples as given (write_recording)".into(),
        warnings: Vec::new(),
    };
    commit_with_sidecar(path, guard, &info)
}

/// Creates a directory (and its parents) for outputs.
///
/// # Errors
/// The directory cannot be created.
pub fn create_dir(dir: &Path) -> Result<(), DataError> {
    std::fs::create_dir_all(dir).map_err(|e| DataError::io(dir, format!("cannot create the directory: {e}")))
}
