//! WAV files: a RIFF reader of its own (8/16/24/32-bit integer PCM, 32/64-bit float, WAVE_FORMAT_EXTENSIBLE,
//! any channel count, odd-sized chunks with their pad byte) and writing through hound (32-bit float or
//! 16/24-bit integer with a stated full scale).

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

    /// Finishes the header; the file stays under its temporary name until the returned guard is committed
    /// (so a signal and its sidecar can be put in place together). Returns the clipped sample count too.
    ///
    /// # Errors
    /// Finalising fails.
    pub fn finish(self) -> Result<(AtomicFile, u64), DataError> {
        self.writer.finalize().map_err(|e| DataError::io(&self.path, e))?;
        Ok((self.guard, self.clipped))
    }
}

/// Sample encodings the reader understands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    /// Unsigned 8-bit PCM (offset 128).
    U8,
    /// Signed little-endian PCM of 2, 3 or 4 bytes.
    Int(usize),
    /// IEEE float, 4 bytes.
    F32,
    /// IEEE float, 8 bytes.
    F64,
}

impl Encoding {
    fn width(self) -> usize {
        match self {
            Self::U8 => 1,
            Self::Int(w) => w,
            Self::F32 => 4,
            Self::F64 => 8,
        }
    }
    /// Decodes one sample (`b` has `width` bytes); integers scaled to [-1, 1) by 2^(bits-1).
    fn decode(self, b: &[u8]) -> f32 {
        match self {
            Self::U8 => (f32::from(b[0]) - 128.0) / 128.0,
            Self::Int(2) => f32::from(i16::from_le_bytes([b[0], b[1]])) / 32768.0,
            Self::Int(3) => ((i32::from_le_bytes([0, b[0], b[1], b[2]]) >> 8) as f64 / 8_388_608.0) as f32,
            Self::Int(_) => (f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])) / 2_147_483_648.0) as f32,
            Self::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            Self::F64 => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]) as f32,
        }
    }
}

/// Appends channel samples at byte `offset` of every `frame`-byte frame of `block` to `out`, with the
/// encoding matched once per block (so the per-sample loop is a plain conversion).
fn decode_channel(block: &[u8], frame: usize, offset: usize, enc: Encoding, out: &mut Vec<f32>) {
    let frames = block.chunks_exact(frame);
    match enc {
        Encoding::F32 => {
            out.extend(frames.map(|f| f32::from_le_bytes([f[offset], f[offset + 1], f[offset + 2], f[offset + 3]])))
        }
        Encoding::Int(2) => {
            out.extend(frames.map(|f| f32::from(i16::from_le_bytes([f[offset], f[offset + 1]])) / 32768.0));
        }
        _ => out.extend(frames.map(|f| enc.decode(&f[offset..offset + enc.width()]))),
    }
}

/// The fmt chunk: channels, rate and encoding (PCM, IEEE float or WAVE_FORMAT_EXTENSIBLE with either).
fn parse_fmt(path: &Path, c: &[u8]) -> Result<(usize, u32, Encoding), DataError> {
    if c.len() < 16 {
        return Err(DataError::format(path, format!("fmt chunk of {} bytes is too short (16 needed)", c.len())));
    }
    let u16_at = |i: usize| u16::from_le_bytes([c[i], c[i + 1]]);
    let mut tag = u16_at(0);
    let channels = usize::from(u16_at(2));
    let rate = u32::from_le_bytes([c[4], c[5], c[6], c[7]]);
    let bits = u16_at(14);
    if tag == 0xFFFE && c.len() >= 26 {
        tag = u16_at(24); // the sub-format GUID starts with the format tag
    }
    let enc = match (tag, bits) {
        (1, 8) => Encoding::U8,
        (1, 16) => Encoding::Int(2),
        (1, 24) => Encoding::Int(3),
        (1, 32) => Encoding::Int(4),
        (3, 32) => Encoding::F32,
        (3, 64) => Encoding::F64,
        _ => {
            return Err(DataError::format(
                path,
                format!(
                    "unsupported WAV sample format (tag {tag}, {bits} bits): expected 8/16/24/32-bit PCM or 32/64-bit float"
                ),
            ));
        }
    };
    if channels == 0 {
        return Err(DataError::format(path, "fmt chunk: 0 channels"));
    }
    if rate == 0 {
        return Err(DataError::format(path, "fmt chunk: sample rate 0 Hz"));
    }
    // the frame's size said twice: a header that disagrees with itself cannot say which to believe
    let block_align = usize::from(u16_at(12));
    if block_align != channels * enc.width() {
        return Err(DataError::format(
            path,
            format!(
                "fmt chunk: a frame of {block_align} bytes, but {channels} channel(s) of {bits}-bit samples make {}: the header contradicts itself",
                channels * enc.width()
            ),
        ));
    }
    Ok((channels, rate, enc))
}

