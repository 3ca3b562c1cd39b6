//! A head's recordings on its node's disk, so that a restart keeps them. Each is two or
//! three files in the head's folder: `recordings/<name>.jsonl`, the frames as a facewire
//! JSONL stream (what `facewire play` and every reader of the format take), its voice, if
//! it has one, as `recordings/<name>.wav` (mono 16-bit PCM, what `facewire play --audio`
//! takes), and `recordings/<name>.json`, what the frames do not say (the stream it was
//! recorded from, whether it was cut, where on the frames' timeline the voice starts).
//! Each file is written whole (temporary file, then renamed), the `.json` last, so a
//! recording whose `.json` is there is complete; a leftover without one is skipped and
//! named.

use std::io::BufReader;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::ids::valid_id;
use super::recorded_voice::RecordedVoice;
use crate::atomic::write_atomic;
use crate::mask::Mask;
use crate::stream::jsonl::{JsonlReader, JsonlWriter};
use crate::stream::Frame;
use crate::voice::read_wav;

#[derive(Debug, thiserror::Error)]
pub enum ShelfError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Invalid { path: String, message: String },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ShelfError + '_ {
    move |source| ShelfError::Io {
        path: path.display().to_string(),
        source,
    }
}

fn invalid(path: &Path, message: impl std::fmt::Display) -> ShelfError {
    ShelfError::Invalid {
        path: path.display().to_string(),
        message: message.to_string(),
    }
}

/// What a recording's `.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShelvedMeta {
    /// The stream it was recorded from.
    pub stream: String,
    /// Whether the producer sent more than the recording kept.
    pub cut: bool,
    /// Where the voice (`<name>.wav`) starts on the frames' timeline, seconds; absent
    /// without a voice.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub voice_start_s: Option<f64>,
}

/// A recording read back: its name, what its `.json` says, its frames and its voice.
pub struct Shelved {
    pub name: String,
    pub meta: ShelvedMeta,
    pub frames: Vec<Frame>,
    pub voice: Option<RecordedVoice>,
}

/// One head's recordings folder.
#[derive(Clone)]
pub struct RecordingShelf {
    dir: PathBuf,
    /// Names the animation units in the files.
    mask: Arc<Mask>,
}

impl RecordingShelf {
    pub fn new(dir: PathBuf, mask: Arc<Mask>) -> RecordingShelf {
        RecordingShelf { dir, mask }
    }

    fn paths(&self, name: &str) -> (PathBuf, PathBuf) {
        (
            self.dir.join(format!("{name}.jsonl")),
            self.dir.join(format!("{name}.json")),
        )
    }

    fn voice_path(&self, name: &str) -> PathBuf {
        self.dir.join(format!("{name}.wav"))
    }

    /// Writes recording `name` (and its voice, when it has one), replacing one of that
    /// name; `meta.voice_start_s` must say where the voice starts.
    pub fn save(
        &self,
        name: &str,
        meta: &ShelvedMeta,
        frames: &[Frame],
        voice: Option<&RecordedVoice>,
    ) -> Result<(), ShelfError> {
        std::fs::create_dir_all(&self.dir).map_err(io(&self.dir))?;
        let (frames_path, meta_path) = self.paths(name);
        let mut writer = JsonlWriter::new(Vec::new(), &self.mask);
        for frame in frames {
            writer.write_frame(frame).map_err(|e| invalid(&frames_path, e))?;
        }
        let text = writer.into_inner().map_err(|e| invalid(&frames_path, e))?;
        write_atomic(&frames_path, &text).map_err(io(&frames_path))?;
        if let Some(voice) = voice {
            let voice_path = self.voice_path(name);
            let wav = voice.voice.to_wav().map_err(|e| invalid(&voice_path, e))?;
            write_atomic(&voice_path, &wav).map_err(io(&voice_path))?;
        }
        let meta_text = serde_json::to_vec_pretty(meta).expect("recording metadata serializes");
        write_atomic(&meta_path, &meta_text).map_err(io(&meta_path))
    }

