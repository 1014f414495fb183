//! WAV files through hound: every format hound reads (8/16/24/32-bit integer, 32-bit float), any channel
//! count; writing 32-bit float or 16/24-bit integer with a stated full scale.

use super::{AtomicFile, DataError, Recording};
use std::path::Path;

/// Sample format of a written file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WavSampleFormat {
    /// 32-bit IEEE float, values as given.
    Float32,
    /// Integer with `bits` (16 or 24): sample = round(value / full_scale * 2^(bits-1)), clamped.
    Int {
        /// 16 or 24.
        bits: u16,
        /// Physical value of full scale.
        full_scale: f64,
    },
}

/// Streaming WAV writer behind an [`AtomicFile`].
pub struct WavOut {
    writer: hound::WavWriter<std::io::BufWriter<std::fs::File>>,
    guard: AtomicFile,
    format: WavSampleFormat,
    path: std::path::PathBuf,
    clipped: u64,
}

impl WavOut {
    /// Creates `path` (atomically) for `channels` channels at `sample_rate_hz`.
    ///
    /// # Errors
    /// The file cannot be created.
    pub fn create(path: &Path, channels: u16, sample_rate_hz: u32, format: WavSampleFormat) -> Result<Self, DataError> {
        let (guard, file) = AtomicFile::create(path)?;
        let spec = match format {
            WavSampleFormat::Float32 => hound::WavSpec {
                channels,
                sample_rate: sample_rate_hz,
                bits_per_sample: 32,
                sample_format: hound::SampleFormat::Float,
            },
            WavSampleFormat::Int { bits, .. } => hound::WavSpec {
                channels,
                sample_rate: sample_rate_hz,
                bits_per_sample: bits,
                sample_format: hound::SampleFormat::Int,
            },
        };
        let writer = hound::WavWriter::new(std::io::BufWriter::with_capacity(1 << 20, file), spec)
            .map_err(|e| DataError::io(path, e))?;
        Ok(Self { writer, guard, format, path: path.to_path_buf(), clipped: 0 })
    }

    /// Appends interleaved frames.
    ///
    /// # Errors
    /// Writing fails.
    pub fn write(&mut self, interleaved: &[f64]) -> Result<(), DataError> {
        let err = |e: hound::Error| DataError::io(&self.path, e);
        match self.format {
            WavSampleFormat::Float32 => {
                for &v in interleaved {
                    self.writer.write_sample(v as f32).map_err(err)?;
                }
            }
            WavSampleFormat::Int { bits, full_scale } => {
                // sample = round(v / full_scale * 2^(bits-1)), the scale `read` divides by
                let scale = (1i64 << (bits - 1)) as f64;
                for &v in interleaved {
                    let x = (v / full_scale * scale).round();
                    if x > scale - 1.0 || x < -scale {
                        self.clipped += 1;
                    }
                    self.writer.write_sample(x.clamp(-scale, scale - 1.0) as i32).map_err(err)?;
                }
            }
        }
        Ok(())
    }

    /// Finishes the header and renames the file into place; returns the number of clipped samples.
    ///
    /// # Errors
    /// Finalising or renaming fails.
    pub fn finish(self) -> Result<u64, DataError> {
        self.writer.finalize().map_err(|e| DataError::io(&self.path, e))?;
        self.guard.commit()?;
        Ok(self.clipped)
    }
}

