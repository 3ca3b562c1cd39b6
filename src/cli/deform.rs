//! `facewire deform`: bind an algorithm to a head and write the deformed head of every
//! frame of a stream as OBJ (placed by the head's own motion, with its parts placed by
//! the head's and the jaw's), with the control displacements and the lip roughness table
//! (the thesis's `dataMetrics.txt`, docs/METRICS.md section 3) as TSV, for offline study and
//! for checking the live service against.

use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use super::fitted_head::FittedHeadArgs;
use super::part_arg::{describe_parts, load_parts};
use super::{CliResult, FilePath};
use crate::animate::{AnimatedHead, FrameJob, FrameMeters, Heat};
use crate::deform::{bind, AlgoSpec};
use crate::head::obj;
use crate::metrics::{FaceVertices, LipRoughnessRow, RoughnessTsvWriter, FOLDS_TSV_HEADER};
use crate::stream::{open_stream, ArkitBasis};

#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    fitted: FittedHeadArgs,
    /// Algorithm spec or preset letter (see `facewire algos`).
    #[arg(long, default_value = crate::server::config::DEFAULT_ALGORITHM)]
    algo: String,
    /// Parameter stream (.jsonl, .fap, .fau).
    #[arg(long)]
    stream: FilePath,
    /// Output directory (created if missing): frame_NNNNN.obj (the head deformed and moved by
    /// the frame's head rotation and translation), control.tsv (the mask before that
    /// motion), metrics.tsv (lip roughness, the thesis's layout), folds.tsv (the lip
    /// region's and the face's folds per frame).
    #[arg(long)]
    out: FilePath,
    /// Only frames A..B (0-based, B excluded; either end may be left out: `10..`, `..50`).
    #[arg(long)]
    frames: Option<String>,
    /// A part mesh (teeth, gums, tongue) in the head's units and frame, as `PATH` (its
    /// role, skull or jaw, inferred) or `ROLE:PATH` (skull, jaw, tongue or eyes). Repeatable;
    /// each is written after the head as an object named after its file (a tongue shaped
    /// by the frame's tongue parameters).
    #[arg(long = "part", value_name = "[ROLE:]PATH")]
    parts: Vec<String>,
}

/// Parses `A..B`, `A..`, `..B` into a half-open range.
fn parse_range(text: &str) -> Result<std::ops::Range<usize>, String> {
    let (a, b) = text
        .split_once("..")
        .ok_or_else(|| format!("--frames {text:?}: expected A..B"))?;
    let bound = |s: &str, default: usize| -> Result<usize, String> {
        if s.trim().is_empty() {
            Ok(default)
        } else {
            s.trim()
                .parse()
                .map_err(|_| format!("--frames {text:?}: {s:?} is not a frame number"))
        }
    };
    let range = bound(a, 0)?..bound(b, usize::MAX)?;
    if range.start >= range.end {
        return Err(format!("--frames {text:?}: the range is empty"));
    }
    Ok(range)
}

