//! `facewire arkit-basis`: derives the ARKit retarget basis from a head's expression
//! targets and its fit, writes it (`data/arkit/basis.tsv` is made this way), and prints per
//! target how well it reproduces the target: at the anchors, where it is exact up to the
//! file's rounding, and over the face, the motion a perfect reproduction of the controls
//! still leaves to the interpolation (docs/STREAMS.md, "ARKit").

use glam::Vec3;

use super::fitted_head::FittedHeadArgs;
use super::{CliResult, FilePath};
use crate::atomic::write_atomic;
use crate::fit::anchor_mask;
use crate::metrics::{ground_truth_error, FaceVertices};
use crate::stream::{arkit_index, ArkitBasis};
use crate::targets::ExpressionTarget;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The head the targets belong to, and its fit.
    #[command(flatten)]
    fitted: FittedHeadArgs,
    /// Folder of `<arkitName>.target` files (`vertex dx dy dz`, head units).
    #[arg(long)]
    targets: FilePath,
    /// Where to write the basis (.tsv); an existing file is replaced atomically.
    #[arg(long)]
    out: FilePath,
}

pub fn run(args: Args) -> CliResult {
    let (head, fitted) = args.fitted.load()?;
    let mm_per_unit = fitted.fit.mm_per_unit;
    let anchors = anchor_mask(&head, &fitted.neutral, mm_per_unit);
    let targets = ExpressionTarget::load_dir(&args.targets, head.positions.len())?;
    if targets.is_empty() {
        return Err(format!("{}: no .target files", args.targets.display()).into());
    }
    let derived = ArkitBasis::derive(&fitted, &anchors, &targets)?;
    let command = format!(
        "facewire arkit-basis --head {} --fit {} --targets {} --out {}",
        args.fitted.head.display(),
        args.fitted.fit.display(),
        args.targets.display(),
        args.out.display()
    );
    let text = derived.to_tsv(&command);
    // Measure what the file holds, rounding included.
    let written = ArkitBasis::parse(&args.out.display().to_string(), &text)?;
    let face = FaceVertices::new(&head, &fitted.mask, &anchors, mm_per_unit)?;
    let controls: Vec<usize> = (0..)
        .zip(fitted.mask.used_vertices())
        .filter_map(|(j, used)| used.then_some(j))
        .collect();

    println!(
        "ARKit basis from {} targets of {} ({} mm per head unit, {:.2} mm per mask unit)",
        targets.len(),
        args.fitted.head.display(),
        mm_per_unit,
        fitted.mm_per_mask_unit()
    );
    println!(
        "anchors: {} control vertices; face: {} head vertices within {} mm of their anchors",
        controls.len(),
        face.vertices().len(),
        face.radius_mm()
    );
    println!(
        "{:<20} {:>4}  {:>19}  {:>23}",
        "blendshape", "rows", "anchors rms/max mm", "target on face rms/max mm"
    );
    let no_animation = vec![0.0; fitted.mask.animation_units.len()];
    let mut offsets = vec![Vec3::ZERO; fitted.mask.vertices.len()];
    let mut moved = offsets.clone();
    let mut truth = offsets.clone();
    let mut target_head = head.positions.clone();
    for target in &targets {
        let shape =
            arkit_index(&target.name).ok_or_else(|| format!("target {}: not an ARKit name", target.name))?;
        offsets.fill(Vec3::ZERO);
        written.apply(&[(shape, 1.0)], &mut offsets);
        fitted.pose_with_offsets_into(&no_animation, &offsets, &mut moved);
        target.controls_into(&anchors, 1.0, &mut truth)?;
        let (mut squares, mut max) = (0.0f64, 0.0f64);
        for &j in &controls {
            let error = f64::from(((moved[j] - fitted.neutral[j]) - truth[j]).length() * mm_per_unit);
            squares += error * error;
            max = max.max(error);
        }
        let anchor_rms = (squares / controls.len() as f64).sqrt();
        target.apply_into(&head.positions, 1.0, &mut target_head)?;
        let on_face = ground_truth_error(&head.positions, &target_head, &face, mm_per_unit)?;
        println!(
            "{:<20} {:>4}  {:>9.5} {:>9.5}  {:>11.3} {:>11.3}",
            target.name,
            written.blendshape_offsets(shape).len(),
            anchor_rms,
            max,
            on_face.rms_mm,
            on_face.max_mm
        );
    }
    write_atomic(&args.out, text.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", args.out.display()))?;
    println!("wrote {}", args.out.display());
    Ok(())
}
