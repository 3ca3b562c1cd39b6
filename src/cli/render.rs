//! `facewire render`: a PNG of a head, and of its fitted mask when a fit is given, to
//! check a fit by eye and to make the docs' pictures.

use std::io::BufWriter;

use super::{load_fit, load_head, load_mask, CliResult, FilePath};
use crate::fit::{anchor_mask, FittedMask};
use crate::render::{Canvas, Ink, View};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// The head mesh (OBJ).
    #[arg(long)]
    head: FilePath,
    /// A fit to draw the mask with (.fit.toml).
    #[arg(long)]
    fit: Option<FilePath>,
    /// A CANDIDE-3 .wfm instead of the embedded one.
    #[arg(long)]
    mask: Option<FilePath>,
    /// Where the camera looks from.
    #[arg(long, value_enum, default_value = "front")]
    view: ViewArg,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 800)]
    size: usize,
    /// Frame the face (the fitted mask) rather than the whole head.
    #[arg(long, conflicts_with = "mouth")]
    face: bool,
    /// Frame the mouth (the fitted mask's lip vertices), for close-ups of the lips.
    #[arg(long, requires = "fit")]
    mouth: bool,
    /// Draw the head alone: the fit then only frames the picture.
    #[arg(long, requires = "fit", conflicts_with = "anchors")]
    no_mask: bool,
    /// Also mark the anchors (nearest head vertices) of the lip vertices.
    #[arg(long)]
    anchors: bool,
    #[arg(long)]
    out: FilePath,
}

/// The command line's names for the renderer's views.
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum ViewArg {
    /// Looking at the face (down -z).
    Front,
    /// From the face's right side.
    Side,
    /// Halfway between front and the face's right side.
    ThreeQuarter,
}

impl From<ViewArg> for View {
    fn from(view: ViewArg) -> View {
        match view {
            ViewArg::Front => View::Front,
            ViewArg::Side => View::Side,
            ViewArg::ThreeQuarter => View::ThreeQuarter,
        }
    }
}

pub fn run(args: Args) -> CliResult {
    let head = load_head(&args.head)?;
    let mask = load_mask(args.mask.as_deref())?;
    let fitted = match &args.fit {
        Some(path) => Some(FittedMask::new(mask.clone(), load_fit(path, &mask)?)),
        None => None,
    };
    let frame_points = match &fitted {
        Some(f) if args.mouth => crate::mask::LIP_VERTICES.iter().map(|&j| f.neutral[j]).collect(),
        Some(f) if args.face => f.neutral.clone(),
        _ => head.positions.clone(),
    };
    let mut canvas = Canvas::framing(&frame_points, args.view.into(), args.size, args.size);
    canvas.draw_mesh(&head.positions, &head.triangles, |_| [0.86, 0.76, 0.68])?;
    if let Some(fitted) = fitted.as_ref().filter(|_| !args.no_mask) {
        let slack = 0.004 * head.bounds().size().length();
        crate::render::draw_fitted_mask(&mut canvas, fitted, &fitted.neutral, slack);
        if args.anchors {
            let anchors = anchor_mask(&head, &fitted.neutral, fitted.fit.mm_per_unit);
            for &j in &crate::mask::LIP_VERTICES {
                let color = if crate::mask::LOWER_LIP.contains(&j) {
                    [240, 160, 0]
                } else {
                    [0, 170, 60]
                };
                canvas.draw_dot(
                    head.positions[anchors.vertex[j] as usize],
                    2.0,
                    Ink::opaque(color),
                    slack,
                );
            }
        }
    }
    let file =
        std::fs::File::create(&args.out).map_err(|e| format!("cannot create {}: {e}", args.out.display()))?;
    canvas.write_png(BufWriter::new(file))?;
    println!("wrote {}", args.out.display());
    Ok(())
}