/// Reads a WAV file into f32 channels (integer formats scaled to [-1, 1)). A RIFF parser of its own: chunks
/// of odd size are followed by their pad byte (as the RIFF rules say), unknown chunks are skipped, a data
/// chunk longer than the file is read as far as the file goes (with the whole frames kept). Memory is
/// reserved from the bytes the file really holds, never from a header's claim, and read in blocks of at
/// most 1 MiB whatever the channel count. RF64 and BW64 files (the WAV of recordings beyond 4 GiB, EBU
/// Tech 3306 and ITU-R BS.2088) are read with the data size of their ds64 chunk.
///
/// # Errors
/// Not a RIFF/WAVE (or RF64/BW64) file, no fmt or data chunk, an unsupported encoding, no whole frame, an
/// RF64 ds64 chunk cut short.
pub fn read(path: &Path) -> Result<Recording<'static>, DataError> {
    read_channels(path, None)
}

/// [`read`] keeping only the 0-based channels in `keep` (the others are left empty, so a long recording of
/// which one channel is analysed needs the memory of that channel alone).
///
/// # Errors
/// As [`read`].
pub fn read_channels(path: &Path, keep: Option<&[usize]>) -> Result<Recording<'static>, DataError> {
    use std::io::{Read, Seek, SeekFrom};
    let file = std::fs::File::open(path).map_err(|e| DataError::io(path, e))?;
    let file_len = file.metadata().map_err(|e| DataError::io(path, e))?.len();
    let mut r = std::io::BufReader::new(file);
    let mut head = [0u8; 12];
    r.read_exact(&mut head).map_err(|_| DataError::format(path, "not a WAV file: shorter than a RIFF header"))?;
    // RF64 (EBU Tech 3306) and BW64 (ITU-R BS.2088): a WAV whose sizes beyond 4 GiB sit in a ds64 chunk
    let wide = matches!(&head[0..4], b"RF64" | b"BW64");
    if !(&head[0..4] == b"RIFF" || wide) || &head[8..12] != b"WAVE" {
        return Err(DataError::format(path, "not a WAV file: no RIFF/WAVE (or RF64/BW64) header"));
    }
    let mut pos = 12u64;
    let mut fmt: Option<(usize, u32, Encoding)> = None;
    // the data chunk's 64-bit size from an RF64 file's ds64 chunk
    let mut wide_data: Option<u64> = None;
    loop {
        let mut ch = [0u8; 8];
        if r.read_exact(&mut ch).is_err() {
            return Err(DataError::format(path, "not a readable WAV file: no data chunk"));
        }
        let mut size = u64::from(u32::from_le_bytes([ch[4], ch[5], ch[6], ch[7]]));
        pos += 8;
        if &ch[0..4] == b"data" && size == u64::from(u32::MAX) {
            size = wide_data.unwrap_or(size);
        }
        match &ch[0..4] {
            b"ds64" if wide => {
                // riff size, data size, sample count (u64 each), then a table of other chunks' sizes
                let mut c = [0u8; 16];
                if size < 16 || r.read_exact(&mut c).is_err() {
                    return Err(DataError::format(path, "ds64 chunk truncated: an RF64 file needs its 64-bit sizes"));
                }
                wide_data = Some(u64::from_le_bytes(c[8..16].try_into().expect("8 bytes")));
                let skip = size + (size & 1) - 16;
                r.seek(SeekFrom::Current(skip as i64)).map_err(|e| DataError::io(path, e))?;
            }
            b"fmt " => {
                if size > file_len.saturating_sub(pos) {
                    return Err(DataError::format(path, "fmt chunk truncated: the file ends inside it (cut short)"));
                }
                let len = size.min(1024) as usize;
                let mut c = vec![0u8; len];
                r.read_exact(&mut c).map_err(|_| DataError::format(path, "fmt chunk truncated"))?;
                fmt = Some(parse_fmt(path, &c)?);
                let skip = size + (size & 1) - len as u64;
                r.seek(SeekFrom::Current(skip as i64)).map_err(|e| DataError::io(path, e))?;
            }
            b"data" => {
                let (nch, rate, enc) =
                    fmt.ok_or_else(|| DataError::format(path, "not a readable WAV file: data chunk before fmt chunk"))?;
                let held = file_len.saturating_sub(pos);
                // a writer that never closed its file leaves the size 0 or all ones: read what is there
                let unset = size == 0 || size == u64::from(u32::MAX);
                let available = if unset { held } else { size.min(held) };
                let channels = read_frames(path, &mut r, available, nch, enc, keep)?;
                let names = (1..=nch).map(|i| format!("ch{i}")).collect();
                let warnings = data_size_warning(size, held, unset).into_iter().collect();
                return Ok(Recording {
                    channels: channels.into_iter().map(std::borrow::Cow::Owned).collect(),
                    sample_rate_hz: Some(f64::from(rate)),
                    units: vec![String::new(); nch],
                    names,
                    warnings,
                });
            }
            _ => {
                r.seek(SeekFrom::Current((size + (size & 1)) as i64)).map_err(|e| DataError::io(path, e))?;
            }
        }
        pos += size + (size & 1);
        if pos >= file_len {
            return Err(DataError::format(path, "not a readable WAV file: no data chunk"));
        }
    }
}

