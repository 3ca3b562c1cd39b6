//! The log-mel frames of every WAV file in a folder, for data/speech/train.py: one
//! safetensors file holding, per file `NAME.wav`, a float32 tensor `NAME` of shape
//! (frames, 40), computed by facewire's own `speech::log_mel` (after `speech::resample`),
//! so the model trains on exactly what the server will hear.
//!
//! cargo run --release --example speech_features -- CORPUS_DIR OUT.safetensors

use std::collections::BTreeMap;
use std::path::Path;

use facewire::speech::log_mel::{LogMel, MELS};
use facewire::speech::resample::ToModelRate;
use facewire::voice::read_wav;
use safetensors::tensor::TensorView;
use safetensors::Dtype;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [corpus, out] = args.as_slice() else {
        return Err("usage: speech_features CORPUS_DIR OUT.safetensors".into());
    };
    let mut names: Vec<_> = std::fs::read_dir(corpus)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "wav"))
        .collect();
    names.sort();
    let mut bytes: BTreeMap<String, (usize, Vec<u8>)> = BTreeMap::new();
    for (i, path) in names.iter().enumerate() {
        let file = path.display().to_string();
        let voice = read_wav(std::fs::File::open(path)?, &file)?;
        let mut resampler = ToModelRate::new(voice.sample_rate)?;
        let samples: Vec<f32> = voice.samples.iter().map(|&s| f32::from(s) / 32768.0).collect();
        let mut at_model_rate = Vec::new();
        resampler.push(&samples, &mut at_model_rate);
        let mut data = Vec::new();
        let mut frames = 0;
        LogMel::new().push(&at_model_rate, |frame| {
            frames += 1;
            data.extend(frame.iter().flat_map(|x| x.to_le_bytes()));
        });
        let name = Path::new(path)
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned();
        bytes.insert(name, (frames, data));
        if (i + 1) % 500 == 0 {
            eprintln!("{} of {} files", i + 1, names.len());
        }
    }
    let views = bytes
        .iter()
        .map(|(name, (frames, data))| {
            Ok((
                name.clone(),
                TensorView::new(Dtype::F32, vec![*frames, MELS], data)?,
            ))
        })
        .collect::<Result<Vec<_>, safetensors::SafeTensorError>>()?;
    safetensors::serialize_to_file(views, None, Path::new(out))?;
    eprintln!("{} files' log-mel frames in {out}", names.len());
    Ok(())
}
