//! `facewire inspect`: what a file holds and what is wrong with it, for people (text) and
//! scripts (`--json`). The kind of file is told by its name.

use serde::Serialize;

use super::{has_suffix, load_glb, load_head, load_mask, print_json, CliResult, FilePath};
use crate::deform::Registration;
use crate::fit::{anchor_mask, residuals, FitFile, FittedMask, Landmarks};
use crate::head::glb_parts::role_by_name;
use crate::head::{glb_head, Bounds, Problem};
use crate::mask::{FapuValues, Mask, UnitKind};
use crate::stream::summary::ChannelKind;
use crate::stream::{open_stream, summarize, ArkitTargets, StreamFormat};
use crate::targets::ExpressionTarget;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// A .wfm, .obj, .glb, .fit.toml or .landmarks.toml file, or a parameter stream (.jsonl, .fap,
    /// .fau, .txt).
    file: FilePath,
    /// With a .fit.toml or .landmarks.toml: the head it belongs to, to report residuals or
    /// check head vertices (default: the `head` named in the file, next to it).
    #[arg(long)]
    head: Option<FilePath>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> CliResult {
    let path = &args.file;
    if has_suffix(path, ".wfm") {
        mask_report(path, args.json)
    } else if has_suffix(path, ".obj") {
        head_report(path, args.json)
    } else if has_suffix(path, ".glb") {
        glb_report(path, args.json)
    } else if has_suffix(path, ".fit.toml") {
        fit_report(path, args.head.as_ref(), args.json)
    } else if has_suffix(path, ".landmarks.toml") {
        landmarks_report(path, args.head.as_ref(), args.json)
    } else if StreamFormat::from_path(path).is_ok() {
        stream_report(path, args.json)
    } else {
        Err(format!(
            "{}: unknown kind of file; expected .wfm, .obj, .glb, .fit.toml, .landmarks.toml, .jsonl, .fap, .fau or .txt",
            path.display()
        )
        .into())
    }
}

#[derive(Serialize)]
struct UnitSummary {
    index: usize,
    key: String,
    title: String,
    kind: String,
    vertices: usize,
}

#[derive(Serialize)]
struct MaskSummary {
    units: &'static str,
    vertices: usize,
    triangles: usize,
    unused_vertices: Vec<usize>,
    bounds: Bounds,
    fapu: FapuValues,
    animation_units: Vec<UnitSummary>,
    shape_units: Vec<UnitSummary>,
    animation_params: usize,
    shape_params: usize,
    texture_coordinates: usize,
}

fn unit_summaries(units: &[crate::mask::Unit]) -> Vec<UnitSummary> {
    units
        .iter()
        .enumerate()
        .map(|(index, u)| UnitSummary {
            index,
            key: u.key.clone(),
            title: u.title.clone(),
            kind: match &u.kind {
                UnitKind::Auv { auv } => format!("AUV{auv}"),
                UnitKind::Fap { fap, fapu, .. } => format!("FAP{fap} ({})", fapu.name()),
                UnitKind::Other => "other".into(),
                UnitKind::Shape => "shape".into(),
            },
            vertices: u.displacements.len(),
        })
        .collect()
}

fn mask_report(path: &std::path::Path, json: bool) -> CliResult {
    let mask = Mask::load(path)?;
    let used = mask.used_vertices();
    let summary = MaskSummary {
        units: "mask units (CANDIDE model frame: +x face's left, +y up, +z out of the face)",
        vertices: mask.vertices.len(),
        triangles: mask.triangles.len(),
        unused_vertices: (0..used.len()).filter(|&v| !used[v]).collect(),
        bounds: Bounds::of(&mask.vertices),
        fapu: FapuValues::measure(&mask.vertices),
        animation_units: unit_summaries(&mask.animation_units),
        shape_units: unit_summaries(&mask.shape_units),
        animation_params: mask.animation_params.len(),
        shape_params: mask.shape_params.len(),
        texture_coordinates: mask.texture.len(),
    };
    if json {
        return print_json(&summary);
    }
    println!("{}: CANDIDE-3 mask", path.display());
    println!(
        "  {} vertices ({} used by no triangle: {:?}), {} triangles",
        summary.vertices,
        summary.unused_vertices.len(),
        summary.unused_vertices,
        summary.triangles
    );
    let auvs = mask
        .animation_units
        .iter()
        .filter(|u| matches!(u.kind, UnitKind::Auv { .. }))
        .count();
    println!(
        "  {} animation units ({auvs} AUVs, {} FAPs), {} shape units",
        summary.animation_units.len(),
        summary.animation_units.len() - auvs,
        summary.shape_units.len()
    );
    println!(
        "  bounds (mask units): min {:?} max {:?}",
        summary.bounds.min.to_array(),
        summary.bounds.max.to_array()
    );
    let f = summary.fapu;
    println!(
        "  FAPU0 (mask units): MNS {:.4} MW {:.4} ENS {:.4} ES {:.4} IRISD {:.4}",
        f.mns, f.mw, f.ens, f.es, f.irisd
    );
    println!(
        "  parameters: {} animation, {} shape; {} texture coordinates",
        summary.animation_params, summary.shape_params, summary.texture_coordinates
    );
    println!("  animation units (index key: kind, vertices):");
    for u in &summary.animation_units {
        println!("    {:>2} {:<28} {:<12} {}", u.index, u.key, u.kind, u.vertices);
    }
    println!("  shape units:");
    for u in &summary.shape_units {
        println!("    {:>2} {:<28} {}", u.index, u.key, u.vertices);
    }
    Ok(())
}