/// What a data chunk's size says of the file: unset (0 or 0xFFFFFFFF, a recording never closed: the
/// `held` bytes after the chunk header are read) or more than the file holds (cut short: what is there is
/// read). `None` when the file holds the chunk whole.
fn data_size_warning(size: u64, held: u64, unset: bool) -> Option<String> {
    if unset {
        Some(format!(
            "the WAV data chunk's size is unset ({size:#x}: a recording whose writer never closed the file): the {held} bytes the file holds after it are read as the samples"
        ))
    } else if size > held {
        Some(format!(
            "the WAV data chunk claims {size} bytes but the file holds {held} after its header: the file was cut short (a copy or a logger that stopped), and the {:.1} % that is there is read",
            100.0 * held as f64 / size as f64
        ))
    } else {
        None
    }
}

/// Whole frames of `nch` channels from `bytes` bytes of the data chunk.
fn read_frames(
    path: &Path,
    r: &mut (impl std::io::Read + Send),
    bytes: u64,
    nch: usize,
    enc: Encoding,
    keep: Option<&[usize]>,
) -> Result<Vec<Vec<f32>>, DataError> {
    let width = enc.width();
    let frame = width * nch;
    let frames = (bytes / frame as u64) as usize;
    if frames == 0 {
        return Err(DataError::format(
            path,
            format!("the data chunk holds {bytes} bytes, not one whole frame of {nch} channel(s) x {width} bytes"),
        ));
    }
    let wanted: Vec<bool> = (0..nch).map(|c| keep.is_none_or(|k| k.contains(&c))).collect();
    let mut channels: Vec<Vec<f32>> =
        wanted.iter().map(|&w| if w { Vec::with_capacity(frames) } else { Vec::new() }).collect();
    let per_block = ((1usize << 20) / frame).max(1);
    // two buffers: the next block is read while the one before is decoded (the read is the kernel's copy
    // out of the page cache, on one core; the channels of a block are decoded in parallel, each into its
    // own vector)
    let (mut current, mut next) = (vec![0u8; per_block * frame], vec![0u8; per_block * frame]);
    let mut n = frames.min(per_block);
    r.read_exact(&mut current[..n * frame]).map_err(|e| DataError::io(path, e))?;
    let mut left = frames - n;
    loop {
        let m = left.min(per_block);
        let decode = || {
            use rayon::prelude::*;
            let block = &current[..n * frame];
            channels.par_iter_mut().enumerate().filter(|(ch, _)| wanted[*ch]).for_each(|(ch, c)| {
                decode_channel(block, frame, ch * width, enc, c);
            });
        };
        let (read, ()) = rayon::join(|| r.read_exact(&mut next[..m * frame]), decode);
        read.map_err(|e| DataError::io(path, e))?;
        if m == 0 {
            break;
        }
        std::mem::swap(&mut current, &mut next);
        (n, left) = (m, left - m);
    }
    Ok(channels)
}
