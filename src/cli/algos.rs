//! `facewire algos`: every interpolation variant with its preset letter, canonical spec,
//! one-line description and whether it is linear in the control displacements.

use serde::Serialize;

use super::{print_json, CliResult};
use crate::deform::AlgoSpec;

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Serialize)]
struct Row {
    letter: char,
    name: &'static str,
    spec: String,
    linear: bool,
    description: &'static str,
}

pub fn run(args: Args) -> CliResult {
    let rows: Vec<Row> = AlgoSpec::presets()
        .into_iter()
        .map(|(letter, spec, description)| Row {
            letter,
            name: spec.name(),
            spec: spec.to_string(),
            linear: spec.is_linear(),
            description,
        })
        .collect();
    if args.json {
        return print_json(&rows);
    }
    println!("{:<3} {:<58} {:<7} description", "", "spec", "linear");
    for r in &rows {
        println!(
            "{:<3} {:<58} {:<7} {}",
            r.letter,
            r.spec,
            if r.linear { "yes" } else { "no" },
            r.description
        );
    }
    println!();
    println!("Any spec can be written short (`bary2:r_mm=10`) or as its letter (`C`).");
    println!("Weight systems: none, distance (r_mm, local), planar_bones (r_pct, n), kshirsagar (r_mm, geometric only).");
    println!("point_distance: k=N|all, local, interpolate=true|false (false: the thesis's G and H).");
    println!("rbf: kernel=gaussian|multiquadric|inverse_multiquadric|thin_plate|wendland, distance=euclidean|surface, r_mm, poly=linear|none.");
    Ok(())
}