pub fn run(args: Args) -> CliResult {
    let spec: AlgoSpec = args.algo.parse()?;
    let range = args
        .frames
        .as_deref()
        .map(parse_range)
        .transpose()?
        .unwrap_or(0..usize::MAX);
    let parts = load_parts(&args.parts)?;
    let (head, fitted) = args.fitted.load()?;
    let mask = fitted.mask.clone();
    let started = Instant::now();
    let registration = args.fitted.register(head, fitted)?;
    let registered = started.elapsed();
    let binding = bind(&registration, &spec);
    eprintln!(
        "registered {} ({} vertices) in {:.0} ms, bound {spec} in {:.0} ms",
        args.fitted.head.display(),
        registration.vertex_count(),
        registered.as_secs_f64() * 1e3,
        (started.elapsed() - registered).as_secs_f64() * 1e3
    );

    std::fs::create_dir_all(&args.out).map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    let control_path = args.out.join("control.tsv");
    let mut control = BufWriter::new(create(&control_path)?);
    writeln!(control, "frame\tmask_vertex\tanchor\tx\ty\tz\tdx\tdy\tdz")?;
    let animated = Arc::new(
        AnimatedHead::with_parts(registration, parts)
            .map_err(|e| format!("{}: {e}", args.fitted.head.display()))?,
    );
    describe_parts(&animated);
    let registration = &animated.registration;
    let metrics_path = args.out.join("metrics.tsv");
    let in_metrics = |e| format!("{}: {e}", metrics_path.display());
    let mut metrics = RoughnessTsvWriter::new(BufWriter::new(create(&metrics_path)?)).map_err(in_metrics)?;
    let mm = registration.mm_per_unit();
    let face = FaceVertices::new(
        &registration.head,
        &registration.fitted.mask,
        &registration.anchors,
        mm,
    )?;
    // The viewer frames' meters, and the face's folds besides.
    let meters = FrameMeters::new(&animated, Heat::None)?
        .with_face_folds(&animated, &face.triangles(&registration.head))?;
    let folds_path = args.out.join("folds.tsv");
    let mut folds = BufWriter::new(create(&folds_path)?);
    writeln!(folds, "{FOLDS_TSV_HEADER}")?;

    let mut job = FrameJob::with_meters(
        animated.clone(),
        Arc::new(binding),
        Arc::new(ArkitBasis::shipped()),
        meters,
    );
    let header = vec![
        format!("facewire deform: {} with {spec}", args.fitted.head.display()),
        format!(
            "stream {}; head units, same vertex order and faces as the input",
            args.stream.display()
        ),
    ];
    let mut placed = vec![glam::Vec3::ZERO; registration.vertex_count()];
    let mut placed_parts: Vec<Vec<glam::Vec3>> = animated
        .parts
        .iter()
        .map(|p| vec![glam::Vec3::ZERO; p.mesh.positions.len()])
        .collect();
    let mut placed_eyes: Vec<Vec<glam::Vec3>> = animated
        .eyes
        .iter()
        .map(|e| vec![glam::Vec3::ZERO; e.mesh.positions.len()])
        .collect();
    let mut written = 0usize;
    for (index, frame) in open_stream(&args.stream, &mask)?.enumerate() {
        if index >= range.end {
            break;
        }
        let frame = frame?;
        if index < range.start {
            continue;
        }
        job.deform(&frame);
        job.head_motion().apply_into(job.deformed(), &mut placed);
        let path = args.out.join(format!("frame_{index:05}.obj"));
        let mut file = BufWriter::new(create(&path)?);
        obj::write(&mut file, &header, &placed, &registration.head.triangles)?;
        let (head_motion, jaw_motion) = (job.head_motion(), job.jaw_motion());
        let mut first_vertex = placed.len() as u32;
        let tongue = animated.tongue.as_ref().map(|(index, _)| *index);
        for (p, (part, out)) in animated.parts.iter().zip(&mut placed_parts).enumerate() {
            let motion = match part.role.moves_with_jaw() {
                true => head_motion.after(&jaw_motion),
                false => head_motion,
            };
            if tongue == Some(p) {
                for ((o, rest), delta) in out.iter_mut().zip(&part.mesh.positions).zip(job.tongue_deltas()) {
                    *o = motion.apply(*rest + *delta);
                }
            } else {
                motion.apply_into(&part.mesh.positions, out);
            }
            obj::write_object(&mut file, &part.name, out, &part.mesh.triangles, first_vertex)?;
            first_vertex += out.len() as u32;
        }
        for ((eye, motion), out) in animated.eyes.iter().zip(job.eye_motions()).zip(&mut placed_eyes) {
            head_motion.after(motion).apply_into(&eye.mesh.positions, out);
            obj::write_object(&mut file, &eye.name, out, &eye.mesh.triangles, first_vertex)?;
            first_vertex += out.len() as u32;
        }
        file.flush()?;
        let measures = job.measure(&frame)?;
        // metrics.tsv numbers its rows by the frame's index in the stream.
        let rows = measures.lip_rows.map(|row| LipRoughnessRow {
            frame: index as u64,
            ..row
        });
        metrics.write_rows(&rows).map_err(in_metrics)?;
        let (lip, face) = (measures.lip_folds, measures.face_folds.unwrap_or_default());
        writeln!(
            folds,
            "{index}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
            frame.time_s,
            lip.turned_over_60,
            lip.turned_over_90,
            lip.max_dihedral_increase_deg,
            face.turned_over_60,
            face.turned_over_90,
            face.max_dihedral_increase_deg
        )?;
        let mask_now = job.mask();
        for (j, (now, rest)) in mask_now.iter().zip(registration.mask_rest()).enumerate() {
            let d = *now - *rest;
            writeln!(
                control,
                "{index}\t{j}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
                registration.anchors.vertex[j], now.x, now.y, now.z, d.x, d.y, d.z
            )?;
        }
        written += 1;
        if written.is_multiple_of(50) {
            eprint!("\r{written} frames");
        }
    }
    control.flush()?;
    metrics.finish().map_err(in_metrics)?;
    folds.flush()?;
    eprintln!("\rwrote {written} frames to {}", args.out.display());
    Ok(())
}

fn create(path: &Path) -> Result<std::fs::File, String> {
    std::fs::File::create(path).map_err(|e| format!("cannot create {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::parse_range;

    #[test]
    fn frame_ranges() {
        assert_eq!(parse_range("3..7"), Ok(3..7));
        assert_eq!(parse_range("10.."), Ok(10..usize::MAX));
        assert_eq!(parse_range("..5"), Ok(0..5));
        assert!(parse_range("7..3").is_err());
        assert!(parse_range("x..3").unwrap_err().contains("not a frame number"));
        assert!(parse_range("5").is_err());
    }
}
