//! WAV files as voices: any PCM or float sample format, any channel count (mixed down to
//! mono), at the rates the wire carries (16, 24 or 48 kHz; other rates are refused with
//! the command that converts them, rather than resampled here); and a voice written as
//! one (mono, 16-bit).

use std::io::Read;

use super::Voice;
use facewire_proto::audio_chunk::PCM_RATES;

/// Why a WAV file cannot be a voice.
#[derive(Debug, thiserror::Error)]
pub enum WavError {
    #[error("{file}: not a WAV file facewire reads: {source}")]
    Format { file: String, source: hound::Error },
    #[error(
        "{file}: {rate} Hz; audio is sent at 16000, 24000 or 48000 Hz \
         (convert it with `ffmpeg -i {file} -ac 1 -ar 48000 out.wav`)"
    )]
    Rate { file: String, rate: u32 },
    #[error("{file}: {bits}-bit {format} samples are not supported (8-32 bit integer or 32-bit float)")]
    SampleFormat {
        file: String,
        bits: u16,
        format: &'static str,
    },
    #[error("{file}: longer than {max_s} s ({found_s:.1} s)")]
    TooLong { file: String, max_s: f64, found_s: f64 },
}

/// The longest voice read: an hour at 48 kHz is 345 MB of samples.
pub const MAX_VOICE_S: f64 = 3600.0;

/// Reads a WAV file from `reader`; `file` names it in errors.
pub fn read_wav(reader: impl Read, file: &str) -> Result<Voice, WavError> {
    let format = |source| WavError::Format {
        file: file.to_string(),
        source,
    };
    let wav = hound::WavReader::new(reader).map_err(format)?;
    let spec = wav.spec();
    if !PCM_RATES.contains(&spec.sample_rate) {
        return Err(WavError::Rate {
            file: file.to_string(),
            rate: spec.sample_rate,
        });
    }
    let channels = usize::from(spec.channels.max(1));
    let frames = wav.duration();
    let found_s = f64::from(frames) / f64::from(spec.sample_rate);
    if found_s > MAX_VOICE_S {
        return Err(WavError::TooLong {
            file: file.to_string(),
            max_s: MAX_VOICE_S,
            found_s,
        });
    }
    // Every sample as a float in -1..1, then mixed down.
    let floats: Vec<f32> = match (spec.sample_format, spec.bits_per_sample) {
        (hound::SampleFormat::Int, bits @ 1..=32) => {
            let scale = 1.0 / (1u64 << (bits - 1)) as f32;
            wav.into_samples::<i32>()
                .map(|s| s.map(|s| s as f32 * scale))
                .collect::<Result<_, _>>()
                .map_err(format)?
        }
        (hound::SampleFormat::Float, 32) => wav
            .into_samples::<f32>()
            .collect::<Result<_, _>>()
            .map_err(format)?,
        (sample_format, bits) => {
            return Err(WavError::SampleFormat {
                file: file.to_string(),
                bits,
                format: match sample_format {
                    hound::SampleFormat::Int => "integer",
                    hound::SampleFormat::Float => "float",
                },
            })
        }
    };
    let samples = floats
        .chunks(channels)
        .map(|frame| {
            let mono = frame.iter().sum::<f32>() / channels as f32;
            (mono * 32768.0).round().clamp(-32768.0, 32767.0) as i16
        })
        .collect();
    Ok(Voice {
        sample_rate: spec.sample_rate,
        samples,
    })
}

impl Voice {
    /// The voice as a WAV file: mono, 16-bit PCM at its rate.
    pub fn to_wav(&self) -> Result<Vec<u8>, hound::Error> {
        let spec = hound::WavSpec {
            channels: 1,
            sample_rate: self.sample_rate,
            bits_per_sample: 16,
            sample_format: hound::SampleFormat::Int,
        };
        let mut bytes = std::io::Cursor::new(Vec::new());
        let mut writer = hound::WavWriter::new(&mut bytes, spec)?;
        let mut samples = writer.get_i16_writer(self.samples.len() as u32);
        for &sample in &self.samples {
            samples.write_sample(sample);
        }
        samples.flush()?;
        writer.finalize()?;
        Ok(bytes.into_inner())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_voice_written_as_wav_reads_back_the_same() {
        let voice = Voice {
            sample_rate: 24_000,
            samples: vec![0, 1, -1, i16::MAX, i16::MIN, 1234],
        };
        let wav = voice.to_wav().unwrap();
        assert_eq!(read_wav(wav.as_slice(), "back.wav").unwrap(), voice);
    }

    fn wav(
        spec: hound::WavSpec,
        write: impl FnOnce(&mut hound::WavWriter<&mut std::io::Cursor<Vec<u8>>>),
    ) -> Vec<u8> {
        let mut bytes = std::io::Cursor::new(Vec::new());
        let mut writer = hound::WavWriter::new(&mut bytes, spec).unwrap();
        write(&mut writer);
        writer.finalize().unwrap();
        bytes.into_inner()
    }

    fn spec(channels: u16, rate: u32, bits: u16, sample_format: hound::SampleFormat) -> hound::WavSpec {
        hound::WavSpec {
            channels,
            sample_rate: rate,
            bits_per_sample: bits,
            sample_format,
        }
    }

    #[test]
    fn mono_16_bit_reads_back_sample_for_sample() {
        let bytes = wav(spec(1, 16_000, 16, hound::SampleFormat::Int), |w| {
            for s in [0i16, 1, -1, 32767, -32768] {
                w.write_sample(s).unwrap();
            }
        });
        let voice = read_wav(&bytes[..], "a.wav").unwrap();
        assert_eq!(voice.sample_rate, 16_000);
        assert_eq!(voice.samples, [0, 1, -1, 32767, -32768]);
    }

    #[test]
    fn stereo_and_float_are_mixed_to_mono_16_bit() {
        let bytes = wav(spec(2, 48_000, 32, hound::SampleFormat::Float), |w| {
            for s in [0.5f32, 0.0, -1.0, -1.0] {
                w.write_sample(s).unwrap();
            }
        });
        assert_eq!(read_wav(&bytes[..], "b.wav").unwrap().samples, [8192, -32768]);
        let bytes = wav(spec(1, 24_000, 24, hound::SampleFormat::Int), |w| {
            w.write_sample(1 << 22).unwrap();
        });
        assert_eq!(read_wav(&bytes[..], "c.wav").unwrap().samples, [16384]);
    }

    #[test]
    fn what_cannot_be_sent_is_refused_by_name() {
        let bytes = wav(spec(1, 44_100, 16, hound::SampleFormat::Int), |w| {
            w.write_sample(0i16).unwrap()
        });
        let message = read_wav(&bytes[..], "song.wav").unwrap_err().to_string();
        assert!(
            message.contains("song.wav: 44100 Hz") && message.contains("ffmpeg"),
            "{message}"
        );
        let message = read_wav(&b"RIFF...."[..], "junk.wav").unwrap_err().to_string();
        assert!(message.starts_with("junk.wav: not a WAV file"), "{message}");
    }
}