/// Reads all channels. Integer data is scaled to [-1, 1) (divided by 2^(bits-1)); float data is kept.
/// Memory is reserved from the file's real size, never from the header's claim.
///
/// # Errors
/// Unreadable, malformed or truncated files, named with hound's reason.
pub fn read(path: &Path) -> Result<Recording, DataError> {
    let file_len = std::fs::metadata(path).map_err(|e| DataError::io(path, e))?.len();
    let mut reader =
        hound::WavReader::open(path).map_err(|e| DataError::format(path, format!("not a readable WAV file: {e}")))?;
    let spec = reader.spec();
    let nch = spec.channels as usize;
    let bytes_per_sample = spec.bits_per_sample.div_ceil(8).max(1) as u64;
    let claimed = reader.duration() as u64;
    let possible = file_len / (bytes_per_sample * nch as u64);
    let frames = claimed.min(possible) as usize;
    let mut channels: Vec<Vec<f32>> = (0..nch).map(|_| Vec::with_capacity(frames)).collect();
    let plain = matches!(
        (spec.sample_format, spec.bits_per_sample),
        (hound::SampleFormat::Float, 32) | (hound::SampleFormat::Int, 16)
    );
    if plain && spec.bits_per_sample == 8 * bytes_per_sample as u16 {
        // fast path: the data chunk is little-endian f32 or i16, read in bulk
        return read_plain(path, reader, spec, claimed, channels);
    }
    let truncated = |e: hound::Error, i: usize| DataError::format(path, format!("data ends early at sample {i}: {e}"));
    match spec.sample_format {
        hound::SampleFormat::Float => {
            for (i, s) in reader.samples::<f32>().enumerate() {
                channels[i % nch].push(s.map_err(|e| truncated(e, i))?);
            }
        }
        hound::SampleFormat::Int => {
            let scale = 1.0 / (1u64 << (spec.bits_per_sample - 1)) as f64;
            for (i, s) in reader.samples::<i32>().enumerate() {
                channels[i % nch].push((f64::from(s.map_err(|e| truncated(e, i))?) * scale) as f32);
            }
        }
    }
    let len = channels.iter().map(Vec::len).min().unwrap_or(0);
    for c in &mut channels {
        c.truncate(len);
    }
    let names = (1..=nch).map(|i| format!("ch{i}")).collect();
    Ok(Recording { channels, sample_rate_hz: Some(f64::from(spec.sample_rate)), names })
}

fn read_plain(
    path: &Path,
    reader: hound::WavReader<std::io::BufReader<std::fs::File>>,
    spec: hound::WavSpec,
    claimed_frames: u64,
    mut channels: Vec<Vec<f32>>,
) -> Result<Recording, DataError> {
    use std::io::Read;
    let nch = spec.channels as usize;
    let width = (spec.bits_per_sample / 8) as usize;
    let total = claimed_frames as usize * nch * width;
    let mut inner = reader.into_inner();
    let mut buf = vec![0u8; (1 << 16) * width * nch];
    let (mut done, mut slot) = (0usize, 0usize);
    while done < total {
        let want = buf.len().min(total - done);
        let got = inner.read(&mut buf[..want]).map_err(|e| DataError::io(path, e))?;
        if got == 0 {
            return Err(DataError::format(path, format!("data ends early at sample {}: file truncated", done / width)));
        }
        let whole = got - got % width;
        let decode = |b: &[u8]| {
            if width == 4 {
                f32::from_le_bytes([b[0], b[1], b[2], b[3]])
            } else {
                f32::from(i16::from_le_bytes([b[0], b[1]])) / 32768.0
            }
        };
        let mut bytes = &buf[..whole];
        // finish a frame left open by the previous read, then whole frames channel by channel
        while slot != 0 && !bytes.is_empty() {
            channels[slot].push(decode(&bytes[..width]));
            slot = (slot + 1) % nch;
            bytes = &bytes[width..];
        }
        let frame = width * nch;
        let full = bytes.len() / frame * frame;
        for f in bytes[..full].chunks_exact(frame) {
            for (c, b) in channels.iter_mut().zip(f.chunks_exact(width)) {
                c.push(decode(b));
            }
        }
        for b in bytes[full..].chunks_exact(width) {
            channels[slot].push(decode(b));
            slot = (slot + 1) % nch;
        }
        if whole != got {
            // keep the partial sample for the next read
            let rest = got - whole;
            buf.copy_within(whole..got, 0);
            let more = inner.read(&mut buf[rest..width]).map_err(|e| DataError::io(path, e))?;
            if more < width - rest {
                return Err(DataError::format(path, "data ends in the middle of a sample: file truncated"));
            }
            let b = &buf[..width];
            let v = if width == 4 {
                f32::from_le_bytes([b[0], b[1], b[2], b[3]])
            } else {
                f32::from(i16::from_le_bytes([b[0], b[1]])) / 32768.0
            };
            channels[slot].push(v);
            slot = (slot + 1) % nch;
            done += width;
        }
        done += whole;
    }
    let len = channels.iter().map(Vec::len).min().unwrap_or(0);
    for c in &mut channels {
        c.truncate(len);
    }
    let names = (1..=nch).map(|i| format!("ch{i}")).collect();
    Ok(Recording { channels, sample_rate_hz: Some(f64::from(spec.sample_rate)), names })
}