#[derive(Serialize)]
struct HeadSummary {
    units: &'static str,
    vertices: usize,
    triangles: usize,
    edges: usize,
    boundary_edges: usize,
    boundary_loops: usize,
    bounds: Bounds,
    problems: Vec<Problem>,
}

#[derive(Serialize)]
struct GlbMeshSummary {
    name: String,
    names: Vec<String>,
    materials: Vec<String>,
    /// What a registration takes it for: skin, skull, jaw, tongue, eyes, part (its row
    /// inferred) or none.
    role: String,
    file_vertices: usize,
    vertices: usize,
    triangles: usize,
    morph_targets: Vec<String>,
    /// The ARKit blendshapes its morph targets make (a skin's drive ARKit streams on it).
    arkit_blendshapes: Vec<String>,
    skinned: bool,
}

#[derive(Serialize)]
struct GlbSummary {
    units: &'static str,
    meshes: Vec<GlbMeshSummary>,
    /// Why a registration would refuse the file as it is (no skin found, two, too many
    /// parts), if it would.
    refused: Option<String>,
}

/// A glTF avatar as a registration would read it: each mesh, what its names make it, its
/// vertices in the file and welded.
fn glb_report(path: &std::path::Path, json: bool) -> CliResult {
    let meshes = load_glb(path)?;
    let summary = GlbSummary {
        units: "metres (glTF's unit: 1000 mm per unit)",
        meshes: meshes
            .iter()
            .map(|m| GlbMeshSummary {
                name: m.name.clone(),
                names: m.names.clone(),
                materials: m.materials.clone(),
                role: role_by_name(m).to_string(),
                file_vertices: m.welded.len(),
                vertices: m.positions.len(),
                triangles: m.triangles.len(),
                morph_targets: m.targets.iter().map(|t| t.name.clone()).collect(),
                arkit_blendshapes: ArkitTargets::sort(
                    m.targets
                        .iter()
                        .map(|t| ExpressionTarget::from_displacements(&t.name, t.offsets.clone()))
                        .collect(),
                )
                .chosen
                .into_iter()
                .map(|t| t.name)
                .collect(),
                skinned: m.skinned,
            })
            .collect(),
        refused: glb_head(meshes, &[]).err().map(|e| e.to_string()),
    };
    if json {
        return print_json(&summary);
    }
    println!("{}: glTF binary, {}", path.display(), summary.units);
    for m in &summary.meshes {
        println!(
            "  {:<24} {:<6} {} vertices ({} in the file), {} triangles, {} morph targets{}{}",
            m.name,
            m.role,
            m.vertices,
            m.file_vertices,
            m.triangles,
            m.morph_targets.len(),
            match m.arkit_blendshapes.len() {
                0 => String::new(),
                n => format!(" ({n} ARKit blendshapes)"),
            },
            if m.skinned { ", skinned" } else { "" }
        );
    }
    match &summary.refused {
        Some(why) => println!("a registration would refuse it: {why}"),
        None => println!("registers as it is (POST /v1/heads?id=..., Content-Type: model/gltf-binary)"),
    }
    Ok(())
}