    /// Removes recording `name`; nothing there is fine.
    pub fn remove(&self, name: &str) -> Result<(), ShelfError> {
        let (frames_path, meta_path) = self.paths(name);
        for path in [meta_path, frames_path, self.voice_path(name)] {
            match std::fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(io(&path)(e)),
            }
        }
        Ok(())
    }

    /// Every complete recording on the shelf, by name, and what could not be read.
    pub fn load_all(&self) -> (Vec<Shelved>, Vec<ShelfError>) {
        let (mut found, mut problems) = (Vec::new(), Vec::new());
        let entries = match std::fs::read_dir(&self.dir) {
            Ok(entries) => entries,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return (found, problems),
            Err(e) => return (found, vec![io(&self.dir)(e)]),
        };
        let mut names: Vec<String> = entries
            .filter_map(Result::ok)
            .filter_map(|e| e.file_name().to_str()?.strip_suffix(".json").map(str::to_string))
            .collect();
        names.sort();
        for name in names {
            match self.load(&name) {
                Ok(shelved) => found.push(shelved),
                Err(e) => problems.push(e),
            }
        }
        (found, problems)
    }

    fn load(&self, name: &str) -> Result<Shelved, ShelfError> {
        let (frames_path, meta_path) = self.paths(name);
        if !valid_id(name) {
            return Err(invalid(&meta_path, "not a recording name (1-64 of a-z 0-9 - _)"));
        }
        let meta_text = std::fs::read(&meta_path).map_err(io(&meta_path))?;
        let meta: ShelvedMeta = serde_json::from_slice(&meta_text).map_err(|e| invalid(&meta_path, e))?;
        let file = std::fs::File::open(&frames_path).map_err(io(&frames_path))?;
        let frames = JsonlReader::new(BufReader::new(file), &self.mask)
            .collect::<Result<Vec<Frame>, _>>()
            .map_err(|e| invalid(&frames_path, e))?;
        if frames.is_empty() {
            return Err(invalid(&frames_path, "no frames"));
        }
        let voice = match meta.voice_start_s {
            None => None,
            Some(start_t_s) => {
                let voice_path = self.voice_path(name);
                let file = std::fs::File::open(&voice_path).map_err(io(&voice_path))?;
                let voice = read_wav(BufReader::new(file), &voice_path.display().to_string())
                    .map_err(|e| invalid(&voice_path, e))?;
                Some(RecordedVoice { start_t_s, voice })
            }
        };
        Ok(Shelved {
            name: name.to_string(),
            meta,
            frames,
            voice,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(seq: u64) -> Frame {
        Frame {
            seq,
            time_s: seq as f64 / 30.0 + 0.1,
            label: Some(["pa", "ta"][seq as usize % 2].into()),
            animation: vec![(1, 0.1 + seq as f32 * 0.013)],
            faps: vec![(3, 117.5)],
            arkit: vec![(5, 0.25)],
            head_rotation_rad: Some([0.01, -0.02, 0.003]),
            ..Frame::default()
        }
    }

    #[test]
    fn a_recording_reads_back_as_written_and_is_removed_whole() {
        let dir = tempfile::tempdir().unwrap();
        let shelf = RecordingShelf::new(dir.path().join("recordings"), Arc::new(Mask::candide3()));
        let frames: Vec<Frame> = (0..5).map(frame).collect();
        let voice = RecordedVoice {
            start_t_s: 0.12,
            voice: crate::voice::Voice {
                sample_rate: 24_000,
                samples: vec![0, 7, -7, i16::MAX, i16::MIN],
            },
        };
        let meta = ShelvedMeta {
            stream: "talk".into(),
            cut: true,
            voice_start_s: Some(voice.start_t_s),
        };
        shelf.save("lesson", &meta, &frames, Some(&voice)).unwrap();
        let (found, problems) = shelf.load_all();
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(found.len(), 1);
        assert_eq!(found[0].name, "lesson");
        assert_eq!(found[0].meta, meta);
        assert_eq!(found[0].frames, frames);
        assert_eq!(found[0].voice.as_ref(), Some(&voice));
        shelf.remove("lesson").unwrap();
        assert!(shelf.load_all().0.is_empty());
        assert_eq!(
            std::fs::read_dir(dir.path().join("recordings")).unwrap().count(),
            0
        );
        // Removing what is not there is fine.
        shelf.remove("lesson").unwrap();
    }

    #[test]
    fn a_broken_or_unfinished_recording_on_disk_is_not_loaded_and_the_broken_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let shelf = RecordingShelf::new(dir.path().to_path_buf(), Arc::new(Mask::candide3()));
        let meta = ShelvedMeta {
            stream: "talk".into(),
            cut: false,
            voice_start_s: None,
        };
        shelf.save("good", &meta, &[frame(0)], None).unwrap();
        std::fs::write(
            dir.path().join("broken.json"),
            br#"{"stream":"talk","cut":false}"#,
        )
        .unwrap();
        std::fs::write(
            dir.path().join("broken.jsonl"),
            b"{\"seq\":0,\"t\":0,\"au\":{\"nope\":1}}\n",
        )
        .unwrap();
        // Frames without their .json: an interrupted write, not listed.
        std::fs::write(dir.path().join("half.jsonl"), b"").unwrap();
        let (found, problems) = shelf.load_all();
        assert_eq!(
            found.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(),
            ["good"]
        );
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(
            problems[0].to_string().contains("broken.jsonl"),
            "{}",
            problems[0]
        );
    }
}