fn head_report(path: &std::path::Path, json: bool) -> CliResult {
    let head = load_head(path)?;
    let summary = HeadSummary {
        units: "head units (as stored in the file)",
        vertices: head.positions.len(),
        triangles: head.triangles.len(),
        edges: head.topology.edges.len(),
        boundary_edges: head.topology.boundary_edge_count(),
        boundary_loops: head.topology.boundary_loops.len(),
        bounds: head.bounds(),
        problems: head.problems.clone(),
    };
    if json {
        return print_json(&summary);
    }
    println!("{}: head mesh", path.display());
    println!(
        "  {} vertices, {} triangles, {} edges",
        summary.vertices, summary.triangles, summary.edges
    );
    println!(
        "  {} boundary edges in {} loop(s)",
        summary.boundary_edges, summary.boundary_loops
    );
    let b = summary.bounds;
    println!(
        "  bounds (head units): min {:?} max {:?} size {:?}",
        b.min.to_array(),
        b.max.to_array(),
        b.size().to_array()
    );
    if summary.problems.is_empty() {
        println!("  problems: none");
    } else {
        println!("  problems:");
        for p in &summary.problems {
            println!("    {p}");
        }
    }
    Ok(())
}

/// The head a fit or landmarks file belongs to: `--head`, else its `head` field resolved
/// next to the file.
fn head_path(path: &std::path::Path, head_arg: Option<&FilePath>, named: Option<&str>) -> Option<FilePath> {
    head_arg.cloned().or_else(|| {
        let name = named?;
        Some(path.parent().unwrap_or(std::path::Path::new(".")).join(name))
    })
}

/// A landmarks file, validated as `facewire fit` and the service validate it: against the
/// CANDIDE-3 mask, and against its head when that is at hand.
fn landmarks_report(path: &std::path::Path, head_arg: Option<&FilePath>, json: bool) -> CliResult {
    let mask = load_mask(None)?;
    let landmarks = Landmarks::load(path)?;
    let origin = path.display().to_string();
    let head_path = head_path(path, head_arg, landmarks.head.as_deref());
    let checked_against = match &head_path {
        Some(hp) if hp.exists() => {
            let head = load_head(hp)?;
            landmarks.validate(&origin, mask.vertices.len(), head.positions.len())?;
            Some(hp.display().to_string())
        }
        _ => {
            landmarks.validate_without_head(&origin, mask.vertices.len())?;
            None
        }
    };
    if json {
        return print_json(&landmarks);
    }
    println!("{}: {} landmarks", path.display(), landmarks.landmarks.len());
    match checked_against {
        Some(head) => println!("  valid for the CANDIDE-3 mask and {head}"),
        None => println!("  valid for the CANDIDE-3 mask; head vertices not checked (no head found)"),
    }
    for l in &landmarks.landmarks {
        println!(
            "  mask vertex {:>3} -> head vertex {:>6}  {}",
            l.mask_vertex,
            l.head_vertex,
            l.name.as_deref().unwrap_or("")
        );
    }
    Ok(())
}

#[derive(Serialize)]
struct FitSummary {
    fit: FitFile,
    mm_per_unit: f32,
    mm_per_unit_derived: bool,
    mm_per_mask_unit: f32,
    fitted_bounds: Bounds,
    head: Option<String>,
    residuals: Option<residuals::Residuals>,
    /// Inner-lip midpoint anchors (mask 87 and 40): distance in space and along the surface, mm.
    inner_lip_anchor_gap_mm: Option<[f32; 2]>,
}

fn fit_report(path: &std::path::Path, head_arg: Option<&FilePath>, json: bool) -> CliResult {
    let mask = load_mask(None)?;
    let file = FitFile::load(path)?;
    let fit = file.resolve(&path.display().to_string(), &mask)?;
    let fitted = FittedMask::new(mask.clone(), fit.clone());
    let head_path = head_path(path, head_arg, file.head.as_deref());
    let (residuals, gap) = match &head_path {
        Some(hp) if hp.exists() => {
            let head = load_head(hp)?;
            // Refused here as the service refuses it: the same checks.
            Registration::check(&head, &fitted)?;
            let r = residuals::measure(
                &head,
                &fitted.neutral,
                &mask.used_vertices(),
                &[],
                fit.mm_per_unit,
            );
            let anchors = anchor_mask(&head, &fitted.neutral, fit.mm_per_unit);
            let (up, low) = (
                anchors.vertex[crate::mask::INNER_LIP_MID_UPPER],
                anchors.vertex[crate::mask::INNER_LIP_MID_LOWER],
            );
            let space = head.positions[up as usize].distance(head.positions[low as usize]) * fit.mm_per_unit;
            let mut sd = crate::head::SurfaceDistance::new(head.positions.len());
            sd.run(&head.topology, &[(up, 0.0)], f32::INFINITY);
            (Some(r), Some([space, sd.distance(low) * fit.mm_per_unit]))
        }
        _ => (None, None),
    };
    let summary = FitSummary {
        mm_per_unit: fit.mm_per_unit,
        mm_per_unit_derived: file.mm_per_unit.is_none(),
        mm_per_mask_unit: fitted.mm_per_mask_unit(),
        fitted_bounds: Bounds::of(&fitted.neutral),
        head: head_path.map(|p| p.display().to_string()),
        residuals,
        inner_lip_anchor_gap_mm: gap,
        fit: file,
    };
    if json {
        return print_json(&summary);
    }
    let f = &summary.fit;
    println!("{}: fit of the CANDIDE-3 mask", path.display());
    println!(
        "  rotation {:?} deg, scale {} head units per mask unit, translation {:?} head units",
        f.rotation_deg, f.scale, f.translation
    );
    println!(
        "  {} mm per head unit ({}), {:.2} mm per mask unit",
        summary.mm_per_unit,
        if summary.mm_per_unit_derived {
            "derived from 63 mm pupils"
        } else {
            "given"
        },
        summary.mm_per_mask_unit
    );
    println!(
        "  shape units: {}",
        if f.shape_units.is_empty() {
            "none".to_string()
        } else {
            f.shape_units
                .iter()
                .map(|(k, v)| format!("{k}={v:.3}"))
                .collect::<Vec<_>>()
                .join(" ")
        }
    );
    println!("  nudges: {}", f.nudges.len());
    let b = summary.fitted_bounds;
    println!(
        "  fitted mask bounds (head units): min {:?} max {:?}",
        b.min.to_array(),
        b.max.to_array()
    );
    if let (Some(head), Some(r)) = (&summary.head, &summary.residuals) {
        println!(
            "  against {head}: mask vertices to surface mean {:.2} mm, max {:.2} mm (vertex {})",
            r.surface.mean_mm, r.surface.max_mm, r.surface.worst_mask_vertex
        );
    }
    if let Some([space, surface]) = summary.inner_lip_anchor_gap_mm {
        println!("  inner-lip midpoint anchors (87, 40): {space:.2} mm apart in space, {surface:.1} mm along the surface");
    }
    Ok(())
}

/// A parameter stream, read once: frames, rate, duration, the range of every channel
/// (animation units by key) and the labels.
fn stream_report(path: &std::path::Path, json: bool) -> CliResult {
    let mask = load_mask(None)?;
    let mut summary = summarize(open_stream(path, &mask)?).map_err(|error| {
        // `.txt` is the one extension that other text files share: say what was assumed.
        let plain_txt = has_suffix(path, ".txt") && !has_suffix(path, ".au.txt");
        if plain_txt {
            format!("{error} (a .txt file is read as an AU text stream; anything else is an unknown kind of file)")
        } else {
            error.to_string()
        }
    })?;
    summary.name_animation_units(&mask);
    if json {
        return print_json(&summary);
    }
    println!("{}: parameter stream", path.display());
    let rate = summary.fps_estimate.map_or_else(
        || "no rate (zero duration)".to_string(),
        |fps| format!("{} fps", round3(fps)),
    );
    println!(
        "  {} frames at {rate}, {} s ({} to {} s)",
        summary.frames,
        round3(summary.duration_s),
        summary.first_time_s.map_or(0.0, round3),
        summary.last_time_s.map_or(0.0, round3)
    );
    if summary.frames_with_controls > 0 {
        println!(
            "  {} frames carry raw control displacements",
            summary.frames_with_controls
        );
    }
    if summary.channels.is_empty() {
        println!("  channels: none (every frame at rest)");
    } else {
        println!("  channels (kind, name: min .. max, frames):");
    }
    for channel in &summary.channels {
        let kind = match channel.kind {
            ChannelKind::Animation => "animation",
            ChannelKind::Fap => "fap",
            ChannelKind::Arkit => "arkit",
            ChannelKind::HeadRotationRad => "head_rotation_rad",
            ChannelKind::HeadTranslation => "head_translation",
        };
        let name = channel
            .name
            .clone()
            .unwrap_or_else(|| format!("#{}", channel.index));
        println!(
            "    {kind:<17} {name:<28} {} .. {}  ({} frames)",
            channel.min, channel.max, channel.frames
        );
    }
    if !summary.labels.is_empty() {
        let labels: Vec<String> = summary
            .labels
            .iter()
            .map(|l| format!("{} ({})", l.label, l.frames))
            .collect();
        println!("  {} labels (frames): {}", labels.len(), labels.join(" "));
    }
    Ok(())
}

/// Rounded to 3 decimals for display (25.000000001 fps prints as 25).
fn round3(x: f64) -> f64 {
    (x * 1000.0).round() / 1000.0
}
